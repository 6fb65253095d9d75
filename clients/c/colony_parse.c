/* The packet parser: the same grammar, limits, errors and positions as
 * crates/wire/src/scan.rs, walking the bytes in place with no allocation. */
#include "colony.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* ---------------------------------------------------------------- bytes */

static int is_control(unsigned char c) { return c < 0x20 || c == 0x7f; }

/* May stand in a bare token: anything but controls, blank, quote and
 * parentheses. A table, as scan.rs has: one load per byte on the hot path. */
static const unsigned char BARE[256] = {
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    0, 1, 0, 1, 1, 1, 1, 1, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1,
    1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1,
    1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 0,
    1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1,
    1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1,
    1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1,
    1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1};

static int is_bare(unsigned char c) { return BARE[c]; }

static int is_subject_byte(unsigned char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
           c == '_' || c == '-' || c == '.' || c == ':' || c == '/';
}

int colony_span_is(colony_span a, const char *s)
{
    size_t n = strlen(s);
    return a.len == n && memcmp(a.ptr, s, n) == 0;
}

const char *colony_status_name(colony_status s)
{
    static const char *const names[] = {
        "ok", "again", "too-large", "empty", "not-utf8", "bad-header", "bad-subject",
        "duplicate-subject", "bad-priority", "control-char", "expected-label", "expected-name",
        "missing-value", "duplicate-name", "unclosed-group", "unmatched-close",
        "unterminated-string", "bad-escape", "too-deep", "missing", "wrong-type", "no-space",
        "bad-argument", "system"};
    return (unsigned)s < sizeof names / sizeof names[0] ? names[s] : "unknown";
}

/* Rust's str::from_utf8: shortest forms only, no surrogates, nothing past U+10FFFF.
 * Returns the length of the valid prefix. */
static size_t utf8_valid_up_to(const unsigned char *b, size_t n)
{
    size_t i = 0;
    while (i < n) {
        /* ASCII eight bytes at a time: most packets are nothing else. */
        uint64_t w;
        while (i + 8 <= n && (memcpy(&w, b + i, 8), (w & 0x8080808080808080u) == 0)) i += 8;
        if (i >= n) break;
        unsigned char c = b[i];
        if (c < 0x80) {
            i++;
            continue;
        }
        size_t need;
        unsigned char lo = 0x80, hi = 0xbf;
        if (c >= 0xc2 && c <= 0xdf) {
            need = 1;
        } else if (c >= 0xe0 && c <= 0xef) {
            need = 2;
            if (c == 0xe0) lo = 0xa0;
            if (c == 0xed) hi = 0x9f;
        } else if (c >= 0xf0 && c <= 0xf4) {
            need = 3;
            if (c == 0xf0) lo = 0x90;
            if (c == 0xf4) hi = 0x8f;
        } else {
            return i;
        }
        if (i + 1 >= n || b[i + 1] < lo || b[i + 1] > hi) return i;
        for (size_t k = 2; k <= need; k++)
            if (i + k >= n || (b[i + k] & 0xc0) != 0x80) return i;
        i += need + 1;
    }
    return n;
}

/* ---------------------------------------------------------------- scanner */

enum tok { TOK_BARE, TOK_QUOTED, TOK_OPEN, TOK_CLOSE, TOK_EOL };

typedef struct scanner {
    const unsigned char *b;
    size_t len, pos, line_start, prev_start;
    unsigned line, prev_line;
    colony_error *err;
} scanner;

/* Reports an error at byte `pos`; a position before this line's start lies
 * on the line just ended (an error found at a line's end is reported there). */
static colony_status fail(scanner *s, size_t pos, colony_status st)
{
    unsigned line = s->line;
    size_t start = s->line_start;
    if (pos < s->line_start) {
        line = s->prev_line;
        start = s->prev_start;
    }
    if (s->err) {
        s->err->status = st;
        s->err->line = line;
        s->err->column = (unsigned)(pos >= start ? pos - start + 1 : 1);
    }
    return st;
}

