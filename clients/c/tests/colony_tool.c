/* The C side of the tests against the real hub (crates/colony/tests/c_client.rs
 * runs it). Each command is a small program an application could be:
 *
 *   colony_tool sub HUB SECONDS SUBJECT...      print what arrives, one line each
 *   colony_tool pub HUB SUBJECTS PRIO COUNT EVERY_MS LINE...   publish COUNT times
 *   colony_tool console HUB KEYFILE VALUE SECONDS   raise the minimum priority, signed
 *   colony_tool sign KEYFILE N                  sign stdin's packet with counter N
 *
 * `sub` prints `lease` once the hub has granted one, `packet <subjects> PRIO ::
 * LINE ;; LINE` for each packet and `error KIND LINE COLUMN` for each datagram
 * that did not parse. Output is flushed line by line for the test to follow.
 */
#define _POSIX_C_SOURCE 200809L
#include "colony.h"

#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int usage(void)
{
    fprintf(stderr, "usage: colony_tool sub|pub|console|sign ... (see tests/colony_tool.c)\n");
    return 2;
}

/* Waits for the socket until the client's deadline, at most `cap_ms`. */
static void wait_for(colony_client *c, int64_t cap_ms)
{
    int64_t now = colony_now_ms(), deadline = colony_deadline(c), wait = cap_ms;
    if (deadline >= 0 && deadline - now < wait) wait = deadline > now ? deadline - now : 0;
    struct pollfd pfd = {colony_fd(c), POLLIN, 0};
    poll(&pfd, 1, (int)wait);
}

static void print_packet(const colony_packet *p)
{
    colony_line l;
    memset(&l, 0, sizeof l);
    printf("packet %.*s %ld ::", (int)p->subjects.len, p->subjects.ptr, (long)p->priority);
    const char *sep = " ";
    while (colony_next_line(p, &l)) {
        printf("%s%.*s%.*s", sep, (int)l.label.len, l.label.ptr, (int)l.fields.len, l.fields.ptr);
        sep = " ;; ";
    }
    printf("\n");
}

/* A key file of any length (up to 64 KB here) handed to the client. */
static int load_key(colony_client *c, const char *path)
{
    static unsigned char key[1 << 16];
    FILE *f = fopen(path, "rb");
    if (!f) return perror(path), 0;
    size_t len = fread(key, 1, sizeof key, f);
    fclose(f);
    if (colony_set_key(c, key, len) == COLONY_OK) return 1;
    fprintf(stderr, "bad key in %s\n", path);
    return 0;
}

/* Signs everything the client sends when COLONY_KEY_FILE names the hub's key. */
static int key_from_env(colony_client *c)
{
    const char *file = getenv("COLONY_KEY_FILE");
    return !file || load_key(c, file);
}

/* Seconds from the command line as a span of milliseconds: refused when not
 * a number from 0 to a year (a cast of a huge or NaN double is undefined). */
static int ms_from_seconds(const char *text, int64_t *ms)
{
    char *end;
    double s = strtod(text, &end);
    if (end == text || *end != 0 || !(s >= 0 && s <= 365.0 * 86400)) {
        fprintf(stderr, "not a number of seconds: %s\n", text);
        return 0;
    }
    *ms = (int64_t)(s * 1000);
    return 1;
}

static int sub(const char *hub, const char *seconds, char **subjects, int n)
{
    static colony_client c;
    int64_t start = colony_now_ms(), end;
    if (!ms_from_seconds(seconds, &end)) return 2;
    end += start;
    if (colony_connect(&c, hub, start) != COLONY_OK) return perror("connect"), 1;
    if (!key_from_env(&c)) return 1;
    for (int i = 0; i < n; i++)
        if (colony_subscribe(&c, subjects[i], start) != COLONY_OK) return fprintf(stderr, "subscribe %s\n", subjects[i]), 1;
    uint64_t leases = 0;
    while (colony_now_ms() < end) {
        wait_for(&c, 50);
        int64_t now = colony_now_ms();
        colony_poll(&c, now);
        colony_packet p;
        colony_error e;
        colony_status st;
        while ((st = colony_recv(&c, &p, &e, now)) != COLONY_AGAIN) {
            if (st == COLONY_OK) print_packet(&p);
            else if (st == COLONY_SYSTEM) perror("recv");
            else printf("error %s %u %u\n", colony_status_name(st), e.line, e.column);
        }
        if (c.leases > leases && leases == 0) printf("lease %lld\n", (long long)c.lease_ms);
        leases = c.leases;
        fflush(stdout);
    }
    colony_close(&c);
    return 0;
}

