/* Target capture: the host client's capture and stream path (host/lib/transport_client.c:
 * take_row, take_frame_end, the row bitmap, the per-frame deadline, the stop) against a scripted
 * board in-process. The board answers every request well at once (INFO of a w x h sensor taken
 * from the input, STATUS, CAPTURE/STREAM/ABORT OK), so the session always reaches the frames;
 * the events then come from the input, one record each, packets valid by construction:
 *   [kind u8][frame u8][row u8][n u8][n bytes]
 *   kind % 8: 0-2 ROW of the request in flight (frame, row; the codes from the bytes),
 *   3 FRAME_END (frame, rows = row, or the height when row is 0xff), 4 an event of another
 *   request, 5 a ROW of another width, 6 a frame with a bad payload CRC, 7 raw bytes.
 * Then: connect, a capture of 1-3 frames, a raw capture, a stream stopped after 2 frames,
 * STATUS. Out of input: the board hangs up (WDR_E_IO), so nothing waits. */
#include "fuzz_input.h"
#include "transport.h"
#include "transport_client.h"
#include "wdr_bytes.h"
#include "wdr_err.h"
#include <stdlib.h>
#include <string.h>

#define MAX_SIDE 16

typedef struct cap_board {
    wdr_transport base;
    fz_input in;
    uint16_t width, height, seq; /* seq: of the last frame-making request */
    uint8_t q[4 * WDR_PROTO_MAX_FRAME];
    size_t q_pos, q_len;
} cap_board;

static void queue(cap_board *b, const wdr_proto_header *h, const uint8_t *payload, uint32_t len)
{
    if (b->q_len + WDR_PROTO_MAX_FRAME <= sizeof b->q)
        b->q_len += wdr_proto_encode(b->q + b->q_len, sizeof b->q - b->q_len, h, payload, len);
}

static void answer(cap_board *b, const wdr_packet *req)
{
    wdr_proto_header h = {.opcode = req->h.opcode, .flags = WDR_FLAG_RESPONSE, .seq = req->h.seq};
    uint8_t p[WDR_INFO_SIZE > WDR_STATUS_SIZE ? WDR_INFO_SIZE : WDR_STATUS_SIZE] = {0};
    uint32_t len = 0;
    if (req->h.opcode == WDR_CMD_INFO) {
        wdr_info i = {.proto_major = WDR_PROTO_VERSION_MAJOR, .proto_minor = WDR_PROTO_VERSION_MINOR,
                      .width = b->width, .height = b->height, .adc_bits = 12, .dac_bits = 12,
                      .max_payload = WDR_PROTO_MAX_PAYLOAD, .row_time_ns = 1000, .fw_slot = WDR_SLOT_NONE};
        wdr_info_pack(&i, p);
        len = WDR_INFO_SIZE;
    } else if (req->h.opcode == WDR_CMD_STATUS) {
        wdr_status_report s = {.cal_slot = WDR_SLOT_NONE, .integration_ns = 1000};
        wdr_status_pack(&s, p);
        len = WDR_STATUS_SIZE;
    }
    if (req->h.opcode == WDR_CMD_CAPTURE || (req->h.opcode == WDR_CMD_STREAM && req->h.length && req->payload[0]))
        b->seq = req->h.seq;
    queue(b, &h, p, len);
}

static int board_send(wdr_transport *t, const uint8_t *buf, size_t len, int timeout_ms)
{
    cap_board *b = (cap_board *)t;
    wdr_proto_decoder d;
    wdr_packet p;
    size_t used;
    (void)timeout_ms;
    wdr_proto_decoder_init(&d);
    if (wdr_proto_feed(&d, buf, len, &used, &p) == WDR_FEED_PACKET)
        answer(b, &p);
    return WDR_OK;
}

static void row_event(cap_board *b, uint16_t seq, uint32_t frame, uint16_t row, uint16_t width, const uint8_t *codes,
                      size_t n)
{
    uint8_t p[WDR_PROTO_ROW_HEADER + 2 * (MAX_SIDE + 1)] = {0};
    wdr_put_u32(p, frame);
    wdr_put_u16(p + 4, row);
    wdr_put_u16(p + 6, width);
    memcpy(p + WDR_PROTO_ROW_HEADER, codes, n < 2u * width ? n : 2u * width);
    wdr_proto_header h = {.opcode = WDR_CMD_ROW, .flags = WDR_FLAG_EVENT, .seq = seq};
    queue(b, &h, p, WDR_PROTO_ROW_HEADER + 2u * width);
}