static void new_line(scanner *s, size_t next)
{
    s->prev_line = s->line;
    s->prev_start = s->line_start;
    s->pos = next;
    s->line++;
    s->line_start = next;
}

static void skip_ws(scanner *s)
{
    while (s->pos < s->len && (s->b[s->pos] == ' ' || s->b[s->pos] == '\t')) s->pos++;
}

/* Takes a line end if one is next: 1 taken, 0 not, or an error for a raw control. */
static int take_eol(scanner *s, colony_status *st)
{
    if (s->pos >= s->len) return 1;
    unsigned char c = s->b[s->pos];
    if (c == '\n') {
        new_line(s, s->pos + 1);
        return 1;
    }
    if (c == '\r' && s->pos + 1 < s->len && s->b[s->pos + 1] == '\n') {
        new_line(s, s->pos + 2);
        return 1;
    }
    if (is_control(c)) {
        *st = fail(s, s->pos, COLONY_CONTROL_CHAR);
        return -1;
    }
    return 0;
}

static colony_status quoted(scanner *s, size_t start)
{
    size_t p = start + 1;
    for (;;) {
        /* A raw tab may stand inside a string; every other control ends it. */
        while (p < s->len && s->b[p] != '"' && s->b[p] != '\\' &&
               (!is_control(s->b[p]) || s->b[p] == '\t'))
            p++;
        if (p >= s->len || s->b[p] == '\n' || s->b[p] == '\r')
            return fail(s, start, COLONY_UNTERMINATED_STRING);
        if (s->b[p] == '"') {
            s->pos = p + 1;
            return COLONY_OK;
        }
        if (s->b[p] == '\\') {
            unsigned char e = p + 1 < s->len ? s->b[p + 1] : '\n';
            if (e == '"' || e == '\\' || e == 'n' || e == 'r' || e == 't') {
                p += 2;
                continue;
            }
            if (e == '\n' || e == '\r') return fail(s, start, COLONY_UNTERMINATED_STRING);
            return fail(s, p, COLONY_BAD_ESCAPE);
        }
        return fail(s, p, COLONY_CONTROL_CHAR);
    }
}

/* The next token after blanks: its kind in *t and where it starts in *at. */
static colony_status next_tok(scanner *s, enum tok *t, size_t *at)
{
    colony_status st = COLONY_OK;
    skip_ws(s);
    *at = s->pos;
    int eol = take_eol(s, &st);
    if (eol < 0) return st;
    if (eol) {
        *t = TOK_EOL;
        return COLONY_OK;
    }
    unsigned char c = s->b[s->pos];
    if (c == '(' || c == ')') {
        *t = c == '(' ? TOK_OPEN : TOK_CLOSE;
        s->pos++;
        return COLONY_OK;
    }
    if (c == '"') {
        *t = TOK_QUOTED;
        return quoted(s, s->pos);
    }
    *t = TOK_BARE;
    while (s->pos < s->len && is_bare(s->b[s->pos])) s->pos++;
    return COLONY_OK;
}

/* ---------------------------------------------------------------- header */

/* Rust's str::parse::<i64>: an optional sign, then decimal digits, no overflow. */
static int parse_i64(const char *p, size_t n, int64_t *out)
{
    size_t i = 0;
    int neg = 0;
    if (n > 0 && (p[0] == '+' || p[0] == '-')) {
        neg = p[0] == '-';
        i = 1;
    }
    if (i == n) return 0;
    uint64_t v = 0, limit = neg ? (uint64_t)INT64_MAX + 1 : (uint64_t)INT64_MAX;
    for (; i < n; i++) {
        if (p[i] < '0' || p[i] > '9') return 0;
        unsigned d = (unsigned)(p[i] - '0');
        if (v > (limit - d) / 10) return 0;
        v = v * 10 + d;
    }
    *out = neg ? (int64_t)(0 - v) : (int64_t)v;
    return 1;
}

