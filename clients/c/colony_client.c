/* The hub client: crates/client/src/session.rs's rules over one non-blocking
 * UDP socket. It sends when asked or when colony_poll() finds something due,
 * and otherwise does nothing: the loop is the application's. */
#define _POSIX_C_SOURCE 200809L
#include "colony.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <netdb.h>
#include <netinet/in.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#define REFRESH_MS 3000          /* well inside the hub's default 10 s lease */
#define RESUBSCRIBE_MS 1000      /* a channel silent this long is asked for again */
#define RESEND_WITHIN_MS 2000    /* requests this recent are resent for a new cookie */
#define COOKIE_EVERY_MS 250      /* forged cookies, alternating, must not make us chatter */
#define MIN_LEASE_MS 100
#define MAX_LEASE_MS 86400000

int64_t colony_now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (int64_t)t.tv_sec * 1000 + t.tv_nsec / 1000000;
}

static uint64_t unix_micros(void)
{
    struct timespec t;
    clock_gettime(CLOCK_REALTIME, &t);
    return t.tv_sec < 0 ? 0 : (uint64_t)t.tv_sec * 1000000u + (uint64_t)t.tv_nsec / 1000u;
}

/* Whether a send or receive error concerns one datagram rather than the
 * socket: an ICMP error that came back for an earlier datagram (port or
 * protocol refused, host or network unreachable, down or isolated,
 * administratively prohibited, too big for the path, a bad parameter), a full
 * buffer, or a signal. The next datagram may well pass, so a robot's program
 * outlives a Wi-Fi gap; the loss is counted. */
static int transient(int e)
{
#ifdef ENONET /* Linux's "host isolated" */
    if (e == ENONET) return 1;
#endif
    return e == ECONNREFUSED || e == EHOSTUNREACH || e == ENETUNREACH || e == EHOSTDOWN ||
           e == ENETDOWN || e == EACCES || e == EMSGSIZE || e == EPROTO || e == ENOPROTOOPT ||
           e == ENOBUFS || e == EAGAIN || e == EWOULDBLOCK || e == EINTR;
}

static void tick(colony_client *c, int64_t now)
{
    if (now > c->clock) c->clock = now;
}

/* Sends one datagram, signed when the client has a key. A hub that is down
 * (refused) or a full buffer loses this one datagram; the session recovers. */
static colony_status send_datagram(colony_client *c, const char *data, size_t len)
{
    if (c->key_len > 0) {
        if (data != c->out) {
            if (len > sizeof c->out) return COLONY_TOO_LARGE;
            memmove(c->out, data, len);
        }
        uint64_t n = unix_micros();
        c->last_n = n > c->last_n ? n : c->last_n + 1;
        colony_status st = colony_sign(c->out, &len, sizeof c->out, c->key, c->key_len, c->last_n);
        if (st != COLONY_OK) return COLONY_TOO_LARGE;
        data = c->out;
    }
    if (send(c->fd, data, len, 0) < 0) {
        if (!transient(errno)) return COLONY_SYSTEM;
        c->unsent++; /* lost, counted; the session recovers */
    }
    return COLONY_OK;
}

/* A control packet: the cookie first (the hub acts only for an address that
 * proved it receives there), then the request lines. */
static colony_status send_control(colony_client *c, const char *lines)
{
    colony_builder b;
    colony_begin(&b, c->out, sizeof c->out, "hub", 0);
    colony_putf(&b, "cookie v %s\n%s", c->cookie, lines);
    if (b.failed) return b.failed;
    c->last_asked = c->clock;
    return send_datagram(c, b.buf, b.len);
}

/* A one-off request, kept a while in case the hub answers with a cookie instead. */
static colony_status send_once(colony_client *c, const char *lines)
{
    if (strlen(lines) >= COLONY_MAX_REQUEST) return COLONY_NO_SPACE;
    int slot = 0;
    for (int i = 0; i < COLONY_RECENT; i++) {
        if (c->clock - c->recent[i].at >= RESEND_WITHIN_MS) c->recent[i].lines[0] = 0;
        if (c->recent[i].at < c->recent[slot].at) slot = i;
    }
    c->recent[slot].at = c->clock;
    strcpy(c->recent[slot].lines, lines);
    return send_control(c, lines);
}

static int64_t refresh_ms(const colony_client *c)
{
    if (c->lease_ms < 0 || c->lease_ms / 3 >= REFRESH_MS) return REFRESH_MS;
    return c->lease_ms / 3;
}

