/* The C client's parser under a fuzzer: parses arbitrary bytes, then reads
 * everything out of whatever parses (subjects, lines, fields, nested groups,
 * every getter) and writes it back in canonical form, which must parse to the
 * same header and lines; colony_parse() and colony_parse_ws() must give one
 * verdict. Beyond not crashing (AddressSanitizer and
 * UndefinedBehaviorSanitizer watch every read), a failed check aborts.
 *
 * libFuzzer:  clang -fsanitize=fuzzer,address,undefined (make -C clients/c fuzz)
 * AFL++:      afl-clang-fast with this file and libAFLDriver
 * replay:     built with -DCOLONY_REPLAY, runs files and directories given as
 *             arguments (make -C clients/c fuzz-replay); --verdicts prints each
 *             file's verdict, for the differential test against the Rust parser.
 */
#include "../../clients/c/colony.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CHECK(cond)                                                                  \
    do {                                                                             \
        if (!(cond)) {                                                               \
            fprintf(stderr, "fuzz_packet: check failed at line %d: %s\n", __LINE__, #cond); \
            abort();                                                                 \
        }                                                                            \
    } while (0)

/* Canonical text can be longer than the packet (`a(b 1)` becomes `a (b 1)`). */
static char canon[3 * COLONY_MAX_PACKET];

static void write_fields(colony_builder *b, colony_span fields, unsigned depth)
{
    colony_field f;
    unsigned seen = 0;
    CHECK(depth <= COLONY_MAX_DEPTH);
    while (colony_next_field(&fields, &f)) {
        CHECK(f.name.len > 0);
        colony_putf(b, "%s%.*s ", b->buf[b->len - 1] == '(' ? "" : " ", (int)f.name.len, f.name.ptr);
        if (f.kind == COLONY_GROUP) {
            colony_putf(b, "(");
            write_fields(b, f.value, depth + 1);
            colony_putf(b, ")");
        } else if (f.kind == COLONY_QUOTED) {
            colony_putf(b, "\"%.*s\"", (int)f.value.len, f.value.ptr);
        } else {
            CHECK(f.value.len > 0);
            colony_putf(b, "%.*s", (int)f.value.len, f.value.ptr);
        }
        /* Getters on the first fields only: finding a field by name is a scan. */
        if (seen++ < 16) {
            char name[256], text[64];
            colony_field again;
            double d;
            int64_t i;
            colony_span g;
            if (f.name.len >= sizeof name) continue;
            memcpy(name, f.name.ptr, f.name.len);
            name[f.name.len] = 0;
            CHECK(colony_get(fields, name, &again) == COLONY_MISSING); /* names are unique */
            (void)colony_get_f64(fields, name, &d);
            (void)colony_get_i64(fields, name, &i);
            (void)colony_get_group(fields, name, &g);
            colony_status st = colony_unescape(&f, text, sizeof text);
            CHECK(st == COLONY_OK || st == COLONY_NO_SPACE || st == COLONY_WRONG_TYPE);
        }
    }
    for (size_t k = 0; k < fields.len; k++) CHECK(fields.ptr[k] == ' ' || fields.ptr[k] == '\t');
}

int LLVMFuzzerTestOneInput(const unsigned char *data, size_t size);
int LLVMFuzzerTestOneInput(const unsigned char *data, size_t size)
{
    static colony_workspace ws; /* the client's way: the table in a workspace */
    colony_packet p;
    colony_error e, e_ws;
    colony_status st = colony_parse(&p, data, size, &e);
    /* Both ways give one verdict; a table left dirty would show here later. */
    CHECK(colony_parse_ws(&p, data, size, &e_ws, &ws) == st);
    CHECK(st == COLONY_OK || (e_ws.line == e.line && e_ws.column == e.column));
    if (st != COLONY_OK) {
        CHECK(st >= COLONY_TOO_LARGE && st <= COLONY_TOO_DEEP && e.status == st);
        CHECK(e.line >= 1 && e.column >= 1);
        return 0;
    }
    colony_builder b = {canon, sizeof canon, 0, 0, COLONY_OK};
    colony_putf(&b, "@");
    size_t at = 0;
    unsigned subjects = 0, lines = 0;
    colony_span s;
    while (colony_next_subject(&p, &at, &s)) {
        CHECK(s.len >= 1 && s.len <= COLONY_MAX_SUBJECT_LEN);
        colony_putf(&b, " <%.*s>", (int)s.len, s.ptr);
        subjects++;
    }
    CHECK(subjects == p.subject_count);
    colony_putf(&b, " %ld\n", (long)p.priority);
    colony_line line;
    memset(&line, 0, sizeof line);
    while (colony_next_line(&p, &line)) {
        CHECK(line.label.len > 0 && line.number >= 2);
        colony_putf(&b, "%.*s", (int)line.label.len, line.label.ptr);
        write_fields(&b, line.fields, 0);
        colony_putf(&b, "\n");
        lines++;
    }
    CHECK(!b.failed);
    if (b.len <= COLONY_MAX_PACKET) {
        colony_packet again;
        CHECK(colony_parse(&again, canon, b.len, &e) == COLONY_OK);
        CHECK(again.subject_count == p.subject_count && again.priority == p.priority);
        unsigned n = 0;
        memset(&line, 0, sizeof line);
        while (colony_next_line(&again, &line)) n++;
        CHECK(n == lines);
    }
    return 0;
}

#ifdef COLONY_REPLAY
#include <dirent.h>

static int verdicts, failures, files;

/* A seed named `ok-*` must parse and `bad-<kind>*` fail with that kind. */
static void expect(const char *name, colony_status st)
{
    const char *want = NULL;
    if (strncmp(name, "ok-", 3) == 0) want = "ok";
    if (strncmp(name, "bad-", 4) == 0) want = name + 4;
    if (!want) return;
    const char *got = colony_status_name(st);
    size_t n = strlen(got);
    if (strncmp(want, got, n) != 0 || (want[n] != 0 && want[n] != '.' && want[n] != '-')) {
        fprintf(stderr, "fuzz_replay: %s: the parser says %s\n", name, got);
        failures++;
    }
}

static void replay_file(const char *path, const char *name)
{
    static unsigned char buf[4 << 20];
    FILE *f = fopen(path, "rb");
    if (!f) return;
    size_t n = fread(buf, 1, sizeof buf, f);
    fclose(f);
    files++;
    LLVMFuzzerTestOneInput(buf, n);
    colony_packet p;
    colony_error e;
    colony_status st = colony_parse(&p, buf, n, &e);
    expect(name, st);
    if (verdicts && st == COLONY_OK) printf("%s\tok\n", name);
    else if (verdicts) printf("%s\t%s %u %u\n", name, colony_status_name(st), e.line, e.column);
}

int main(int argc, char **argv)
{
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--verdicts") == 0) {
            verdicts = 1;
            continue;
        }
        DIR *d = opendir(argv[i]);
        if (!d) {
            const char *slash = strrchr(argv[i], '/');
            replay_file(argv[i], slash ? slash + 1 : argv[i]);
            continue;
        }
        struct dirent *ent;
        char path[4096];
        while ((ent = readdir(d)) != NULL) {
            if (ent->d_name[0] == '.') continue;
            snprintf(path, sizeof path, "%s/%s", argv[i], ent->d_name);
            replay_file(path, ent->d_name);
        }
        closedir(d);
    }
    fprintf(stderr, "fuzz_replay: %d files, %d named for a verdict they did not get\n", files,
            failures);
    return failures > 0 || files == 0;
}
#endif
