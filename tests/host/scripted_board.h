/* A scripted stand-in for a board on the other end of a socket: it decodes requests with the
 * firmware's codec and lets each test decide, per request, what goes back (a good answer,
 * nothing, garbage, a broken frame, a hang-up). Runs in its own thread; every wait is bounded. */
#ifndef FAKE_BOARD_H
#define FAKE_BOARD_H
#include "wdr_proto.h"
#include <pthread.h>
#include <stdint.h>

typedef struct scripted_board scripted_board;

/* What to do with one request; return 0 to go on, -1 to hang up. n is the request's index. */
typedef int (*fake_script)(scripted_board *b, const wdr_packet *req, int n);

struct scripted_board {
    int fd;                 /* connected socket, or -1 until accepted */
    int listen_fd;          /* -1 when built on a socketpair */
    fake_script script;
    void *user;
    int requests;           /* requests seen */
    int opcodes[256];       /* request count per opcode */
    uint16_t last_seq;
    uint16_t width, height;
    int sessions;           /* hosts served one after the other on a listening socket (0: one) */
    pthread_t thread;
    volatile int stop;
};

/* Serve an already connected fd (one end of a socketpair). */
void scripted_board_start_fd(scripted_board *b, int fd, fake_script script);

/* Listen on path, accept one host, serve it. */
int scripted_board_start_listen(scripted_board *b, const char *path, fake_script script);

/* Stop the thread and close the sockets. */
void scripted_board_stop(scripted_board *b);

/* Send a response to req with status and payload (len bytes). */
void fake_reply(scripted_board *b, const wdr_packet *req, int status, const void *payload, uint32_t len);

/* Send a response whose payload CRC is wrong. */
void fake_reply_bad_crc(scripted_board *b, const wdr_packet *req);

/* Send raw bytes. */
void fake_send_raw(scripted_board *b, const void *bytes, size_t len);

/* Send an event (ROW or FRAME_END) carrying seq. */
void fake_event(scripted_board *b, uint8_t opcode, uint16_t seq, const void *payload, uint32_t len);

/* The INFO answer of a small board (width x height, 12-bit). */
void fake_reply_info(scripted_board *b, const wdr_packet *req, uint16_t major);

/* A script that answers everything well: INFO, STATUS, uploads (commit with the right CRC), and
 * CAPTURE with whole frames of value (row + frame) */
int fake_script_good(scripted_board *b, const wdr_packet *req, int n);

#endif
