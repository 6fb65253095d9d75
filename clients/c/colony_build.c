/* Writing packets (crates/wire/src/build.rs's rules) and signing them
 * (crates/wire/src/auth.rs's `auth n N mac M` line). */
#include "colony.h"

#include <inttypes.h>
#include <locale.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A failed builder holds nothing that could be sent by mistake. */
static void fail(colony_builder *b, colony_status st)
{
    if (!b->failed) b->failed = st;
    b->len = 0;
    if (b->cap > 0) b->buf[0] = 0;
}

/* Appends n bytes, keeping a NUL after them so the text can be printed. */
static void put(colony_builder *b, const char *s, size_t n)
{
    if (b->failed) return;
    if (b->len + n + 1 > b->cap) {
        fail(b, COLONY_NO_SPACE);
        return;
    }
    memcpy(b->buf + b->len, s, n);
    b->len += n;
    b->buf[b->len] = 0;
}

static void puts_(colony_builder *b, const char *s) { put(b, s, strlen(s)); }

void colony_putf(colony_builder *b, const char *fmt, ...)
{
    if (b->failed) return;
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(b->buf + b->len, b->cap - b->len, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n + 1 > b->cap - b->len) {
        fail(b, COLONY_NO_SPACE);
        return;
    }
    b->len += (size_t)n;
}

void colony_begin(colony_builder *b, char *buf, size_t cap, const char *subjects, int32_t priority)
{
    b->buf = buf;
    b->cap = cap;
    b->len = 0;
    b->depth = 0;
    b->failed = cap == 0 ? COLONY_NO_SPACE : COLONY_OK;
    puts_(b, "@");
    for (const char *s = subjects; *s;) {
        while (*s == ' ') s++;
        size_t n = strcspn(s, " ");
        if (n == 0) break;
        if (n > COLONY_MAX_SUBJECT_LEN ||
            strspn(s, "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-.:/") < n)
            fail(b, COLONY_BAD_ARGUMENT);
        puts_(b, " <");
        put(b, s, n);
        puts_(b, ">");
        s += n;
    }
    colony_putf(b, " %" PRId32 "\n", priority);
}

/* A label, name or bare value as the grammar reads one: a non-empty run of
 * bytes that are not blank, control, quote or parenthesis. Anything else
 * could end the token early, or start a line of the caller's choosing. */
static void token(colony_builder *b, const char *t)
{
    size_t n = 0;
    for (unsigned char c; (c = (unsigned char)t[n]) != 0; n++)
        if (c <= ' ' || c == 0x7f || c == '"' || c == '(' || c == ')') break;
    if (n == 0 || t[n] != 0) fail(b, COLONY_BAD_ARGUMENT);
    put(b, t, n);
}

void colony_put_line(colony_builder *b, const char *label)
{
    if (b->len > 0 && b->buf[b->len - 1] != '\n') puts_(b, "\n");
    token(b, label);
    b->depth = 0;
}

/* ` name ` before a value; no blank right after a `(`, so groups read `(a 1)`. */
static void name(colony_builder *b, const char *n)
{
    if (b->len == 0 || b->buf[b->len - 1] != '(') puts_(b, " ");
    token(b, n);
    puts_(b, " ");
}

/* The locale's decimal point in printf's output becomes ".". */
static void c_decimal_point(char *text)
{
    const char *dp = localeconv()->decimal_point;
    size_t n = dp ? strlen(dp) : 0;
    char *at;
    if (n == 0 || (n == 1 && dp[0] == '.') || !(at = strstr(text, dp))) return;
    *at = '.';
    memmove(at + 1, at + n, strlen(at + n) + 1);
}

void colony_put_int(colony_builder *b, const char *n, int64_t value)
{
    name(b, n);
    colony_putf(b, "%" PRId64, value);
}

void colony_put_f64(colony_builder *b, const char *n, double v)
{
    char text[40];
    name(b, n);
    /* Rust's spelling of the three that printf spells its own way. */
    if (isnan(v)) {
        puts_(b, "NaN");
        return;
    }
    if (isinf(v)) {
        puts_(b, v > 0 ? "inf" : "-inf");
        return;
    }
    /* The shortest of 15 or 17 digits that reads back to the same double
     * (checked in the locale's own spelling, then spelt with "."). */
    snprintf(text, sizeof text, "%.15g", v);
    if (strtod(text, NULL) != v) snprintf(text, sizeof text, "%.17g", v);
    c_decimal_point(text);
    /* A whole number keeps a `.0`, as Rust writes it, so readers that tell
     * integers from numbers (the Python client) read a number. */
    if (!strpbrk(text, ".eEn")) strcat(text, ".0");
    puts_(b, text);
}

void colony_put_text(colony_builder *b, const char *n, const char *s)
{
    name(b, n);
    puts_(b, "\"");
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"') puts_(b, "\\\"");
        else if (c == '\\') puts_(b, "\\\\");
        else if (c == '\n') puts_(b, "\\n");
        else if (c == '\r') puts_(b, "\\r");
        else if (c == '\t') puts_(b, "\\t");
        else if (c < 0x20 || c == 0x7f) puts_(b, "\xef\xbf\xbd"); /* U+FFFD */
        else put(b, s, 1);
    }
    puts_(b, "\"");
}

void colony_put_bare(colony_builder *b, const char *n, const char *value)
{
    name(b, n);
    token(b, value);
}

void colony_put_open(colony_builder *b, const char *n)
{
    name(b, n);
    puts_(b, "(");
    b->depth++;
}

void colony_put_close(colony_builder *b)
{
    puts_(b, ")");
    b->depth--;
}

size_t colony_finish(colony_builder *b, colony_error *err)
{
    colony_packet p;
    colony_error ignored;
    if (!err) err = &ignored;
    if (b->len > 0 && b->buf[b->len - 1] != '\n') puts_(b, "\n");
    if (b->failed) {
        err->status = b->failed;
        err->line = err->column = 0;
        return 0;
    }
    if (colony_parse(&p, b->buf, b->len, err) != COLONY_OK) {
        fail(b, err->status);
        return 0;
    }
    return b->len;
}

colony_status colony_sign(char *buf, size_t *len, size_t cap, const void *key, size_t key_len,
                          uint64_t n)
{
    colony_builder b = {buf, cap, *len, 0, COLONY_OK};
    unsigned char mac[32];
    /* Room checked first (`\nauth n <20 digits> mac <64 hex>\n` and a NUL),
     * so the builder cannot fail and empty the caller's packet. */
    if (cap < 100 || *len > cap - 100) return COLONY_NO_SPACE;
    if (b.len > 0 && buf[b.len - 1] != '\n') puts_(&b, "\n");
    colony_putf(&b, "auth n %" PRIu64 " mac ", n);
    if (b.failed) return b.failed;
    colony_hmac_sha256(key, key_len, buf, b.len, mac);
    for (int i = 0; i < 32; i++) colony_putf(&b, "%02x", mac[i]);
    puts_(&b, "\n");
    if (b.failed) return b.failed;
    *len = b.len;
    return COLONY_OK;
}