static colony_status header(scanner *s, colony_packet *p)
{
    const unsigned char *b = s->b;
    if (b[0] != '@') return fail(s, 0, COLONY_BAD_HEADER);
    if (s->len < 2 || (b[1] != ' ' && b[1] != '\t')) return fail(s, 1, COLONY_BAD_HEADER);
    s->pos = 1;
    skip_ws(s);
    size_t first = s->pos, last_end = s->pos;
    size_t name_at[COLONY_MAX_SUBJECTS], name_len[COLONY_MAX_SUBJECTS];
    unsigned count = 0;
    while (s->pos < s->len && b[s->pos] == '<') {
        size_t open = s->pos, close = open;
        while (close < s->len && b[close] != '>' && b[close] != '\n') close++;
        if (close >= s->len || b[close] != '>') return fail(s, open, COLONY_BAD_HEADER);
        size_t n = close - open - 1;
        int ok = n >= 1 && n <= COLONY_MAX_SUBJECT_LEN;
        for (size_t i = open + 1; ok && i < close; i++) ok = is_subject_byte(b[i]);
        if (!ok) return fail(s, open, COLONY_BAD_SUBJECT);
        for (unsigned k = 0; k < count; k++)
            if (name_len[k] == n && memcmp(b + name_at[k], b + open + 1, n) == 0)
                return fail(s, open, COLONY_DUPLICATE_SUBJECT);
        if (count == COLONY_MAX_SUBJECTS) return fail(s, open, COLONY_BAD_HEADER);
        name_at[count] = open + 1;
        name_len[count] = n;
        count++;
        s->pos = close + 1;
        last_end = s->pos;
        if (s->pos >= s->len || (b[s->pos] != ' ' && b[s->pos] != '\t'))
            return fail(s, s->pos, COLONY_BAD_HEADER);
        skip_ws(s);
    }
    if (count == 0) return fail(s, s->pos, COLONY_BAD_HEADER);
    size_t prio_at = s->pos, at;
    enum tok t;
    colony_status st = next_tok(s, &t, &at);
    if (st != COLONY_OK) return st;
    if (t != TOK_BARE) return fail(s, prio_at, COLONY_BAD_HEADER);
    int64_t prio;
    if (!parse_i64((const char *)b + at, s->pos - at, &prio) || prio < INT32_MIN ||
        prio > INT32_MAX)
        return fail(s, prio_at, COLONY_BAD_PRIORITY);
    size_t end_at = s->pos;
    st = next_tok(s, &t, &at);
    if (st != COLONY_OK) return st;
    if (t != TOK_EOL) return fail(s, end_at, COLONY_BAD_HEADER);
    p->subjects.ptr = (const char *)b + first;
    p->subjects.len = last_end - first;
    p->subject_count = count;
    p->priority = (int32_t)prio;
    p->body = s->pos;
    return COLONY_OK;
}

/* ---------------------------------------------------------------- body */

/* A name may appear once per line or group. A frame of up to LINEAR names is
 * searched linearly (the common case, and the fastest). A hostile line with
 * thousands of names would make that quadratic, so a frame that grows past
 * LINEAR moves to a hash table of name offsets (packets < 64 KB, so a
 * uint16_t offset names any byte). Every name takes at least three bytes
 * (`A()`), so a packet holds fewer than COLONY_MAX_NAMES, the table is never
 * two-thirds full, and every probe ends at an empty slot. Frames close in
 * strict nesting order, so each inserted slot is logged and a closing frame
 * empties its own slots again: the table is exactly as it was before the
 * frame opened, and a name repeated in frame after frame costs no more than
 * the first time. */
#define LINEAR 16
#define TABLE COLONY_TABLE_SLOTS
#define EMPTY 0

typedef struct frame {
    size_t start;      /* first name of the frame (after the label, or after `(`) */
    unsigned first, n; /* its names in the linear list */
    unsigned mark;     /* the undo log's length when it moved to the table */
    int big;           /* its names are in the table */
} frame;

