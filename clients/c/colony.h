/* colony.h: a C client for colony's hub (C99, POSIX sockets, nothing else).
 *
 * Three parts, each usable alone:
 *
 *   parser   colony_parse() checks a datagram exactly as colony's Rust parser
 *            does and records where its header and body lie; colony_next_line()
 *            and colony_next_field() then walk the bytes in place, as scanf
 *            would. Nothing is allocated and nothing is copied.
 *   builder  colony_begin(), colony_put_*() and colony_finish() write a packet
 *            into a buffer of yours, as easily as printf.
 *   client   a colony_client owns one non-blocking UDP socket. It never blocks
 *            and never owns the loop: wait on colony_fd() until colony_deadline(),
 *            then call colony_poll() and colony_recv(). It keeps leases,
 *            resubscribes silent channels, answers the hub's cookies and signs
 *            what it sends when given the hub's key.
 *
 * Times are milliseconds on a monotonic clock (colony_now_ms()), always passed
 * in, so a program (or a test) decides what "now" is.
 */
#ifndef COLONY_H
#define COLONY_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define COLONY_MAX_PACKET 65507 /* one UDP payload over IPv4 */
#define COLONY_MAX_SUBJECTS 16
#define COLONY_MAX_SUBJECT_LEN 64
#define COLONY_MAX_DEPTH 32
#define COLONY_MIN_KEY_LEN 16

/* What went wrong. The parse errors are colony_wire's ErrorKind, one for one. */
typedef enum colony_status {
    COLONY_OK = 0,
    COLONY_AGAIN,              /* nothing waiting (not an error) */
    COLONY_TOO_LARGE,          /* parse errors: */
    COLONY_EMPTY,
    COLONY_NOT_UTF8,
    COLONY_BAD_HEADER,
    COLONY_BAD_SUBJECT,
    COLONY_DUPLICATE_SUBJECT,
    COLONY_BAD_PRIORITY,
    COLONY_CONTROL_CHAR,
    COLONY_EXPECTED_LABEL,
    COLONY_EXPECTED_NAME,
    COLONY_MISSING_VALUE,
    COLONY_DUPLICATE_NAME,
    COLONY_UNCLOSED_GROUP,
    COLONY_UNMATCHED_CLOSE,
    COLONY_UNTERMINATED_STRING,
    COLONY_BAD_ESCAPE,
    COLONY_TOO_DEEP,
    COLONY_MISSING,            /* getters: no field of that name */
    COLONY_WRONG_TYPE,         /* getters: not a number, not an integer, not a group... */
    COLONY_NO_SPACE,           /* a buffer of yours, or a table of the client, is full */
    COLONY_BAD_ARGUMENT,       /* a subject that cannot be one, a short key, ... */
    COLONY_SYSTEM              /* a socket call failed: see errno */
} colony_status;

/* Where a packet went wrong: 1-based line and byte column, as the Rust parser says. */
typedef struct colony_error {
    colony_status status;
    unsigned line, column;
} colony_error;

/* A name for a status: "duplicate-name", the corpus files' spelling. */
const char *colony_status_name(colony_status s);

/* A run of bytes inside a packet (never NUL-terminated). */
typedef struct colony_span {
    const char *ptr;
    size_t len;
} colony_span;

/* Whether a span holds exactly the C string s. */
int colony_span_is(colony_span a, const char *s);

/* A valid packet, pointing into the bytes it was parsed from. */
typedef struct colony_packet {
    const char *text;
    size_t len;
    colony_span subjects;      /* "<a> <b>" as written */
    unsigned subject_count;
    int32_t priority;
    size_t body;               /* offset of the second line */
} colony_packet;

/* Checks a datagram; COLONY_OK and *p filled, or the first error with its place.
 * A packet with a line or group of more than 16 names needs a table of names:
 * colony_parse() then takes about 110 KB of stack (under 4 KB otherwise); on
 * a thread with a small stack, use colony_parse_ws() (colony_recv() does). */
