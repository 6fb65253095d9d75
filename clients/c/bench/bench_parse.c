/* Parse throughput of the C client on one packet file, measured the way
 * crates/wire/examples/parse_throughput.rs measures the Rust parser, so the two
 * figures in BENCHMARKS.md compare like with like:
 *
 *   make -C clients/c bench && clients/c/build/bench_parse clients/c/bench/vision.txt
 *
 * Each of 11 rounds runs one operation for about 0.3 s; the best and the
 * median round's time per packet are printed (the best is the one a busy
 * machine disturbs least). "parse" checks the whole packet (what
 * colony_recv does to every datagram); "parse+read" also walks every line and
 * field and reads every bare value as a number. */
#define _POSIX_C_SOURCE 200809L
#include "colony.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static char data[COLONY_MAX_PACKET + 1];
static size_t len;
static volatile double sink;

static double seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + (double)t.tv_nsec / 1e9;
}

static void parse_only(void)
{
    colony_packet p;
    if (colony_parse(&p, data, len, NULL) != COLONY_OK) abort();
    sink += (double)p.priority;
}

static void parse_and_read(void)
{
    colony_packet p;
    colony_line l;
    colony_field f;
    double v, sum = 0;
    if (colony_parse(&p, data, len, NULL) != COLONY_OK) abort();
    memset(&l, 0, sizeof l);
    while (colony_next_line(&p, &l)) {
        colony_span fields = l.fields;
        while (colony_next_field(&fields, &f))
            if (colony_field_f64(&f, &v) == COLONY_OK) sum += v;
    }
    sink += sum;
}

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void measure(const char *name, void (*op)(void))
{
    double per[11];
    for (int r = 0; r < 11; r++) {
        long n = 0;
        double start = seconds(), now;
        do {
            for (int i = 0; i < 1000; i++) op();
            n += 1000;
        } while ((now = seconds()) - start < 0.3);
        per[r] = (now - start) / (double)n;
    }
    qsort(per, 11, sizeof per[0], cmp);
    printf("C     %-10s %5zu bytes  best %7.3f us %7.1f MiB/s  median %7.3f us %7.1f MiB/s\n",
           name, len, per[0] * 1e6, (double)len / per[0] / 1048576.0, per[5] * 1e6,
           (double)len / per[5] / 1048576.0);
}

int main(int argc, char **argv)
{
    FILE *f = argc == 2 ? fopen(argv[1], "rb") : NULL;
    if (!f) {
        fprintf(stderr, "usage: bench_parse PACKET_FILE\n");
        return 2;
    }
    len = fread(data, 1, sizeof data, f);
    fclose(f);
    measure("parse", parse_only);
    measure("parse+read", parse_and_read);
    return 0;
}