/* When a subscription next needs asking for: at once when new; then every
 * refresh while data flows, or every second while the channel is silent. */
static int64_t due(const colony_client *c, int i)
{
    int64_t asked = c->subs[i].last_request;
    if (asked < 0) return c->subs[i].added;
    int64_t heard = c->subs[i].last_data > asked ? c->subs[i].last_data : asked;
    int64_t a = asked + refresh_ms(c), b = heard + RESUBSCRIBE_MS;
    return a < b ? a : b;
}

/* A console need not subscribe to anything, so before the hub has said its
 * lease, the minimum is asked for as often as a silent channel. */
static int64_t min_priority_due(const colony_client *c)
{
    return c->min_priority_asked + (c->lease_ms < 0 ? RESUBSCRIBE_MS : refresh_ms(c));
}

int64_t colony_deadline(const colony_client *c)
{
    int64_t next = -1;
    if (c->since_poll >= COLONY_RECV_BUDGET) return c->clock;
    for (int i = 0; i < c->sub_count; i++)
        if (next < 0 || due(c, i) < next) next = due(c, i);
    if (c->has_min_priority && (next < 0 || min_priority_due(c) < next)) next = min_priority_due(c);
    return next;
}

colony_status colony_poll(colony_client *c, int64_t now)
{
    char lines[COLONY_MAX_SUBS * (COLONY_MAX_SUBJECT_LEN + 16) + 1];
    size_t len = 0;
    tick(c, now);
    for (int i = 0; i < c->sub_count; i++) {
        if (due(c, i) > now) continue;
        c->subs[i].last_request = now;
        len += (size_t)sprintf(lines + len, "subscribe ch %s\n", c->subs[i].name);
    }
    colony_status st = COLONY_OK;
    c->since_poll = 0; /* colony_recv() may take another budget's worth */
    if (len > 0) st = send_control(c, lines);
    if (st == COLONY_OK && c->has_min_priority && min_priority_due(c) <= now) {
        c->min_priority_asked = now;
        sprintf(lines, "min_priority value %" PRId32 "\n", c->min_priority);
        st = send_once(c, lines);
    }
    return st;
}

static int valid_subject(const char *s)
{
    size_t n = strlen(s);
    if (n == 0 || n > COLONY_MAX_SUBJECT_LEN || strcmp(s, "hub") == 0) return 0;
    return strspn(s, "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-.:/") == n;
}

colony_status colony_subscribe(colony_client *c, const char *subject, int64_t now)
{
    if (!valid_subject(subject)) return COLONY_BAD_ARGUMENT;
    tick(c, now);
    for (int i = 0; i < c->sub_count; i++)
        if (strcmp(c->subs[i].name, subject) == 0) return COLONY_OK;
    if (c->sub_count == COLONY_MAX_SUBS) return COLONY_NO_SPACE;
    int i = c->sub_count++;
    strcpy(c->subs[i].name, subject);
    c->subs[i].added = now;
    c->subs[i].last_data = c->subs[i].last_request = -1;
    return colony_poll(c, now);
}

colony_status colony_unsubscribe(colony_client *c, const char *subject, int64_t now)
{
    char line[COLONY_MAX_SUBJECT_LEN + 32];
    tick(c, now);
    for (int i = 0; i < c->sub_count; i++) {
        if (strcmp(c->subs[i].name, subject) != 0) continue;
        c->subs[i] = c->subs[--c->sub_count];
        sprintf(line, "unsubscribe ch %s\n", subject);
        return send_once(c, line);
    }
    return COLONY_OK;
}

colony_status colony_request(colony_client *c, const char *lines, int64_t now)
{
    tick(c, now);
    return send_once(c, lines);
}

colony_status colony_set_min_priority(colony_client *c, int32_t value, int64_t now)
{
    char line[48];
    tick(c, now);
    c->has_min_priority = value != INT32_MIN;
    c->min_priority = value;
    c->min_priority_asked = now;
    sprintf(line, "min_priority value %" PRId32 "\n", value);
    return send_once(c, line);
}

colony_status colony_set_key(colony_client *c, const void *key, size_t len)
{
    const unsigned char *k = key;
    /* As colony's key files are read: trailing whitespace is no part of the key. */
    while (len > 0 && (k[len - 1] == ' ' || k[len - 1] == '\t' || k[len - 1] == '\n' ||
                       k[len - 1] == '\r' || k[len - 1] == '\f'))
        len--;
    if (len < COLONY_MIN_KEY_LEN) return COLONY_BAD_ARGUMENT;
    /* HMAC hashes a key longer than its block first, so keeping the hash
     * signs exactly as the whole key would, whatever its length. */
    if (len > sizeof c->key) {
        colony_sha256(k, len, c->key);
        c->key_len = 32;
    } else {
        memcpy(c->key, k, len);
        c->key_len = len;
    }
    return COLONY_OK;
}