colony_status colony_parse(colony_packet *p, const void *data, size_t len, colony_error *err);

/* The most names a packet can hold: each takes at least 3 bytes (`A()`). */
#define COLONY_MAX_NAMES (COLONY_MAX_PACKET / 3 + 1)
#define COLONY_TABLE_SLOTS 32768 /* > COLONY_MAX_NAMES * 3 / 2: a probe always ends */

/* The parser's table of names, somewhere other than the stack. Zero it once
 * before its first use (declare it static, or memset it); every parse leaves
 * it empty again. One workspace serves one parse at a time. */
typedef struct colony_workspace {
    uint16_t table[COLONY_TABLE_SLOTS];
    uint16_t undo[COLONY_MAX_NAMES];
    uint64_t seed;   /* the table's hash key; 0: one made from the stack's place and the clocks */
    uint64_t probes; /* table slots the last parse looked at: a bound on its work, for tests */
} colony_workspace;

/* colony_parse() with the table in *ws, so it needs under 4 KB of stack. */
colony_status colony_parse_ws(colony_packet *p, const void *data, size_t len, colony_error *err,
                              colony_workspace *ws);

/* Walks the header's subjects: start with *at = 0; 1 while there is another. */
int colony_next_subject(const colony_packet *p, size_t *at, colony_span *subject);
int colony_has_subject(const colony_packet *p, const char *subject);

/* One body line: its label, and its fields as text to walk with colony_next_field(). */
typedef struct colony_line {
    colony_span label;
    colony_span fields;        /* after the label, to the line's end */
    unsigned number;           /* 1-based line of the packet */
    size_t next;               /* where the walk resumes */
} colony_line;

/* Walks the body's lines (blank ones skipped): zero *line first; 1 while there is another. */
int colony_next_line(const colony_packet *p, colony_line *line);
/* The next line labelled `label`, after *line (zero it to start from the top). */
int colony_find_line(const colony_packet *p, const char *label, colony_line *line);

typedef enum colony_kind { COLONY_BARE, COLONY_QUOTED, COLONY_GROUP } colony_kind;

/* One `name value` pair. A quoted value is the raw text between the quotes,
 * escapes unresolved (colony_unescape() resolves them); a group's value is the
 * text between its parentheses, to walk with colony_next_field() again. */
typedef struct colony_field {
    colony_span name;
    colony_kind kind;
    colony_span value;
} colony_field;

/* Takes the next field off the front of *fields; 1 while there is one. Only
 * for spans from a parsed packet (a line's fields or a group's value). */
int colony_next_field(colony_span *fields, colony_field *field);

/* A field's bare value as a number (Rust's f64 grammar: 1e5, .5, inf, NaN;
 * no hex; any length; "." whatever the locale) or a 64-bit integer;
 * COLONY_WRONG_TYPE otherwise. */
colony_status colony_field_f64(const colony_field *f, double *out);
colony_status colony_field_i64(const colony_field *f, int64_t *out);

/* Typed getters over a line's fields or a group's value, by name. */
colony_status colony_get(colony_span fields, const char *name, colony_field *out);
colony_status colony_get_f64(colony_span fields, const char *name, double *out);
colony_status colony_get_i64(colony_span fields, const char *name, int64_t *out);
colony_status colony_get_group(colony_span fields, const char *name, colony_span *out);
/* The text of a bare or quoted value, unescaped, into buf. When cap > 0, buf
 * is always NUL-terminated: "" on an error, and with COLONY_NO_SPACE as much
 * of the text as fits (cut before a character that does not fit whole). */
colony_status colony_get_str(colony_span fields, const char *name, char *buf, size_t cap);
/* A value's text, unescaped, into buf, as colony_get_str() writes it. */
colony_status colony_unescape(const colony_field *f, char *buf, size_t cap);