typedef struct body_state {
    frame frames[COLONY_MAX_DEPTH + 1];
    unsigned depth;
    uint16_t at[(COLONY_MAX_DEPTH + 1) * LINEAR]; /* packets < 64 KB */
    uint16_t len[(COLONY_MAX_DEPTH + 1) * LINEAR];
    colony_workspace *ws; /* NULL until a frame needs the table */
    unsigned logged;      /* slots in ws->undo */
    uint64_t seed;        /* of the table's hash */
} body_state;

/* What body() returns to ask for the table: never a parse verdict. */
#define NEED_TABLE COLONY_AGAIN

static size_t bare_len(const scanner *s, size_t at)
{
    size_t e = at;
    while (e < s->len && is_bare(s->b[e])) e++;
    return e - at;
}

/* FNV-1a from a secret start, then mixed (MurmurHash3's finalizer). Unkeyed,
 * a publisher could send names that all fall in one bucket, which the hub
 * (whose Rust parser hashes with a random key) would forward to every C
 * subscriber, and each would spend quadratic time on it. */
static uint32_t hash_name(uint64_t seed, const unsigned char *p, size_t n)
{
    uint64_t h = seed ^ 14695981039346656037u;
    for (size_t i = 0; i < n; i++) h = (h ^ p[i]) * 1099511628211u;
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdu;
    h ^= h >> 33;
    return (uint32_t)h;
}

/* Adds a name to the innermost frame; 0 when the frame holds it already. */
static int table_insert(body_state *bs, const scanner *s, size_t at, size_t n)
{
    uint16_t *table = bs->ws->table;
    size_t frame_start = bs->frames[bs->depth].start;
    uint32_t i = hash_name(bs->seed, s->b + at, n) & (TABLE - 1);
    for (;; i = (i + 1) & (TABLE - 1)) {
        uint16_t v = table[i];
        bs->ws->probes++;
        if (v == EMPTY) break;
        size_t o = (size_t)v - 1;
        /* Names of outer frames stand before this frame's start; inner frames'
         * names were removed when they closed. */
        if (o >= frame_start && bare_len(s, o) == n && memcmp(s->b + o, s->b + at, n) == 0)
            return 0;
    }
    table[i] = (uint16_t)(at + 1);
    bs->ws->undo[bs->logged++] = (uint16_t)i;
    return 1;
}

/* Empties the slots filled since the log was `mark` long. */
static void undo_to(body_state *bs, unsigned mark)
{
    while (bs->logged > mark) bs->ws->table[bs->ws->undo[--bs->logged]] = EMPTY;
}

static int insert_name(body_state *bs, const scanner *s, size_t at, size_t n, colony_status *st)
{
    frame *f = &bs->frames[bs->depth];
    if (f->big) return table_insert(bs, s, at, n);
    for (unsigned k = f->first; k < f->first + f->n; k++)
        if (bs->len[k] == n && s->b[bs->at[k]] == s->b[at] && memcmp(s->b + bs->at[k], s->b + at, n) == 0)
            return 0;
    if (f->n < LINEAR) {
        bs->at[f->first + f->n] = (uint16_t)at;
        bs->len[f->first + f->n] = (uint16_t)n;
        f->n++;
        return 1;
    }
    if (!bs->ws) {
        *st = NEED_TABLE;
        return -1;
    }
    f->big = 1;
    f->mark = bs->logged;
    for (unsigned k = f->first; k < f->first + f->n; k++) table_insert(bs, s, bs->at[k], bs->len[k]);
    return table_insert(bs, s, at, n);
}

static void open_frame(body_state *bs, size_t start)
{
    frame *outer = &bs->frames[bs->depth];
    frame *f = &bs->frames[++bs->depth];
    f->start = start;
    f->first = outer->first + outer->n;
    f->n = 0;
    f->big = 0;
}

static void close_frame(body_state *bs)
{
    frame *f = &bs->frames[bs->depth];
    if (f->big) undo_to(bs, f->mark);
    if (bs->depth > 0) bs->depth--;
}

