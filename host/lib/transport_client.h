/* Host side of the wire protocol (firmware/SPEC.md) over a transport: connect with a version
 * check, numbered requests with bounded timeouts and retries (the board answers a repeated
 * sequence number from its cache, so a retry never executes twice), chunked uploads that
 * compare the CRC the board read back, and frame capture from ROW/FRAME_END events. */
#ifndef WDR_TRANSPORT_CLIENT_H
#define WDR_TRANSPORT_CLIENT_H
#include "transport.h"
#include "wdr_image.h"
#include "wdr_proto.h"
#include <stddef.h>
#include <stdint.h>

/* WDR_E_STATUS (see wdr_client.status) and WDR_E_PROTOCOL are in wdr_err.h. */

#define WDR_CLIENT_TIMEOUT_MS 2000 /* per attempt, default */
#define WDR_CLIENT_RETRIES 2       /* extra attempts after a timeout or a garbled answer */

/* Called for every event packet (ROW, FRAME_END) while a request waits or a capture runs.
 * Return WDR_OK to go on, or an error to stop the capture with it. */
typedef int (*wdr_event_fn)(void *ctx, const wdr_packet *p);

/* Called after each chunk of an upload with bytes sent and total. */
typedef void (*wdr_progress_fn)(void *ctx, size_t done, size_t total);

typedef struct wdr_client {
    wdr_transport *t;            /* not owned */
    int timeout_ms, retries;     /* set before connect: timeout 0 and retries < 0 take the defaults;
                                    retries 0 is one attempt */
    uint16_t seq;                /* last sequence number used */
    int status;                  /* enum wdr_status of the last response */
    wdr_info info;               /* from connect */
    uint32_t retries_used;       /* attempts repeated since connect (for tests and reports) */
    uint64_t tx_bytes, rx_bytes; /* bytes on the link since connect, framing included (wire time) */
    int commit_unknown;          /* the link failed during the last upload's COMMIT: the board may
                                    or may not have made the table active (ask STATUS) */
    wdr_event_fn on_event;
    void *event_ctx;
    wdr_proto_decoder dec;
    uint8_t tx[WDR_PROTO_MAX_FRAME];
    uint8_t reply[WDR_PROTO_MAX_PAYLOAD]; /* payload of the last response */
    uint32_t reply_len;
    uint8_t rx[16384];           /* received bytes not yet fed to the decoder */
    size_t rx_pos, rx_len;
    uint32_t garbled[2];         /* answers to the last request: [0] bad payload CRC, [1] oversize */
    char err[256];               /* message for the last failure */
} wdr_client;

/* Ask INFO with our protocol version; fills c->info.
 * @retval WDR_OK
 * @retval WDR_E_VERSION   the board speaks another major version (message names both)
 * @retval WDR_E_TIMEOUT, WDR_E_IO, WDR_E_PROTOCOL */
int wdr_client_connect(wdr_client *c, wdr_transport *t);

/* One request and its response; the response payload is in c->reply / c->reply_len.
 * @retval WDR_OK         status OK
 * @retval WDR_E_STATUS   the board refused: c->status says why, c->err too
 * @retval WDR_E_TIMEOUT  no answer after the retries
 * @retval WDR_E_IO       the board disconnected
 * @retval WDR_E_PROTOCOL an answer with the wrong opcode or flags */
int wdr_client_request(wdr_client *c, uint8_t opcode, const void *payload, uint32_t len);

int wdr_client_status(wdr_client *c, wdr_status_report *out);

/* Upload a table (kind: enum wdr_table_kind) in chunks, commit, and compare the CRC the board
 * read back from flash with ours. progress may be NULL. A link failure on the COMMIT itself
 * sets c->commit_unknown: the table may be active all the same.
 * @retval WDR_OK, request errors, WDR_E_CORRUPT (board stored other bytes than we sent) */
int wdr_client_upload(wdr_client *c, int kind, const uint8_t *table, size_t len, wdr_progress_fn progress,
                      void *progress_ctx, wdr_commit_reply *out);