/* Builds a packet in buf. Labels, names and bare tokens must be non-empty runs
 * of bare bytes (no blank, control, quote or parenthesis): anything else
 * fails the builder with COLONY_BAD_ARGUMENT, so user data cannot start a line
 * of its own (pass text with colony_put_text(), which quotes it). On any
 * failure (that, or a full buffer) buf is emptied (len 0, buf[0] = 0), every
 * later colony_put_* call does nothing, and colony_finish() reports it. */
typedef struct colony_builder {
    char *buf;
    size_t cap, len;
    int depth;
    colony_status failed;
} colony_builder;

/* Starts `@ <a> <b> priority`; subjects are names separated by blanks ("vision", "a b"),
 * each 1 to 64 of a-z A-Z 0-9 _ - . : / (COLONY_BAD_ARGUMENT otherwise). */
void colony_begin(colony_builder *b, char *buf, size_t cap, const char *subjects, int32_t priority);
void colony_put_line(colony_builder *b, const char *label);
void colony_put_int(colony_builder *b, const char *name, int64_t value);
/* Written so that it reads back to the same double (NaN, inf and -inf
 * included), with "." whatever the locale. */
void colony_put_f64(colony_builder *b, const char *name, double value);
void colony_put_text(colony_builder *b, const char *name, const char *text); /* quoted */
void colony_put_bare(colony_builder *b, const char *name, const char *token);
void colony_put_open(colony_builder *b, const char *name);                  /* name ( */
void colony_put_close(colony_builder *b);                                   /* ) */
/* Appends printf's output as is: colony_putf(&b, "ball x %.2f y %.2f", x, y).
 * Nothing is checked until colony_finish() (which checks the whole packet),
 * so never give it untrusted text: a newline in it starts a line. Its numbers
 * follow the program's locale (printf's %f writes "0,5" under de_DE). */
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
void colony_putf(colony_builder *b, const char *fmt, ...);
/* Ends the packet, checks it with colony_parse(), and returns its length; on
 * an error, 0 with *err (line and column 0 for a builder error), and buf emptied. */
size_t colony_finish(colony_builder *b, colony_error *err);

/* HMAC-SHA256 (colony_sha256.c), as `auth n N mac M` lines need. */
void colony_hmac_sha256(const void *key, size_t key_len, const void *msg, size_t msg_len,
                        unsigned char out[32]);
void colony_sha256(const void *msg, size_t len, unsigned char out[32]);

/* Appends `auth n N mac <64 hex>` to the packet of `*len` bytes in buf (which
 * must have room for 100 more bytes), as colony_wire::auth::Key::sign does. */
colony_status colony_sign(char *buf, size_t *len, size_t cap, const void *key, size_t key_len,
                          uint64_t n);

#define COLONY_MAX_SUBS 64
#define COLONY_RECENT 8
#define COLONY_MAX_REQUEST 256
#define COLONY_RECV_BUDGET 64 /* datagrams taken between two colony_poll() calls */
#define COLONY_KEY_BLOCK 64   /* HMAC-SHA256's block: longer keys are kept hashed */

/* A client of one hub. Declare it where you like (it holds two datagram
 * buffers and the parser's workspace, about 240 KB); it is filled by
 * colony_connect(). Read its fields, but change them only through the
 * functions below. */