static colony_status body(scanner *s, body_state *bs)
{
    colony_status st = COLONY_OK;
    while (s->pos < s->len) {
        scanner line_start = *s;
        enum tok t;
        size_t at;
        if ((st = next_tok(s, &t, &at)) != COLONY_OK) return st;
        if (t == TOK_EOL) continue;
        if (t != TOK_BARE) return fail(s, at, COLONY_EXPECTED_LABEL);
        bs->depth = 0;
        bs->frames[0].start = s->pos;
        bs->frames[0].first = 0;
        bs->frames[0].n = 0;
        bs->frames[0].big = 0;
        for (;;) {
            if ((st = next_tok(s, &t, &at)) != COLONY_OK) return st;
            if (t == TOK_EOL) {
                if (bs->depth > 0) return fail(s, at, COLONY_UNCLOSED_GROUP);
                close_frame(bs);
                break;
            }
            if (t == TOK_CLOSE) {
                if (bs->depth == 0) return fail(s, at, COLONY_UNMATCHED_CLOSE);
                close_frame(bs);
                continue;
            }
            if (t != TOK_BARE) return fail(s, at, COLONY_EXPECTED_NAME);
            size_t name_at = at;
            int fresh = insert_name(bs, s, at, s->pos - at, &st);
            if (fresh < 0) {
                *s = line_start; /* parse this line again with the table */
                return st;
            }
            if (!fresh) return fail(s, name_at, COLONY_DUPLICATE_NAME);
            if ((st = next_tok(s, &t, &at)) != COLONY_OK) return st;
            if (t == TOK_OPEN) {
                if (bs->depth >= COLONY_MAX_DEPTH) return fail(s, at, COLONY_TOO_DEEP);
                open_frame(bs, s->pos);
            } else if (t == TOK_EOL || t == TOK_CLOSE) {
                return fail(s, name_at, COLONY_MISSING_VALUE);
            }
        }
    }
    return COLONY_OK;
}

/* The body with the table: whatever the verdict, every slot filled is emptied
 * again, so the workspace is left as it was found (all empty). */
static colony_status body_in(scanner *s, body_state *bs, colony_workspace *ws)
{
    bs->ws = ws;
    bs->logged = 0;
    /* A secret in C99 alone, and no shared state: where this thread's stack
     * lies (randomised by the loader) and the clocks; or the workspace's own
     * seed (colony_connect reads one from /dev/urandom). */
    bs->seed = ws->seed ? ws->seed
                        : (uint64_t)(uintptr_t)&bs * 0x9e3779b97f4a7c15u ^ (uint64_t)time(NULL) ^
                              (uint64_t)clock() << 32;
    colony_status st = body(s, bs);
    undo_to(bs, 0);
    bs->ws = NULL;
    return st;
}

/* Plain colony_parse's table, on the stack of a function entered only for a
 * packet with a frame of more than LINEAR names: such packets alone pay for
 * the stack and for clearing it. */
static colony_status body_with_stack_table(scanner *s, body_state *bs)
{
    colony_workspace ws;
    memset(ws.table, 0, sizeof ws.table);
    ws.seed = 0;
    ws.probes = 0;
    return body_in(s, bs, &ws);
}

colony_status colony_parse_ws(colony_packet *p, const void *data, size_t len, colony_error *err,
                              colony_workspace *ws)
{
    colony_error ignored;
    if (!err) err = &ignored;
    err->status = COLONY_OK;
    err->line = 1;
    err->column = 1;
    if (ws) ws->probes = 0;
    if (len > COLONY_MAX_PACKET) return err->status = COLONY_TOO_LARGE;
    if (len == 0) return err->status = COLONY_EMPTY;
    const unsigned char *b = data;
    size_t good = utf8_valid_up_to(b, len);
    if (good < len) {
        size_t line_start = 0;
        for (size_t i = 0; i < good; i++)
            if (b[i] == '\n') {
                err->line++;
                line_start = i + 1;
            }
        err->column = (unsigned)(good - line_start + 1);
        return err->status = COLONY_NOT_UTF8;
    }
    scanner s = {b, len, 0, 0, 0, 1, 1, err};
    colony_packet out;
    colony_status st = header(&s, &out);
    if (st != COLONY_OK) return st;
    body_state bs;
    bs.ws = NULL;
    if (ws) {
        st = body_in(&s, &bs, ws);
    } else {
        st = body(&s, &bs);
        if (st == NEED_TABLE) st = body_with_stack_table(&s, &bs);
    }
    if (st != COLONY_OK) return st;
    out.text = data;
    out.len = len;
    *p = out;
    return COLONY_OK;
}