colony_status colony_publish(colony_client *c, const void *data, size_t len, colony_error *err)
{
    colony_packet p;
    colony_status st = colony_parse(&p, data, len, err);
    return st != COLONY_OK ? st : send_datagram(c, data, len);
}

/* The hub did not know us (a new client, or a restarted hub): ask again, now
 * with its cookie, for everything it may not have acted on. */
static void take_cookie(colony_client *c, int64_t now, const char *v)
{
    /* The same cookie again means the hub refused it for a reason of its own:
     * asking again at once could only loop. */
    if (memcmp(v, c->cookie, 16) == 0 || memcmp(v, "0000000000000000", 16) == 0) return;
    int asked = c->last_asked >= 0 && now - c->last_asked < RESEND_WITHIN_MS;
    int too_soon = c->last_cookie >= 0 && now - c->last_cookie < COOKIE_EVERY_MS;
    if (!asked || too_soon) return;
    memcpy(c->cookie, v, 16);
    c->last_cookie = now;
    /* One-off requests first: an unsubscribe then a subscribe to the same
     * channel must end subscribed. Oldest first, as they were sent. */
    int order[COLONY_RECENT], n = 0;
    for (int i = 0; i < COLONY_RECENT; i++)
        if (c->recent[i].lines[0] && now - c->recent[i].at < RESEND_WITHIN_MS) order[n++] = i;
    for (int i = 1; i < n; i++)
        for (int j = i; j > 0 && c->recent[order[j]].at < c->recent[order[j - 1]].at; j--) {
            int t = order[j];
            order[j] = order[j - 1];
            order[j - 1] = t;
        }
    for (int i = 0; i < n; i++) {
        c->recent[order[i]].at = now; /* sent again, so kept again, as session.rs does */
        send_control(c, c->recent[order[i]].lines);
    }
    for (int i = 0; i < c->sub_count; i++) c->subs[i].last_request = -1;
    int spent = c->since_poll; /* called from colony_recv(): its budget stays spent */
    colony_poll(c, now);
    c->since_poll = spent;
}

/* A cookie as control.rs reads one: 16 lowercase hex digits, bare or quoted. */
static int read_cookie(colony_span fields, char out[17])
{
    if (colony_get_str(fields, "v", out, 17) != COLONY_OK || strlen(out) != 16) return 0;
    return strspn(out, "0123456789abcdef") == 16;
}

/* Takes in the hub's lease and cookie replies; 1 when the packet was one.
 * A status report is returned as a packet, and changes nothing here: its
 * lease_ms is the hub's setting, not a grant (session.rs ignores it too). */
static int hub_reply(colony_client *c, const colony_packet *p, int64_t now)
{
    colony_line line = {{0, 0}, {0, 0}, 0, 0};
    if (p->subject_count != 1 || !colony_has_subject(p, "hub") || !colony_next_line(p, &line))
        return 0;
    int64_t ms;
    char cookie[17];
    if (colony_span_is(line.label, "lease")) {
        if (colony_get_i64(line.fields, "ms", &ms) != COLONY_OK) return 0;
        /* A forged `lease ms 0` must not set the client chattering. */
        c->lease_ms = ms < MIN_LEASE_MS ? MIN_LEASE_MS : ms > MAX_LEASE_MS ? MAX_LEASE_MS : ms;
        c->leases++;
        return 1;
    }
    if (colony_span_is(line.label, "cookie")) {
        if (!read_cookie(line.fields, cookie)) return 0;
        c->cookies++;
        take_cookie(c, now, cookie);
        return 1;
    }
    return 0;
}