typedef struct colony_client {
    int fd;
    struct {
        char name[COLONY_MAX_SUBJECT_LEN + 1];
        int64_t added, last_data, last_request; /* -1: never */
    } subs[COLONY_MAX_SUBS];
    int sub_count;
    struct {
        int64_t at;
        char lines[COLONY_MAX_REQUEST];
    } recent[COLONY_RECENT]; /* one-off requests lately sent, to send again for a new cookie */
    int64_t clock, started, last_from_hub, last_asked, last_cookie; /* -1: never */
    int64_t lease_ms;        /* the hub's lease, once it said; -1 before */
    char cookie[17];
    int has_min_priority;    /* a console's standing minimum priority, refreshed as a lease */
    int32_t min_priority;
    int64_t min_priority_asked;
    unsigned char key[COLONY_KEY_BLOCK]; /* the key, or SHA-256 of a longer one (same MACs) */
    size_t key_len;          /* 0: nothing is signed */
    uint64_t last_n;
    uint64_t malformed;      /* datagrams from the hub's address that did not parse */
    uint64_t leases, cookies;
    uint64_t refused;        /* errors received for an earlier datagram (ECONNREFUSED, EHOSTUNREACH, ...) */
    uint64_t unsent;         /* datagrams lost on sending (a full buffer, EHOSTUNREACH, ...) */
    int since_poll;          /* datagrams taken (and receive calls retried) since colony_poll() */
    colony_workspace ws;     /* the parser's table, seeded from /dev/urandom */
    char in[COLONY_MAX_PACKET + 1];
    char out[COLONY_MAX_PACKET + 1];
} colony_client;

/* The monotonic clock the client's `now` arguments are read from, in ms. */
int64_t colony_now_ms(void);

/* Opens a socket to the hub at "host:port" ("127.0.0.1:7400", "[::1]:7400").
 * A host name is looked up with getaddrinfo(), which may block (DNS); a
 * numeric address never does. The socket is close-on-exec. */
colony_status colony_connect(colony_client *c, const char *hub, int64_t now);
/* Closes the socket and wipes the key. */
void colony_close(colony_client *c);
/* The socket to wait on for reading (poll, select, epoll, your GUI's loop). */
int colony_fd(const colony_client *c);
/* When colony_poll() next has work to do (ms, colony_now_ms()'s clock), or -1
 * for never; the client's latest `now` once colony_recv() has spent its budget. */
int64_t colony_deadline(const colony_client *c);
/* Does what is due by now: lease refreshes, resubscribing silent channels.
 * It also renews colony_recv()'s budget, so call it on every turn of the loop. */
colony_status colony_poll(colony_client *c, int64_t now);

colony_status colony_subscribe(colony_client *c, const char *subject, int64_t now);
colony_status colony_unsubscribe(colony_client *c, const char *subject, int64_t now);
/* Sends control request lines ("status\n", ...) to the hub, with the cookie in front. */
colony_status colony_request(colony_client *c, const char *lines, int64_t now);
/* A console's override: drop everything below `value` at the hub, kept as a
 * lease (it lapses if this program dies); INT32_MIN lifts it. Needs the hub's
 * console address or its key (colony_set_key). */
colony_status colony_set_min_priority(colony_client *c, int32_t value, int64_t now);
/* Signs everything sent from now on, for a hub started with --key (the key
 * file's bytes; trailing whitespace is not part of the key). */
colony_status colony_set_key(colony_client *c, const void *key, size_t len);

/* Publishes a packet (checked first: a bad one fails here, with its place). */
colony_status colony_publish(colony_client *c, const void *data, size_t len, colony_error *err);

/* The next packet the hub forwarded: COLONY_OK with *p pointing into the
 * client's buffer (valid until the next colony_recv), a parse error (with
 * *err) for a datagram that did not parse (it is counted and dropped; call
 * again), COLONY_SYSTEM, or COLONY_AGAIN: nothing is waiting, or
 * COLONY_RECV_BUDGET datagrams (of any kind) have been taken since the last
 * colony_poll(). So a flood cannot hold your loop away from colony_poll()
 * and its lease refreshes; what is left stays in the socket, which stays
 * readable: wait on it level-triggered (poll, select, epoll without
 * EPOLLET), or call colony_poll() and colony_recv() again at once. Leases
 * and cookies are taken in along the way; status reports are returned as
 * packets. */
colony_status colony_recv(colony_client *c, colony_packet *p, colony_error *err, int64_t now);

/* Whether anything was heard from the hub within `within_ms`. */
int colony_hub_alive(const colony_client *c, int64_t now, int64_t within_ms);

#ifdef __cplusplus
}
#endif
#endif
