/* A robot controller in C for `colony sort live`: it watches `vision` and
 * drives one robot on `radio`, as the Broker paper's AI processes did.
 *
 *   colony hub &
 *   colony sort live --controllers external &      # the world, no controllers
 *   ./build/sort_robot 127.0.0.1:7400 0            # drive robot 0 from C
 *
 * (Start `colony sort robot --id N` for the other robots, or leave them be.)
 * Its behaviour is deliberately simple: head for the nearest puck (one in its
 * own gripper excepted), and turn back toward the middle near a wall. The
 * loop is the program's own: poll() on the client's socket until its next
 * deadline.
 */
#define _POSIX_C_SOURCE 200809L
#include "colony.h"

#include <math.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct world {
    double arena_w, arena_h; /* from the frame's first part; 0 until known */
    double x, y, theta;
    int seen;                /* our robot was in the last packet */
    double target_x, target_y;
} world;

/* Reads one `vision` packet: our robot's pose, and the nearest puck. A large
 * swarm's frame comes in parts; each stands alone, so the robot steers by the
 * pucks of the part that holds it (the arena comes with part 0). */
static void read_vision(const colony_packet *p, long id, world *w)
{
    colony_line l;
    double best = INFINITY, px, py, x, y, theta;
    int64_t rid;
    memset(&l, 0, sizeof l);
    if (colony_find_line(p, "arena", &l)) {
        colony_get_f64(l.fields, "width", &w->arena_w);
        colony_get_f64(l.fields, "height", &w->arena_h);
    }
    w->seen = 0;
    memset(&l, 0, sizeof l);
    /* The pose is taken whole or not at all. */
    while (colony_find_line(p, "robot", &l))
        if (colony_get_i64(l.fields, "id", &rid) == COLONY_OK && rid == id &&
            colony_get_f64(l.fields, "x", &x) == COLONY_OK &&
            colony_get_f64(l.fields, "y", &y) == COLONY_OK &&
            colony_get_f64(l.fields, "theta", &theta) == COLONY_OK) {
            w->x = x;
            w->y = y;
            w->theta = theta;
            w->seen = 1;
        }
    if (!w->seen) return;
    w->target_x = w->target_y = 0;
    memset(&l, 0, sizeof l);
    while (colony_find_line(p, "puck", &l)) {
        if (colony_get_f64(l.fields, "x", &px) != COLONY_OK ||
            colony_get_f64(l.fields, "y", &py) != COLONY_OK)
            continue;
        double d = hypot(px - w->x, py - w->y);
        if (d > 5 && d < best) {
            best = d;
            w->target_x = px;
            w->target_y = py;
        }
    }
    /* Within 25 cm of a wall, the middle comes first. */
    if (w->arena_w > 0 && (fabs(w->x) > w->arena_w / 2 - 25 || fabs(w->y) > w->arena_h / 2 - 25))
        w->target_x = w->target_y = 0;
}

static size_t command(const world *w, long id, char *buf, size_t cap)
{
    double err = atan2(w->target_y - w->y, w->target_x - w->x) - w->theta;
    err = atan2(sin(err), cos(err)); /* into (-pi, pi] */
    double turn = fmax(-1, fmin(1, 2 * err)), forward = fabs(err) < 0.6 ? 0.7 : 0.1;
    colony_builder b;
    colony_begin(&b, buf, cap, "radio", 0);
    colony_put_line(&b, "cmd");
    colony_put_int(&b, "id", id);
    colony_putf(&b, " forward %.2f turn %.2f", forward, turn);
    return colony_finish(&b, NULL);
}

int main(int argc, char **argv)
{
    static colony_client c;
    char out[256];
    world w;
    memset(&w, 0, sizeof w);
    if (argc < 3) {
        fprintf(stderr, "usage: sort_robot HUB:PORT ROBOT_ID [SECONDS]\n");
        return 2;
    }
    long id = atol(argv[2]);
    double seconds = argc > 3 ? atof(argv[3]) : -1;
    if (argc > 3 && !(seconds >= 0 && seconds <= 365.0 * 86400)) {
        fprintf(stderr, "sort_robot: SECONDS is from 0 to a year\n");
        return 2;
    }
    int64_t now = colony_now_ms(), end = seconds >= 0 ? now + (int64_t)(seconds * 1000) : -1;
    int64_t last_report = now;
    long frames = 0, commands = 0, skipped = 0;
    if (colony_connect(&c, argv[1], now) != COLONY_OK || colony_subscribe(&c, "vision", now) != COLONY_OK) {
        perror("sort_robot: cannot reach the hub");
        return 1;
    }
    while (end < 0 || now < end) {
        int64_t deadline = colony_deadline(&c);
        int wait = deadline < 0 ? 1000 : (int)(deadline > now ? deadline - now : 0);
        struct pollfd pfd = {colony_fd(&c), POLLIN, 0};
        poll(&pfd, 1, wait > 1000 ? 1000 : wait);
        now = colony_now_ms();
        colony_poll(&c, now);
        colony_packet p;
        colony_error e;
        colony_status st;
        /* COLONY_AGAIN ends the inner loop at least every COLONY_RECV_BUDGET
         * datagrams, so colony_poll() keeps the lease through any flood. */
        while ((st = colony_recv(&c, &p, &e, now)) != COLONY_AGAIN) {
            if (st == COLONY_SYSTEM) {
                perror("sort_robot: recv");
                break;
            }
            if (st != COLONY_OK) {
                /* Counted, and said once a second below: a flood of them must
                 * not become a flood on stderr. */
                if (skipped++ == 0)
                    fprintf(stderr, "sort_robot: skipped a datagram: %s at line %u, column %u\n",
                            colony_status_name(st), e.line, e.column);
                continue;
            }
            if (!colony_has_subject(&p, "vision")) continue;
            frames++;
            read_vision(&p, id, &w);
            size_t n = w.seen ? command(&w, id, out, sizeof out) : 0;
            if (n > 0 && colony_publish(&c, out, n, NULL) == COLONY_OK) commands++;
        }
        if (now - last_report >= 1000) {
            printf("robot %ld x %.1f y %.1f theta %.2f frames %ld commands %ld skipped %ld\n", id,
                   w.x, w.y, w.theta, frames, commands, skipped);
            fflush(stdout);
            last_report = now;
        }
    }
    colony_close(&c);
    return 0;
}
