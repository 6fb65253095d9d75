/* What the C client does without a hub: SHA-256 and HMAC against published
 * vectors, the parser's verdicts and positions and its work on hostile
 * packets, walking a packet, the builder's round trips (in a comma locale
 * too), and the client's receive budget against a socket standing in for the
 * hub. Built with AddressSanitizer and UBSan. */
#define _POSIX_C_SOURCE 200809L
#include "colony.h"

#include <arpa/inet.h>
#include <locale.h>
#include <math.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

static int failures;

#define CHECK(cond)                                                           \
    do {                                                                      \
        if (!(cond)) {                                                        \
            fprintf(stderr, "%s:%d: failed: %s\n", __FILE__, __LINE__, #cond); \
            failures++;                                                       \
        }                                                                     \
    } while (0)

static void hex(const unsigned char *b, size_t n, char *out)
{
    for (size_t i = 0; i < n; i++) sprintf(out + 2 * i, "%02x", b[i]);
}

static void hmac_is(const void *key, size_t kn, const void *msg, size_t mn, const char *want)
{
    unsigned char mac[32];
    char got[65];
    colony_hmac_sha256(key, kn, msg, mn, mac);
    hex(mac, 32, got);
    if (strcmp(got, want) != 0) {
        fprintf(stderr, "hmac: got %s, want %s\n", got, want);
        failures++;
    }
}

static void sha256_and_hmac_match_published_vectors(void)
{
    unsigned char d[32], k[131], m[50];
    char got[65];
    colony_sha256("", 0, d);
    hex(d, 32, got);
    CHECK(strcmp(got, "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855") == 0);
    colony_sha256("abc", 3, d);
    hex(d, 32, got);
    CHECK(strcmp(got, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad") == 0);
    /* RFC 4231, test cases 1, 2, 3, 4, 6 and 7 (5 truncates the MAC). */
    memset(k, 0x0b, 20);
    hmac_is(k, 20, "Hi There", 8,
            "b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e9376c2e32cff7");
    hmac_is("Jefe", 4, "what do ya want for nothing?", 28,
            "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843");
    memset(k, 0xaa, 20);
    memset(m, 0xdd, 50);
    hmac_is(k, 20, m, 50, "773ea91e36800e46854db8ebd09181a72959098b3ef8c122d9635514ced565fe");
    for (int i = 0; i < 25; i++) k[i] = (unsigned char)(i + 1);
    memset(m, 0xcd, 50);
    hmac_is(k, 25, m, 50, "82558a389a443c0ea4cc819899f2083a85f0faa3e578f8077a2e3ff46729665b");
    memset(k, 0xaa, 131);
    const char *t6 = "Test Using Larger Than Block-Size Key - Hash Key First";
    hmac_is(k, 131, t6, strlen(t6),
            "60e431591ee0b67f0d8a26aacbf5b77f8e0bc6213728c5140546040f0ee37f54");
    const char *t7 = "This is a test using a larger than block-size key and a larger than "
                     "block-size data. The key needs to be hashed before being used by the HMAC "
                     "algorithm.";
    hmac_is(k, 131, t7, strlen(t7),
            "9b09ffa71b942fcb27635fbcd5b0e944bfdc63644f0713938a7f51535c3a35e2");
}

static void a_signed_packet_matches_an_independent_hmac(void)
{
    /* The MAC below is Python's hmac module over the same bytes. */
    const char *key = "0123456789abcdef-a-test-key";
    char buf[256] = "@ <hub> 0\nmin_priority value 5";
    size_t len = strlen(buf);
    CHECK(colony_sign(buf, &len, sizeof buf, key, strlen(key), 42) == COLONY_OK);
    CHECK(strncmp(buf, "@ <hub> 0\nmin_priority value 5\nauth n 42 mac ", 45) == 0);
    CHECK(strcmp(buf + 45, "066e4cfc96a82a7a45714af774766fbba07f8c0b7c29bb8406df28d005b1fef2\n") == 0);
    colony_packet p;
    CHECK(colony_parse(&p, buf, len, NULL) == COLONY_OK);
    CHECK(colony_sign(buf, &len, len + 10, key, strlen(key), 43) == COLONY_NO_SPACE);
}

static colony_error parse_error(const char *text)
{
    colony_packet p;
    colony_error e;
    colony_parse(&p, text, strlen(text), &e);
    return e;
}

#define REJECTS(text, st, l, c)                                                           \
    do {                                                                                  \
        colony_error e_ = parse_error(text);                                              \
        if (e_.status != (st) || e_.line != (l) || e_.column != (c)) {                    \
            fprintf(stderr, "%s:%d: %s at %u:%u, want %s at %u:%u\n", __FILE__, __LINE__, \
                    colony_status_name(e_.status), e_.line, e_.column,                    \
                    colony_status_name(st), (unsigned)(l), (unsigned)(c));                \
            failures++;                                                                   \
        }                                                                                 \
    } while (0)

static void malformed_packets_are_refused_with_their_place(void)
{
    REJECTS("", COLONY_EMPTY, 1, 1);
    REJECTS("hello", COLONY_BAD_HEADER, 1, 1);
    REJECTS("@<a> 0\n", COLONY_BAD_HEADER, 1, 2);
    REJECTS("@ <a b> 0\n", COLONY_BAD_SUBJECT, 1, 3);
    REJECTS("@ <a> <a> 0\n", COLONY_DUPLICATE_SUBJECT, 1, 7);
    REJECTS("@ <a> 2147483648\n", COLONY_BAD_PRIORITY, 1, 7);
    REJECTS("@ <a> 0\nx y\n", COLONY_MISSING_VALUE, 2, 3);
    REJECTS("@ <a> 0\nx y 1 y 2\n", COLONY_DUPLICATE_NAME, 2, 7);
    REJECTS("@ <a> 0\nx y (z 1\n", COLONY_UNCLOSED_GROUP, 2, 9);
    REJECTS("@ <a> 0\nx y 1)\n", COLONY_UNMATCHED_CLOSE, 2, 6);
    REJECTS("@ <a> 0\nx y \"abc\n", COLONY_UNTERMINATED_STRING, 2, 5);
    REJECTS("@ <a> 0\nx y \"a\\qb\"\n", COLONY_BAD_ESCAPE, 2, 7);
    REJECTS("@ <a> 0\n\"x\" y 1\n", COLONY_EXPECTED_LABEL, 2, 1);
    REJECTS("@ <a> 0\nx (y 1)\n", COLONY_EXPECTED_NAME, 2, 3);
    REJECTS("@ <a> 0\nx y\x01 1\n", COLONY_CONTROL_CHAR, 2, 4);
    REJECTS("@ <a> 0\nx y \xc0\x80\n", COLONY_NOT_UTF8, 2, 5);
    REJECTS("@ <a> 0\nx y \xed\xa0\x80\n", COLONY_NOT_UTF8, 2, 5);
    REJECTS("@ <a> 0\r\nx y 1\rz 2\n", COLONY_CONTROL_CHAR, 2, 6);
    char deep[256] = "@ <a> 0\nx";
    for (int i = 0; i < 33; i++) strcat(deep, " g (");
    REJECTS(deep, COLONY_TOO_DEEP, 2, 2 + 4 * 32 + 3);
}

static void a_line_of_thousands_of_names_is_checked_for_repeats(void)
{
    static char big[COLONY_MAX_PACKET + 1];
    size_t n = (size_t)sprintf(big, "@ <a> 0\nline");
    for (int i = 0; i < 5000; i++) n += (size_t)sprintf(big + n, " n%d 1", i);
    /* the same names again in a group, and after it on the line: both legal */
    n += (size_t)sprintf(big + n, " g (");
    for (int i = 0; i < 40; i++) n += (size_t)sprintf(big + n, " m%d 1", i);
    n += (size_t)sprintf(big + n, ") m0 2 m39 2\n");
    colony_packet p;
    colony_error e;
    CHECK(colony_parse(&p, big, n, &e) == COLONY_OK);
    n += (size_t)sprintf(big + n - 1, " n4999 2\n") - 1;
    CHECK(colony_parse(&p, big, n, &e) == COLONY_DUPLICATE_NAME && e.line == 2);
}

/* The shapes a hostile review found quadratic: the same 17 names in group
 * after group of one line, or on line after line, filling a packet. */
static size_t repeated_names_in_groups(char *buf)
{
    size_t n = (size_t)sprintf(buf, "@ <a> 0\nl");
    for (int g = 0; n < COLONY_MAX_PACKET - 80; g++) {
        n += (size_t)sprintf(buf + n, " g%d(", g);
        for (char c = 'A'; c <= 'Q'; c++) n += (size_t)sprintf(buf + n, "%c()", c);
        n += (size_t)sprintf(buf + n, ")");
    }
    return n + (size_t)sprintf(buf + n, "\n");
}

static size_t repeated_names_on_lines(char *buf)
{
    size_t n = (size_t)sprintf(buf, "@ <a> 0\n");
    while (n < COLONY_MAX_PACKET - 60) n += (size_t)sprintf(buf + n, "l A()B()C()D()E()F()G()H()I()J()K()L()M()N()O()P()Q()\n");
    return n;
}

/* The most names a packet holds, all in one line: the table's fullest. */
static size_t most_names_in_one_line(char *buf)
{
    size_t n = (size_t)sprintf(buf, "@ <a> 0\nl");
    for (int i = 0; n < COLONY_MAX_PACKET - 8; i++) n += (size_t)sprintf(buf + n, " %x()", i);
    return n + (size_t)sprintf(buf + n, "\n");
}

static void repeated_names_cost_linear_work(void)
{
    static char buf[COLONY_MAX_PACKET + 64];
    static colony_workspace ws; /* zeroed, as it must be before its first use */
    size_t (*shapes[])(char *) = {repeated_names_in_groups, repeated_names_on_lines,
                                  most_names_in_one_line};
    for (unsigned k = 0; k < 3; k++) {
        size_t n = shapes[k](buf);
        colony_packet p;
        colony_error e;
        CHECK(n <= COLONY_MAX_PACKET);
        CHECK(colony_parse_ws(&p, buf, n, &e, &ws) == COLONY_OK);
        /* Each name is looked up once; a few probes each on average, whatever
         * the packet. With tombstones the first two shapes took thousands. */
        uint64_t names = 0;
        for (size_t i = 0; i < n; i++) names += buf[i] == '(';
        if (ws.probes > 4 * names) {
            fprintf(stderr, "shape %u: %llu probes for %llu names\n", k,
                    (unsigned long long)ws.probes, (unsigned long long)names);
            failures++;
        }
        CHECK(colony_parse(&p, buf, n, &e) == COLONY_OK); /* the stack's table agrees */
        /* A repeat at the end is still found, and the table is left empty. */
        n += (size_t)sprintf(buf + n - 1, " %s()\n", k == 0 ? "g0" : k == 1 ? "Q" : "0") - 1;
        CHECK(colony_parse_ws(&p, buf, n, &e, &ws) == COLONY_DUPLICATE_NAME);
        CHECK(colony_parse(&p, buf, n, &e) == COLONY_DUPLICATE_NAME);
    }
    unsigned used = 0;
    for (unsigned i = 0; i < COLONY_TABLE_SLOTS; i++) used += ws.table[i] != 0;
    CHECK(used == 0);
}

/* 17 names in 80 bytes need the table; with a workspace, a thread with a
 * small stack parses them (the table on the stack was 64 KB). */
static void *parse_on_a_small_stack(void *arg)
{
    static colony_workspace ws;
    const char *text = "@ <a> 0\nl a 1 b 1 c 1 d 1 e 1 f 1 g 1 h 1 i 1 j 1 k 1 l 1 m 1 n 1 o 1 p 1 q 1\n";
    colony_packet p;
    *(colony_status *)arg = colony_parse_ws(&p, text, strlen(text), NULL, &ws);
    return NULL;
}

static void a_workspace_parses_on_a_small_stack(void)
{
    pthread_attr_t attr;
    pthread_t t;
    colony_status st = COLONY_SYSTEM;
    pthread_attr_init(&attr);
    pthread_attr_setstacksize(&attr, 64 * 1024);
    CHECK(pthread_create(&t, &attr, parse_on_a_small_stack, &st) == 0 && pthread_join(t, NULL) == 0);
    CHECK(st == COLONY_OK);
    pthread_attr_destroy(&attr);
}

static void fields_are_read_in_place(void)
{
    const char *text = "@ <vision_out> <b> -3\r\n\nball x 5.3 y -2.5\n"
                       "blue id 0 x 15.2 pose (xh 1.0 yh 0.0 deep (z 7))\n"
                       "note text \"kick \\\"off\\\"\\n\" n 9223372036854775807\n";
    colony_packet p;
    CHECK(colony_parse(&p, text, strlen(text), NULL) == COLONY_OK);
    CHECK(p.subject_count == 2 && p.priority == -3);
    CHECK(colony_has_subject(&p, "b") && !colony_has_subject(&p, "vision"));
    colony_line l;
    memset(&l, 0, sizeof l);
    double x = 0, y = 0;
    CHECK(colony_find_line(&p, "ball", &l) && l.number == 3);
    CHECK(colony_get_f64(l.fields, "x", &x) == COLONY_OK && x == 5.3);
    CHECK(colony_get_f64(l.fields, "y", &y) == COLONY_OK && y == -2.5);
    CHECK(colony_get_f64(l.fields, "z", &y) == COLONY_MISSING);
    colony_span pose, deep;
    CHECK(colony_find_line(&p, "blue", &l) && l.number == 4);
    CHECK(colony_get_group(l.fields, "pose", &pose) == COLONY_OK);
    CHECK(colony_get_group(pose, "deep", &deep) == COLONY_OK);
    int64_t z = 0;
    CHECK(colony_get_i64(deep, "z", &z) == COLONY_OK && z == 7);
    CHECK(colony_get_i64(l.fields, "pose", &z) == COLONY_WRONG_TYPE);
    char s[32];
    CHECK(colony_find_line(&p, "note", &l));
    CHECK(colony_get_str(l.fields, "text", s, sizeof s) == COLONY_OK);
    CHECK(strcmp(s, "kick \"off\"\n") == 0);
    CHECK(colony_get_str(l.fields, "text", s, 5) == COLONY_NO_SPACE && strcmp(s, "kick") == 0);
    CHECK(colony_get_i64(l.fields, "n", &z) == COLONY_OK && z == INT64_MAX);
    CHECK(colony_get_f64(l.fields, "text", &x) == COLONY_WRONG_TYPE);
    CHECK(!colony_find_line(&p, "note", &l));
}

static void strings_handed_back_are_always_terminated(void)
{
    const char *text = "@ <a> 0\nl t \"\xc3\xa9t\xc3\xa9\" g (x 1) b bare\n";
    colony_packet p;
    colony_line l;
    memset(&l, 0, sizeof l);
    char s[8];
    CHECK(colony_parse(&p, text, strlen(text), NULL) == COLONY_OK && colony_next_line(&p, &l));
    memset(s, 'x', sizeof s);
    CHECK(colony_get_str(l.fields, "t", s, 5) == COLONY_NO_SPACE && strcmp(s, "\xc3\xa9t") == 0);
    memset(s, 'x', sizeof s); /* "é" cut in half would not be UTF-8: cut before it */
    CHECK(colony_get_str(l.fields, "t", s, 2) == COLONY_NO_SPACE && s[0] == 0);
    memset(s, 'x', sizeof s);
    CHECK(colony_get_str(l.fields, "t", s, 1) == COLONY_NO_SPACE && s[0] == 0);
    memset(s, 'x', sizeof s);
    CHECK(colony_get_str(l.fields, "g", s, sizeof s) == COLONY_WRONG_TYPE && s[0] == 0);
    memset(s, 'x', sizeof s);
    CHECK(colony_get_str(l.fields, "none", s, sizeof s) == COLONY_MISSING && s[0] == 0);
    memset(s, 'x', sizeof s);
    CHECK(colony_get_str(l.fields, "b", s, 4) == COLONY_NO_SPACE && strcmp(s, "bar") == 0);
    CHECK(colony_get_str(l.fields, "b", s, 0) == COLONY_NO_SPACE && s[0] == 'b');
}

static void numbers_follow_rusts_grammar(void)
{
    const char *text = "@ <a> 0\nn a 1e5 b .5 c 5. d inf e -Infinity f NaN g 0x10 h 1e i +7 j - k 1_0\n";
    colony_packet p;
    colony_line l;
    memset(&l, 0, sizeof l);
    CHECK(colony_parse(&p, text, strlen(text), NULL) == COLONY_OK && colony_next_line(&p, &l));
    double v;
    int64_t i;
    CHECK(colony_get_f64(l.fields, "a", &v) == COLONY_OK && v == 1e5);
    CHECK(colony_get_f64(l.fields, "b", &v) == COLONY_OK && v == 0.5);
    CHECK(colony_get_f64(l.fields, "c", &v) == COLONY_OK && v == 5.0);
    CHECK(colony_get_f64(l.fields, "d", &v) == COLONY_OK && isinf(v) && v > 0);
    CHECK(colony_get_f64(l.fields, "e", &v) == COLONY_OK && isinf(v) && v < 0);
    CHECK(colony_get_f64(l.fields, "f", &v) == COLONY_OK && isnan(v));
    CHECK(colony_get_f64(l.fields, "g", &v) == COLONY_WRONG_TYPE);
    CHECK(colony_get_f64(l.fields, "h", &v) == COLONY_WRONG_TYPE);
    CHECK(colony_get_i64(l.fields, "i", &i) == COLONY_OK && i == 7);
    CHECK(colony_get_i64(l.fields, "j", &i) == COLONY_WRONG_TYPE);
    CHECK(colony_get_i64(l.fields, "k", &i) == COLONY_WRONG_TYPE);
}

static void decimals_read_as_strtod_reads_them(void)
{
    /* The fast path for short decimals against the C library's own reading. */
    unsigned long long x = 88172645463325252ull;
    int differ = 0;
    for (int i = 0; i < 200000; i++) {
        char text[40];
        x ^= x << 13, x ^= x >> 7, x ^= x << 17;
        int digits = 1 + (int)(x % 17), point = (int)((x >> 8) % (unsigned)(digits + 1));
        unsigned long long m = x >> 20;
        int n = sprintf(text, "%s", (x >> 5) & 1 ? "-" : "");
        for (int d = 0; d < digits; d++) {
            if (d == point) text[n++] = '.';
            text[n++] = (char)('0' + (m % 10));
            m /= 10;
        }
        text[n] = 0;
        colony_field f = {{"v", 1}, COLONY_BARE, {text, (size_t)n}};
        double got = 0;
        if (colony_field_f64(&f, &got) != COLONY_OK || got != strtod(text, NULL)) differ++;
    }
    CHECK(differ == 0);
}

/* Past 15 digits strtod reads the rewritten text; past 780, only whether the
 * rest is zero counts. Checked against strtod on the whole text (correctly
 * rounded in glibc), in the C locale, at lengths Rust reads and the old
 * 511-byte buffer refused. */
static void long_numbers_read_as_strtod_reads_them(void)
{
    static char text[4096];
    const char *cases[] = {"9007199254740993", "0.000000000000000000000000000001234567890123456789",
                           "123456789012345678901234567890e-40", "1e400", "-1e-400", "2.5E+2",
                           "0.0", "-0e5", "4.9406564584124654e-324", "1.7976931348623157e308"};
    for (unsigned k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        double got = 0;
        colony_field f = {{"v", 1}, COLONY_BARE, {cases[k], strlen(cases[k])}};
        CHECK(colony_field_f64(&f, &got) == COLONY_OK && got == strtod(cases[k], NULL));
    }
    /* 2^53 + 1 is halfway between two doubles: a 1 far beyond the 780th digit
     * decides it upward, zeros leave it to round to even. */
    for (int tail = 0; tail < 2; tail++) {
        size_t n = (size_t)sprintf(text, "9007199254740993.");
        while (n < 3000) text[n++] = '0';
        text[n++] = tail ? '1' : '0';
        text[n] = 0;
        double got = 0;
        colony_field f = {{"v", 1}, COLONY_BARE, {text, n}};
        CHECK(colony_field_f64(&f, &got) == COLONY_OK && got == strtod(text, NULL));
        CHECK(got == (tail ? 9007199254740994.0 : 9007199254740992.0));
    }
    unsigned long long x = 2463534242ull;
    int differ = 0;
    for (int i = 0; i < 2000; i++) {
        x ^= x << 13, x ^= x >> 7, x ^= x << 17;
        size_t digits = 1 + (size_t)(x % 2500), point = (size_t)((x >> 12) % (digits + 1)), n = 0;
        if (x & 1) text[n++] = '-';
        for (size_t d = 0; d < digits; d++) {
            x ^= x << 13, x ^= x >> 7, x ^= x << 17;
            if (d == point) text[n++] = '.';
            text[n++] = (char)('0' + (d > 20 && (x >> 3) % 4 ? 0 : x % 10));
        }
        if ((x >> 20) % 3 == 0) n += (size_t)sprintf(text + n, "e%d", (int)((x >> 24) % 700) - 350);
        text[n] = 0;
        double got = 0;
        colony_field f = {{"v", 1}, COLONY_BARE, {text, n}};
        double want = strtod(text, NULL);
        if (colony_field_f64(&f, &got) != COLONY_OK || memcmp(&got, &want, sizeof got) != 0) {
            if (differ++ < 3) fprintf(stderr, "long number read wrong: %.80s...\n", text);
        }
    }
    CHECK(differ == 0);
}

static void built_packets_read_back_exactly(void)
{
    char buf[512];
    colony_builder b;
    colony_begin(&b, buf, sizeof buf, "radio  robot.2", 10);
    colony_put_line(&b, "cmd");
    colony_put_int(&b, "id", 2);
    colony_put_f64(&b, "forward", 0.1);
    colony_put_f64(&b, "turn", -1);
    colony_put_f64(&b, "big", 1e300);
    colony_put_f64(&b, "odd", 0.1 + 0.2);
    colony_put_f64(&b, "nan", NAN);
    colony_put_f64(&b, "inf", -INFINITY);
    colony_put_open(&b, "pose");
    colony_put_f64(&b, "x", 1.5);
    colony_put_close(&b);
    colony_put_line(&b, "note");
    colony_put_text(&b, "text", "a \"b\"\\\n\t\x01");
    colony_put_bare(&b, "kind", "red");
    colony_putf(&b, " k %d", 3);
    colony_error e;
    size_t n = colony_finish(&b, &e);
    CHECK(n > 0);
    CHECK(strcmp(buf, "@ <radio> <robot.2> 10\n"
                      "cmd id 2 forward 0.1 turn -1.0 big 1e+300 odd 0.30000000000000004 nan NaN "
                      "inf -inf pose (x 1.5)\n"
                      "note text \"a \\\"b\\\"\\\\\\n\\t\xef\xbf\xbd\" kind red k 3\n") == 0);
    colony_packet p;
    colony_line l;
    memset(&l, 0, sizeof l);
    double v;
    char s[32];
    CHECK(colony_parse(&p, buf, n, NULL) == COLONY_OK && colony_find_line(&p, "cmd", &l));
    CHECK(colony_get_f64(l.fields, "odd", &v) == COLONY_OK && v == 0.1 + 0.2);
    CHECK(colony_find_line(&p, "note", &l));
    CHECK(colony_get_str(l.fields, "text", s, sizeof s) == COLONY_OK);
    CHECK(strcmp(s, "a \"b\"\\\n\t\xef\xbf\xbd") == 0);

    colony_begin(&b, buf, 16, "radio", 0);
    colony_put_line(&b, "cmd");
    colony_put_int(&b, "id", 12345);
    CHECK(colony_finish(&b, &e) == 0 && e.status == COLONY_NO_SPACE);
    colony_begin(&b, buf, sizeof buf, "radio", 0);
    colony_putf(&b, "cmd id 1 id 2");
    CHECK(colony_finish(&b, &e) == 0 && e.status == COLONY_DUPLICATE_NAME && e.line == 2);
    CHECK(b.len == 0 && buf[0] == 0);
}

/* What a full buffer leaves behind must not parse: `cmd id 1 ` would. */
static void a_failed_builder_leaves_nothing_to_send(void)
{
    char buf[24];
    colony_builder b;
    colony_error e;
    colony_packet p;
    colony_begin(&b, buf, sizeof buf, "radio", 0);
    colony_put_line(&b, "cmd");
    colony_put_int(&b, "id", 1);
    colony_put_int(&b, "speed", 12345);
    CHECK(b.failed == COLONY_NO_SPACE && b.len == 0 && buf[0] == 0);
    CHECK(colony_parse(&p, buf, strlen(buf), NULL) != COLONY_OK);
    colony_put_int(&b, "x", 1); /* does nothing */
    CHECK(b.len == 0 && colony_finish(&b, &e) == 0 && e.status == COLONY_NO_SPACE);
}

/* Labels, names and bare values are single tokens: user data cannot add a line. */
static void the_builder_refuses_tokens_that_would_inject(void)
{
    const char *bad[] = {"fast\nstop all 1", "id 9 x", "", "a\tb", "(", "x)", "\"q\"", "a\x7f", "a\rb"};
    char buf[256];
    colony_builder b;
    colony_error e;
    for (unsigned k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        for (int where = 0; where < 3; where++) {
            colony_begin(&b, buf, sizeof buf, "radio", 0);
            colony_put_line(&b, where == 0 ? bad[k] : "cmd");
            if (where == 1) colony_put_int(&b, bad[k], 2);
            if (where == 2) colony_put_bare(&b, "mode", bad[k]);
            CHECK(b.failed == COLONY_BAD_ARGUMENT && b.len == 0);
            CHECK(colony_finish(&b, &e) == 0 && e.status == COLONY_BAD_ARGUMENT);
        }
    }
    colony_begin(&b, buf, sizeof buf, "radio\n", 0);
    CHECK(b.failed == COLONY_BAD_ARGUMENT);
    colony_begin(&b, buf, sizeof buf, "radio", 0);
    colony_put_line(&b, "cmd");
    colony_put_bare(&b, "mode", "fast-#1/\xc3\xa9");
    CHECK(colony_finish(&b, &e) > 0);
}

/* Under a locale whose decimal point is a comma, numbers are still written
 * and read with ".". The locale comes from the system, or from the one the
 * Makefile builds with localedef beside this program. */
static void numbers_ignore_a_comma_locale(const char *argv0)
{
    const char *names[] = {"de_DE.UTF-8", "de_DE.utf8", "fr_FR.UTF-8", "de_DE", "fr_FR"};
    const char *got = NULL;
    for (unsigned k = 0; !got && k < sizeof names / sizeof names[0]; k++)
        got = setlocale(LC_NUMERIC, names[k]);
    if (!got) {
        char dir[4096];
        const char *slash = strrchr(argv0, '/');
        snprintf(dir, sizeof dir, "%.*s/locale", slash ? (int)(slash - argv0) : 1,
                 slash ? argv0 : ".");
        setenv("LOCPATH", dir, 1);
        got = setlocale(LC_NUMERIC, "de_DE.UTF-8");
    }
    if (!got || strcmp(localeconv()->decimal_point, ",") != 0) {
        fprintf(stderr, "test_unit: no comma locale (localedef found none to build): "
                        "numbers checked in the C locale only\n");
        setlocale(LC_NUMERIC, "C");
        return;
    }
    char buf[256], text[8];
    colony_builder b;
    colony_begin(&b, buf, sizeof buf, "radio", 0);
    colony_put_line(&b, "cmd");
    colony_put_f64(&b, "forward", 0.7);
    colony_put_f64(&b, "odd", 0.1 + 0.2);
    colony_put_f64(&b, "tiny", 1.5e-300);
    colony_put_f64(&b, "whole", 3);
    size_t n = colony_finish(&b, NULL);
    CHECK(n > 0 && strcmp(buf, "@ <radio> 0\ncmd forward 0.7 odd 0.30000000000000004 tiny 1.5e-300 "
                                "whole 3.0\n") == 0);
    snprintf(text, sizeof text, "%.1f", 1.5);
    CHECK(strcmp(text, "1,5") == 0); /* the locale is in force */
    const char *packet = "@ <a> 0\nl a 1.5e0 b 0.30000000000000004 c 1.5\n";
    colony_packet p;
    colony_line l;
    memset(&l, 0, sizeof l);
    double v = 0;
    CHECK(colony_parse(&p, packet, strlen(packet), NULL) == COLONY_OK && colony_next_line(&p, &l));
    CHECK(colony_get_f64(l.fields, "a", &v) == COLONY_OK && v == 1.5);
    CHECK(colony_get_f64(l.fields, "b", &v) == COLONY_OK && v == 0.1 + 0.2);
    CHECK(colony_get_f64(l.fields, "c", &v) == COLONY_OK && v == 1.5);
    setlocale(LC_NUMERIC, "C");
}

/* A socket on loopback stands in for the hub: the client is connected to it,
 * so what it sends reaches the client as if from the hub. */
static int fake_hub(colony_client *c, struct sockaddr_in *client)
{
    struct sockaddr_in a;
    socklen_t len = sizeof a;
    char addr[64];
    int fd = socket(AF_INET, SOCK_DGRAM, 0);
    memset(&a, 0, sizeof a);
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (fd < 0 || bind(fd, (struct sockaddr *)&a, sizeof a) != 0 ||
        getsockname(fd, (struct sockaddr *)&a, &len) != 0)
        return -1;
    snprintf(addr, sizeof addr, "127.0.0.1:%u", (unsigned)ntohs(a.sin_port));
    if (colony_connect(c, addr, 1000) != COLONY_OK) return -1;
    len = sizeof *client;
    if (getsockname(colony_fd(c), (struct sockaddr *)client, &len) != 0) return -1;
    return fd;
}

static void hub_says(int fd, const struct sockaddr_in *to, const char *text)
{
    sendto(fd, text, strlen(text), 0, (const struct sockaddr *)to, sizeof *to);
}

/* Waits (up to 5 s) until the client's socket has something to read. */
static void settle(const colony_client *c)
{
    struct pollfd pfd = {colony_fd(c), POLLIN, 0};
    poll(&pfd, 1, 5000);
}

static void a_flood_cannot_keep_the_loop_from_colony_poll(void)
{
    static colony_client c;
    struct sockaddr_in to;
    int fd = fake_hub(&c, &to);
    CHECK(fd >= 0);
    if (fd < 0) return;
    for (int i = 0; i < 150; i++) hub_says(fd, &to, i % 3 ? "not a packet" : "@ <hub> 0\nlease ms 5000\n");
    settle(&c);
    colony_packet p;
    colony_error e;
    int taken = 0, turns = 0;
    colony_status st;
    while ((st = colony_recv(&c, &p, &e, 1000)) != COLONY_AGAIN) taken++;
    CHECK(taken > 0 && taken <= COLONY_RECV_BUDGET);
    CHECK(colony_deadline(&c) == 1000); /* poll now */
    for (int all = taken; all < 100 && turns < 20; turns++) {
        colony_poll(&c, 1000);
        while (colony_recv(&c, &p, &e, 1000) != COLONY_AGAIN) all++;
        if (all == 100) break;
    }
    CHECK(c.malformed == 100 && c.leases == 50);
    colony_close(&c);
    close(fd);
}

/* A hub's port with no one behind it: each datagram sent there comes back as
 * ECONNREFUSED on the next call, a send (counted in unsent) or a receive
 * (counted in refused), never an error. */
static void a_hub_that_is_gone_is_counted_not_an_error(void)
{
    static colony_client c;
    struct sockaddr_in to;
    int fd = fake_hub(&c, &to);
    CHECK(fd >= 0);
    if (fd < 0) return;
    close(fd);
    const char *pkt = "@ <pose> 0\nrobot x 1\n";
    colony_packet p;
    int ok = 1;
    for (int i = 0; i < 100 && c.unsent == 0; i++) {
        ok = ok && colony_publish(&c, pkt, strlen(pkt), NULL) == COLONY_OK;
        poll(NULL, 0, 10);
    }
    CHECK(c.unsent > 0);
    for (int i = 0; i < 100 && c.refused == 0; i++) {
        ok = ok && colony_publish(&c, pkt, strlen(pkt), NULL) == COLONY_OK;
        poll(NULL, 0, 10);
        ok = ok && colony_recv(&c, &p, NULL, 1000) == COLONY_AGAIN;
    }
    CHECK(ok);
    CHECK(c.refused > 0);
    colony_close(&c);
}

static void hub_replies_are_read_as_the_rust_session_reads_them(void)
{
    static colony_client c;
    struct sockaddr_in to;
    int fd = fake_hub(&c, &to);
    CHECK(fd >= 0);
    if (fd < 0) return;
    colony_packet p;
    CHECK(colony_subscribe(&c, "t", 1000) == COLONY_OK); /* asks: a cookie may come */
    hub_says(fd, &to, "@ <hub> 0\ncookie v \"00112233aabbccdd\"\n");
    hub_says(fd, &to, "@ <hub> 0\nstatus lease_ms 5000 clients 1\n");
    settle(&c);
    CHECK(colony_recv(&c, &p, NULL, 1000) == COLONY_OK && colony_has_subject(&p, "hub"));
    CHECK(c.cookies == 1 && strcmp(c.cookie, "00112233aabbccdd") == 0);
    CHECK(c.lease_ms == -1); /* a status report's lease_ms is no grant */
    /* Keys of any length: one longer than HMAC's block signs as the whole key. */
    unsigned char key[1000], mac[32];
    char buf[256] = "@ <a> 0\nx n 1\n", want[256];
    size_t len = strlen(buf);
    memset(key, 0xaa, sizeof key);
    CHECK(colony_set_key(&c, key, sizeof key) == COLONY_OK);
    CHECK(colony_sign(buf, &len, sizeof buf, c.key, c.key_len, 7) == COLONY_OK);
    int n = sprintf(want, "@ <a> 0\nx n 1\nauth n 7 mac ");
    colony_hmac_sha256(key, sizeof key, want, (size_t)n, mac);
    for (int i = 0; i < 32; i++) n += sprintf(want + n, "%02x", mac[i]);
    strcat(want, "\n");
    CHECK(strcmp(buf, want) == 0);
    colony_close(&c);
    unsigned char zero[COLONY_KEY_BLOCK] = {0};
    CHECK(c.key_len == 0 && memcmp(c.key, zero, sizeof zero) == 0);
    close(fd);
}

int main(int argc, char **argv)
{
    (void)argc;
    sha256_and_hmac_match_published_vectors();
    a_signed_packet_matches_an_independent_hmac();
    malformed_packets_are_refused_with_their_place();
    a_line_of_thousands_of_names_is_checked_for_repeats();
    repeated_names_cost_linear_work();
    a_workspace_parses_on_a_small_stack();
    strings_handed_back_are_always_terminated();
    long_numbers_read_as_strtod_reads_them();
    fields_are_read_in_place();
    numbers_follow_rusts_grammar();
    decimals_read_as_strtod_reads_them();
    built_packets_read_back_exactly();
    a_failed_builder_leaves_nothing_to_send();
    the_builder_refuses_tokens_that_would_inject();
    numbers_ignore_a_comma_locale(argv[0]);
    a_flood_cannot_keep_the_loop_from_colony_poll();
    a_hub_that_is_gone_is_counted_not_an_error();
    hub_replies_are_read_as_the_rust_session_reads_them();
    if (failures) {
        fprintf(stderr, "test_unit: %d checks failed\n", failures);
        return 1;
    }
    printf("test_unit: every check passed\n");
    return 0;
}
