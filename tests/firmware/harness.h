/* Host side of the firmware tests: drive a wdr_fw on the fake board through the wire protocol,
 * collect responses and frames, build tables. */
#ifndef HARNESS_H
#define HARNESS_H
#include "fake_hal.h"
#include "table_builders.h"
#include "wdr_fw.h"
#include "wdr_proto.h"
#include <stdint.h>

#define TH_NO_RESPONSE (-1)

/* What the board sent during the last request. */
typedef struct th_capture {
    uint16_t px[FB_HEIGHT][FB_WIDTH]; /* rows of the last frame seen */
    int rows;                         /* ROW packets seen */
    int frame_ends;
    wdr_frame_end last_end;
} th_capture;

extern th_capture th_cap;

/* wdr_fw_init, then run until idle. Returns wdr_fw_init's result. */
int th_boot(wdr_fw *fw);

/* Run the task loop until nothing is ready and nothing is scheduled. */
void th_run(wdr_fw *fw);

/* Send raw bytes to the board, run, collect. */
void th_send_raw(wdr_fw *fw, const void *bytes, size_t n);

/* Send one request with the next sequence number (or seq >= 0 to force one); run; return the
 * response status (TH_NO_RESPONSE if none). resp (may be NULL) gets up to cap payload bytes. */
int th_request_seq(wdr_fw *fw, int seq, uint8_t op, const void *payload, uint32_t len, uint8_t *resp, uint32_t cap);
int th_request(wdr_fw *fw, uint8_t op, const void *payload, uint32_t len, uint8_t *resp, uint32_t cap);
int th_last_seq(void);

/* BEGIN(len, crc of data) + chunks of chunk bytes + COMMIT; the first failing status, or the
 * commit's. reply (may be NULL) gets the commit reply. */
int th_upload(wdr_fw *fw, int kind, const uint8_t *data, uint32_t len, uint32_t chunk, wdr_commit_reply *reply);

/* STATUS of the board. */
wdr_status_report th_status(wdr_fw *fw);

/* CAPTURE n frames; returns the status, frames land in th_cap. */
int th_capture_frames(wdr_fw *fw, uint32_t n);

#endif