/* ---- Firmware images (protocol 1.4; WDR_E_UNSUPPORTED from an older board) ---------------- */

typedef struct wdr_fw_commit {
    uint8_t slot;                /* 0 (A) or 1 (B): where the image waits, pending */
    wdr_image_header hdr;        /* its header, as the board read it back */
} wdr_fw_commit;

/* Upload a signed image (FW_BEGIN, FW_CHUNKs, FW_COMMIT) into the slot not running: the same
 * chunking, retries and ABORT on refusal as wdr_client_upload. A refusal leaves its status in
 * c->status (15-21, TRUNCATED, BAD_CRC, TOO_LARGE, BAD_STATE): nothing is pending then.
 * @retval WDR_OK, request errors, WDR_E_UNSUPPORTED, WDR_E_PROTOCOL (commit answer malformed) */
int wdr_client_fw_upload(wdr_client *c, const uint8_t *img, size_t len, wdr_progress_fn progress, void *progress_ctx,
                         wdr_fw_commit *out);

/* FW_STATUS: both slots, the running one, the last reset. @retval WDR_OK, request errors,
 * WDR_E_UNSUPPORTED, WDR_E_PROTOCOL (short answer) */
int wdr_client_fw_status(wdr_client *c, wdr_fw_status_report *out);

/* A firmware request without payload or answer: FW_CONFIRM, FW_REVERT, REBOOT.
 * @retval WDR_OK, request errors, WDR_E_UNSUPPORTED */
int wdr_client_fw_request(wdr_client *c, uint8_t opcode);

/* One captured frame, assembled from ROW events. */
typedef struct wdr_frame {
    uint16_t width, height;
    uint16_t *codes;       /* width*height, rows top-down (caller-provided) */
    wdr_frame_end end;
    uint32_t rows_seen;
} wdr_frame;

/* Called once per complete frame; return WDR_OK to go on. */
typedef int (*wdr_frame_fn)(void *ctx, const wdr_frame *f);

/* Capture n frames: one CAPTURE request, then frames until n FRAME_ENDs. codes must hold
 * width*height values. A frame is complete only when each of its rows arrived once; each frame
 * must complete within the board's frame time (STATUS integration + INFO readout) plus
 * timeout_ms of the last one, whatever else keeps arriving.
 * @retval WDR_OK, request errors
 * @retval WDR_E_FRAME    a row arrived twice, outside the sensor, or not at all (c->err names them)
 * @retval WDR_E_TIMEOUT  no complete frame in time (c->err says what arrived instead) */
int wdr_client_capture(wdr_client *c, uint32_t n, uint16_t *codes, wdr_frame_fn on_frame, void *ctx);

/* The same with no calibration table applied on the board (protocol 1.1): what calibration
 * measures. The board's tables are not touched.
 * @retval as wdr_client_capture; WDR_E_UNSUPPORTED from a board of protocol 1.0 */
int wdr_client_capture_raw(wdr_client *c, uint32_t n, uint16_t *codes, wdr_frame_fn on_frame, void *ctx);

/* Stream until on_frame returns non-OK or *stop becomes non-zero, then switch streaming off
 * and drain. @retval WDR_OK when stopped by on_frame's WDR_E_... or *stop; request errors */
int wdr_client_stream(wdr_client *c, uint16_t *codes, wdr_frame_fn on_frame, void *ctx, volatile int *stop);

/* Simulated boards only: light every pixel with amps. */
int wdr_client_set_illuminant(wdr_client *c, double amps);
/* Simulated boards only: take the uniform light away, back to the scene (protocol 1.4).
 * @retval WDR_OK, request errors, WDR_E_UNSUPPORTED from a board of protocol 1.3 or earlier */
int wdr_client_restore_scene(wdr_client *c);

/* Text of a protocol status. */
const char *wdr_client_status_text(int status);

/* The status's name in SPEC.md ("BAD_KEY"), for messages that quote it. */
const char *wdr_client_status_ident(int status);

#endif