/* The next input record as bytes in b->q; 0 when the input is used up. */
static int next_record(cap_board *b)
{
    if (!b->in.left)
        return 0;
    uint8_t kind = fz_u8(&b->in) % 8, frame = fz_u8(&b->in), row = fz_u8(&b->in);
    size_t n;
    const uint8_t *bytes = fz_bytes(&b->in, fz_u8(&b->in), &n);
    wdr_proto_header h = {.flags = WDR_FLAG_EVENT, .seq = b->seq};
    uint8_t fe[WDR_FRAME_END_SIZE];
    wdr_frame_end end = {.frame = frame, .rows = row == 0xff ? b->height : row};
    switch (kind) {
    case 0: case 1: case 2: row_event(b, b->seq, frame, row % (b->height + 2u), b->width, bytes, n); break;
    case 3:
        wdr_frame_end_pack(&end, fe);
        h.opcode = WDR_CMD_FRAME_END;
        queue(b, &h, fe, sizeof fe);
        break;
    case 4: row_event(b, (uint16_t)(b->seq + 1 + row), frame, row % b->height, b->width, bytes, n); break;
    case 5: row_event(b, b->seq, frame, row % b->height, (uint16_t)(row % (MAX_SIDE + 1)), bytes, n); break;
    case 6: {
        size_t at = b->q_len;
        row_event(b, b->seq, frame, row % b->height, b->width, bytes, n);
        if (b->q_len > at + WDR_PROTO_HEADER_SIZE)
            b->q[at + WDR_PROTO_HEADER_SIZE] ^= 0x5a; /* payload no longer matches its CRC */
        break;
    }
    default:
        memcpy(b->q + b->q_len, bytes, n);
        b->q_len += n;
        break;
    }
    return 1;
}

static int board_recv(wdr_transport *t, uint8_t *buf, size_t cap, int timeout_ms)
{
    cap_board *b = (cap_board *)t;
    (void)timeout_ms;
    if (b->q_pos == b->q_len) {
        b->q_pos = b->q_len = 0;
        if (!next_record(b))
            return WDR_E_IO;
    }
    size_t n = b->q_len - b->q_pos < cap ? b->q_len - b->q_pos : cap;
    memcpy(buf, b->q + b->q_pos, n);
    b->q_pos += n;
    return (int)n;
}

static void board_close(wdr_transport *t) { (void)t; }

static const wdr_transport_ops board_ops = {board_send, board_recv, board_close};

static int stop_after_two(void *ctx, const wdr_frame *f)
{
    int *n = ctx;
    for (uint32_t i = 0; i < (uint32_t)f->width * f->height; i++)
        (void)f->codes[i]; /* every code of a complete frame was written (ASan, MSan) */
    return ++*n >= 2 ? WDR_E_INVAL : WDR_OK;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static cap_board b;
    static wdr_client c;
    static uint16_t codes[MAX_SIDE * MAX_SIDE];
    memset(&b, 0, sizeof b);
    b.base.ops = &board_ops;
    strcpy(b.base.name, "fuzz-board");
    b.in = (fz_input){data, size};
    uint8_t shape = fz_u8(&b.in);
    b.width = (uint16_t)(1 + shape % MAX_SIDE);
    b.height = (uint16_t)(1 + (shape >> 4) % MAX_SIDE);
    memset(&c, 0, sizeof c);
    c.timeout_ms = 10000; /* never reached: the board never makes the client wait */
    c.retries = 0;
    if (wdr_client_connect(&c, &b.base) != WDR_OK)
        return 0;
    int frames = 0;
    volatile int stop = 0;
    wdr_status_report st;
    wdr_client_capture(&c, 1 + (shape & 1) + (shape >> 7), codes, NULL, NULL);
    wdr_client_capture_raw(&c, 1, codes, NULL, NULL);
    wdr_client_stream(&c, codes, stop_after_two, &frames, &stop);
    wdr_client_status(&c, &st);
    return 0;
}