colony_status colony_parse(colony_packet *p, const void *data, size_t len, colony_error *err)
{
    return colony_parse_ws(p, data, len, err, NULL);
}

/* ---------------------------------------------------------------- walking a valid packet */

int colony_next_subject(const colony_packet *p, size_t *at, colony_span *subject)
{
    const char *s = p->subjects.ptr;
    size_t i = *at, n = p->subjects.len;
    while (i < n && s[i] != '<') i++;
    if (i >= n) return 0;
    size_t close = i + 1;
    while (close < n && s[close] != '>') close++;
    subject->ptr = s + i + 1;
    subject->len = close - i - 1;
    *at = close + 1;
    return 1;
}

int colony_has_subject(const colony_packet *p, const char *subject)
{
    size_t at = 0;
    colony_span s;
    while (colony_next_subject(p, &at, &s))
        if (colony_span_is(s, subject)) return 1;
    return 0;
}

int colony_next_line(const colony_packet *p, colony_line *line)
{
    const char *t = p->text;
    size_t pos = line->next ? line->next : p->body;
    unsigned number = line->next ? line->number + 1 : 2;
    for (;;) {
        while (pos < p->len && (t[pos] == ' ' || t[pos] == '\t')) pos++;
        if (pos >= p->len) {
            line->next = p->len;
            return 0;
        }
        if (t[pos] == '\n' || t[pos] == '\r') {
            pos += t[pos] == '\r' ? 2 : 1;
            number++;
            continue;
        }
        break;
    }
    size_t label_end = pos;
    while (label_end < p->len && is_bare((unsigned char)t[label_end])) label_end++;
    size_t end = label_end;
    while (end < p->len && t[end] != '\n') end++;
    line->next = end < p->len ? end + 1 : p->len;
    if (end > label_end && t[end - 1] == '\r') end--;
    line->label.ptr = t + pos;
    line->label.len = label_end - pos;
    line->fields.ptr = t + label_end;
    line->fields.len = end - label_end;
    line->number = number;
    return 1;
}

int colony_find_line(const colony_packet *p, const char *label, colony_line *line)
{
    while (colony_next_line(p, line))
        if (colony_span_is(line->label, label)) return 1;
    return 0;
}

int colony_next_field(colony_span *fields, colony_field *f)
{
    const char *s = fields->ptr;
    size_t n = fields->len, i = 0;
    while (i < n && (s[i] == ' ' || s[i] == '\t')) i++;
    size_t name = i;
    while (i < n && is_bare((unsigned char)s[i])) i++;
    if (i == name) return 0;
    f->name.ptr = s + name;
    f->name.len = i - name;
    while (i < n && (s[i] == ' ' || s[i] == '\t')) i++;
    if (i >= n) return 0;
    size_t v = i;
    if (s[i] == '"') {
        for (i++; i < n && s[i] != '"'; i++)
            if (s[i] == '\\') i++;
        if (i >= n) return 0;
        f->kind = COLONY_QUOTED;
        f->value.ptr = s + v + 1;
        f->value.len = i - v - 1;
        i++;
    } else if (s[i] == '(') {
        unsigned depth = 1;
        for (i++; i < n && depth > 0; i++) {
            if (s[i] == '(') depth++;
            else if (s[i] == ')') depth--;
            else if (s[i] == '"')
                for (i++; i < n && s[i] != '"'; i++)
                    if (s[i] == '\\') i++;
        }
        if (depth > 0) return 0;
        f->kind = COLONY_GROUP;
        f->value.ptr = s + v + 1;
        f->value.len = i - v - 2;
    } else {
        while (i < n && is_bare((unsigned char)s[i])) i++;
        if (i == v) return 0;
        f->kind = COLONY_BARE;
        f->value.ptr = s + v;
        f->value.len = i - v;
    }
    fields->ptr = s + i;
    fields->len = n - i;
    return 1;
}