static int pub(const char *hub, const char *subjects, int prio, int count, int every_ms,
               char **lines, int n)
{
    static colony_client c;
    static char buf[COLONY_MAX_PACKET + 1];
    if (colony_connect(&c, hub, colony_now_ms()) != COLONY_OK) return perror("connect"), 1;
    if (!key_from_env(&c)) return 1;
    colony_builder b;
    colony_begin(&b, buf, sizeof buf, subjects, prio);
    for (int i = 0; i < n; i++) colony_putf(&b, "%s\n", lines[i]);
    colony_error e;
    size_t len = colony_finish(&b, &e);
    if (len == 0) {
        fprintf(stderr, "not a packet: %s at line %u, column %u\n", colony_status_name(e.status),
                e.line, e.column);
        return 1;
    }
    for (int i = 0; i < count; i++) {
        if (colony_publish(&c, buf, len, &e) != COLONY_OK) return perror("publish"), 1;
        if (i + 1 < count) poll(NULL, 0, every_ms);
    }
    colony_close(&c);
    return 0;
}

/* A console's override, signed: raises the hub's minimum priority, then asks
 * for status until the report shows it. Status is answered only to a client
 * holding a lease, so it subscribes to a channel of its own. */
static int console(const char *hub, const char *key_file, int value, const char *seconds)
{
    static colony_client c;
    int64_t now = colony_now_ms(), end, asked = 0;
    if (!ms_from_seconds(seconds, &end)) return 2;
    end += now;
    if (colony_connect(&c, hub, now) != COLONY_OK) return perror("connect"), 1;
    if (!load_key(&c, key_file)) return 1;
    colony_subscribe(&c, "c-console", now);
    colony_set_min_priority(&c, value, now);
    while ((now = colony_now_ms()) < end) {
        if (now - asked > 300) {
            colony_request(&c, "status\n", now);
            asked = now;
        }
        wait_for(&c, 50);
        now = colony_now_ms();
        colony_poll(&c, now);
        colony_packet p;
        colony_line l;
        int64_t min = 0;
        while (colony_recv(&c, &p, NULL, now) == COLONY_OK) {
            memset(&l, 0, sizeof l);
            if (colony_has_subject(&p, "hub") && colony_find_line(&p, "status", &l) &&
                colony_get_i64(l.fields, "min_priority", &min) == COLONY_OK && min == value) {
                printf("min_priority %d\n", value);
                return 0;
            }
        }
    }
    fprintf(stderr, "the hub never reported min_priority %d\n", value);
    return 1;
}

static int sign(const char *key_file, const char *n)
{
    static char buf[COLONY_MAX_PACKET + 1];
    size_t len = fread(buf, 1, sizeof buf - 128, stdin);
    static colony_client c; /* for the key's trimming (and hashing) rule */
    if (!load_key(&c, key_file)) return 1;
    if (colony_sign(buf, &len, sizeof buf, c.key, c.key_len, strtoull(n, NULL, 10)) != COLONY_OK)
        return 1;
    fwrite(buf, 1, len, stdout);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc >= 5 && strcmp(argv[1], "sub") == 0)
        return sub(argv[2], argv[3], argv + 4, argc - 4);
    if (argc >= 8 && strcmp(argv[1], "pub") == 0)
        return pub(argv[2], argv[3], atoi(argv[4]), atoi(argv[5]), atoi(argv[6]), argv + 7, argc - 7);
    if (argc == 6 && strcmp(argv[1], "console") == 0)
        return console(argv[2], argv[3], atoi(argv[4]), argv[5]);
    if (argc == 4 && strcmp(argv[1], "sign") == 0) return sign(argv[2], argv[3]);
    return usage();
}