colony_status colony_recv(colony_client *c, colony_packet *p, colony_error *err, int64_t now)
{
    colony_error ignored;
    if (!err) err = &ignored;
    tick(c, now);
    /* Replies are taken in here without returning. Every datagram (and every
     * retried call) spends the budget colony_poll() renews, so no flood, of
     * replies, data or garbage, can keep the application's loop from
     * colony_poll() and its lease refreshes. The socket stays readable. */
    while (c->since_poll < COLONY_RECV_BUDGET) {
        c->since_poll++;
        ssize_t n = recv(c->fd, c->in, sizeof c->in, 0);
        if (n < 0) {
            if (errno == EAGAIN || errno == EWOULDBLOCK) {
                c->since_poll--; /* nothing was taken */
                return COLONY_AGAIN;
            }
            if (errno == EINTR) continue;
            /* An error that came back for an earlier datagram: the hub's port
             * was closed (it is down) or its network unreachable. The silent
             * channels will be asked for again once it answers. */
            if (transient(errno)) {
                c->refused++;
                continue;
            }
            return COLONY_SYSTEM;
        }
        c->last_from_hub = now;
        colony_status st = colony_parse_ws(p, c->in, (size_t)n, err, &c->ws);
        if (st != COLONY_OK) {
            c->malformed++;
            return st;
        }
        if (hub_reply(c, p, now)) continue;
        for (int i = 0; i < c->sub_count; i++)
            if (colony_has_subject(p, c->subs[i].name)) c->subs[i].last_data = now;
        return COLONY_OK;
    }
    return COLONY_AGAIN;
}

int colony_hub_alive(const colony_client *c, int64_t now, int64_t within_ms)
{
    return c->last_from_hub >= 0 && now - c->last_from_hub < within_ms;
}

/* The parser's hash key: from /dev/urandom, or where this client lies and
 * the clocks when it cannot be read (then as plain colony_parse() does). */
static uint64_t random_seed(const colony_client *c)
{
    uint64_t seed = 0;
    int fd = open("/dev/urandom", O_RDONLY | O_CLOEXEC);
    if (fd >= 0) {
        if (read(fd, &seed, sizeof seed) != (ssize_t)sizeof seed) seed = 0;
        close(fd);
    }
    if (seed == 0)
        seed = (uint64_t)(uintptr_t)c * 0x9e3779b97f4a7c15u ^ (uint64_t)time(NULL) ^
               (uint64_t)clock() << 32 ^ unix_micros();
    return seed ? seed : 1;
}

colony_status colony_connect(colony_client *c, const char *hub, int64_t now)
{
    char host[256];
    const char *colon = strrchr(hub, ':');
    memset(c, 0, sizeof *c);
    c->fd = -1;
    size_t n = colon ? (size_t)(colon - hub) : 0;
    if (!colon || n == 0 || n >= sizeof host) return COLONY_BAD_ARGUMENT;
    if (hub[0] == '[' && hub[n - 1] == ']') {
        memcpy(host, hub + 1, n - 2);
        host[n - 2] = 0;
    } else {
        memcpy(host, hub, n);
        host[n] = 0;
    }
    struct addrinfo hints, *ai;
    memset(&hints, 0, sizeof hints);
    hints.ai_socktype = SOCK_DGRAM;
    if (getaddrinfo(host, colon + 1, &hints, &ai) != 0) return COLONY_BAD_ARGUMENT;
#ifdef SOCK_CLOEXEC
    c->fd = socket(ai->ai_family, SOCK_DGRAM | SOCK_CLOEXEC, 0);
#else
    c->fd = socket(ai->ai_family, SOCK_DGRAM, 0);
    if (c->fd >= 0) fcntl(c->fd, F_SETFD, FD_CLOEXEC);
#endif
    /* Connected: the kernel passes us datagrams from the hub's address only.
     * The kernel binds us to loopback when the hub is local, so nothing else
     * can reach us. */
    if (c->fd < 0 || connect(c->fd, ai->ai_addr, ai->ai_addrlen) != 0 ||
        fcntl(c->fd, F_SETFL, fcntl(c->fd, F_GETFL) | O_NONBLOCK) != 0) {
        int e = errno;
        if (c->fd >= 0) close(c->fd);
        freeaddrinfo(ai);
        c->fd = -1;
        errno = e;
        return COLONY_SYSTEM;
    }
    freeaddrinfo(ai);
    c->clock = c->started = now;
    c->last_from_hub = c->last_asked = c->last_cookie = c->lease_ms = -1;
    for (int i = 0; i < COLONY_RECENT; i++) c->recent[i].at = INT64_MIN / 2;
    memcpy(c->cookie, "0000000000000000", 17);
    c->ws.seed = random_seed(c);
    return COLONY_OK;
}

void colony_close(colony_client *c)
{
    if (c->fd >= 0) close(c->fd);
    c->fd = -1;
    /* Through a volatile pointer, so the compiler cannot drop the stores. */
    volatile unsigned char *k = c->key;
    for (size_t i = 0; i < sizeof c->key; i++) k[i] = 0;
    c->key_len = 0;
}

int colony_fd(const colony_client *c) { return c->fd; }