colony_status colony_get(colony_span fields, const char *name, colony_field *out)
{
    while (colony_next_field(&fields, out))
        if (colony_span_is(out->name, name)) return COLONY_OK;
    return COLONY_MISSING;
}

/* Rust's f64 grammar (no hex, no blanks): [+-] then inf, infinity, nan (any
 * case) or digits[.digits][e[+-]digits] with a digit somewhere before the e. */
static int is_rust_float(const char *p, size_t n)
{
    size_t i = 0, digits = 0;
    if (i < n && (p[i] == '+' || p[i] == '-')) i++;
    const char *words[] = {"inf", "infinity", "nan"};
    for (unsigned w = 0; w < 3; w++) {
        size_t len = strlen(words[w]), k = 0;
        if (n - i != len) continue;
        while (k < len && (p[i + k] | 0x20) == words[w][k]) k++;
        if (k == len) return 1;
    }
    for (; i < n && p[i] >= '0' && p[i] <= '9'; i++) digits++;
    if (i < n && p[i] == '.')
        for (i++; i < n && p[i] >= '0' && p[i] <= '9'; i++) digits++;
    if (digits == 0) return 0;
    if (i < n && (p[i] == 'e' || p[i] == 'E')) {
        i++;
        if (i < n && (p[i] == '+' || p[i] == '-')) i++;
        size_t exp = i;
        while (i < n && p[i] >= '0' && p[i] <= '9') i++;
        if (i == exp) return 0;
    }
    return i == n;
}

/* Clinger's fast path: up to 15 digits with up to 22 after the point are an
 * exact integer over an exact power of ten, so one division rounds correctly.
 * Most values on the wire (`12.5`, `-40.17`) take it; the rest go to strtod. */
static int fast_f64(const char *p, size_t n, double *out)
{
    static const double pow10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                     1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                     1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
    size_t i = p[0] == '-' || p[0] == '+';
    uint64_t m = 0;
    unsigned digits = 0, after = 0, point = 0;
    for (; i < n; i++) {
        if (p[i] == '.' && !point) {
            point = 1;
            continue;
        }
        if (p[i] < '0' || p[i] > '9' || ++digits > 15) return 0;
        m = m * 10 + (uint64_t)(p[i] - '0');
        after += point;
    }
    if (digits == 0 || after > 22) return 0;
    *out = (double)m / pow10[after];
    if (p[0] == '-') *out = -*out;
    return 1;
}

/* Rust's f64 from text of any length, read the same in every locale: the
 * digits are rewritten as an integer and an exponent (`12.5e3` as `125e2`),
 * which strtod reads with no decimal point to misread. Past SIGNIFICANT
 * digits, the rest only matter as nonzero or not (no halfway point between
 * two doubles has more than 767 significant digits), so one `1` stands for
 * them; exponents are clamped far beyond where the value is 0 or infinite. */
#define SIGNIFICANT 780
static double slow_f64(const char *p, size_t n)
{
    char text[SIGNIFICANT + 32];
    size_t i = 0, kept = 0;
    int neg = p[0] == '-', sticky = 0;
    long exp10 = 0, e = 0;
    if (p[0] == '-' || p[0] == '+') i++;
    if (p[i] == 'i' || p[i] == 'I') return neg ? -INFINITY : INFINITY;
    if (p[i] == 'n' || p[i] == 'N') return NAN;
    text[kept++] = neg ? '-' : '+';
    for (int point = 0; i < n && p[i] != 'e' && p[i] != 'E'; i++) {
        if (p[i] == '.') {
            point = 1;
        } else if (kept == 1 && p[i] == '0') {
            exp10 -= point; /* a leading zero */
        } else if (kept <= SIGNIFICANT) {
            text[kept++] = p[i];
            exp10 -= point;
        } else {
            sticky |= p[i] != '0';
            exp10 += !point;
        }
    }
    if (kept == 1) return neg ? -0.0 : 0.0;
    if (sticky) text[kept++] = '1', exp10--;
    if (i < n) {
        int eneg = p[++i] == '-';
        if (p[i] == '-' || p[i] == '+') i++;
        for (; i < n; i++)
            if (e < 1000000) e = e * 10 + (p[i] - '0');
        exp10 += eneg ? -e : e;
    }
    snprintf(text + kept, sizeof text - kept, "e%ld", exp10);
    return strtod(text, NULL); /* overflow gives ±inf and underflow 0, as Rust's does */
}

colony_status colony_field_f64(const colony_field *f, double *out)
{
    if (f->kind != COLONY_BARE || !is_rust_float(f->value.ptr, f->value.len)) return COLONY_WRONG_TYPE;
    if (!fast_f64(f->value.ptr, f->value.len, out)) *out = slow_f64(f->value.ptr, f->value.len);
    return COLONY_OK;
}

colony_status colony_field_i64(const colony_field *f, int64_t *out)
{
    if (f->kind != COLONY_BARE || !parse_i64(f->value.ptr, f->value.len, out)) return COLONY_WRONG_TYPE;
    return COLONY_OK;
}

colony_status colony_get_f64(colony_span fields, const char *name, double *out)
{
    colony_field f;
    if (colony_get(fields, name, &f) != COLONY_OK) return COLONY_MISSING;
    return colony_field_f64(&f, out);
}

colony_status colony_get_i64(colony_span fields, const char *name, int64_t *out)
{
    colony_field f;
    if (colony_get(fields, name, &f) != COLONY_OK) return COLONY_MISSING;
    return colony_field_i64(&f, out);
}

colony_status colony_get_group(colony_span fields, const char *name, colony_span *out)
{
    colony_field f;
    if (colony_get(fields, name, &f) != COLONY_OK) return COLONY_MISSING;
    if (f.kind != COLONY_GROUP) return COLONY_WRONG_TYPE;
    *out = f.value;
    return COLONY_OK;
}

/* Whenever there is room for it, buf ends up NUL-terminated: the whole value,
 * as much of it as fits (cut at a character's start) with COLONY_NO_SPACE,
 * or "" on any other error. */
colony_status colony_unescape(const colony_field *f, char *buf, size_t cap)
{
    if (cap > 0) buf[0] = 0;
    if (f->kind == COLONY_GROUP) return COLONY_WRONG_TYPE;
    size_t o = 0;
    for (size_t i = 0; i < f->value.len; i++) {
        char c = f->value.ptr[i];
        if (f->kind == COLONY_QUOTED && c == '\\' && i + 1 < f->value.len) {
            c = f->value.ptr[++i];
            c = c == 'n' ? '\n' : c == 'r' ? '\r' : c == 't' ? '\t' : c;
        }
        if (o + 1 >= cap) {
            /* c did not fit: a continuation byte means a character was cut. */
            while (o > 0 && ((unsigned char)c & 0xc0) == 0x80) c = buf[--o];
            if (cap > 0) buf[o] = 0;
            return COLONY_NO_SPACE;
        }
        buf[o++] = c;
    }
    buf[o] = 0;
    return COLONY_OK;
}

colony_status colony_get_str(colony_span fields, const char *name, char *buf, size_t cap)
{
    colony_field f;
    if (cap > 0) buf[0] = 0;
    if (colony_get(fields, name, &f) != COLONY_OK) return COLONY_MISSING;
    return colony_unescape(&f, buf, cap);
}
