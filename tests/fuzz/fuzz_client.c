/* Target client: the host's parsing of a board's replies (host/lib/transport_client.c). A
 * transport of our own answers from the input, one record per read; the harness supplies the
 * sequence number of the request in flight, which a board would echo, so replies are taken:
 *   [k u8][len u16][bytes]   k % 4 = 0 raw bytes; 1 response to the last request, status =
 *   bytes[0], payload the rest; 2 event (ROW if bytes[0] is odd, else FRAME_END) of the last
 *   request; 3 a frame with opcode bytes[0] and flags bytes[1].
 * Then a session: connect, status, an upload, FW_STATUS, an image upload, FW_CONFIRM, a capture
 * and a stream. Out of input: the board
 * hangs up (WDR_E_IO), so nothing ever waits. */
#include "fuzz_input.h"
#include "transport.h"
#include "transport_client.h"
#include "wdr_lut.h"
#include <stdlib.h>
#include <string.h>

typedef struct fz_transport {
    wdr_transport base;
    fz_input in;
    uint16_t seq;     /* of the last request sent */
    uint8_t opcode;
    uint8_t q[WDR_PROTO_MAX_FRAME];
    size_t q_pos, q_len;
} fz_transport;

static int fz_send(wdr_transport *t, const uint8_t *buf, size_t len, int timeout_ms)
{
    fz_transport *f = (fz_transport *)t;
    (void)timeout_ms;
    if (len >= WDR_PROTO_HEADER_SIZE) { /* the codec's header: sync, opcode, flags, seq (SPEC.md) */
        wdr_proto_decoder d;
        wdr_packet p;
        size_t used;
        wdr_proto_decoder_init(&d);
        if (wdr_proto_feed(&d, buf, len, &used, &p) == WDR_FEED_PACKET) {
            f->seq = p.h.seq;
            f->opcode = p.h.opcode;
        }
    }
    return WDR_OK;
}

/* The next record as bytes on the wire in f->q; 0 when the input is used up. */
static int next_record(fz_transport *f)
{
    if (!f->in.left)
        return 0;
    uint8_t k = fz_u8(&f->in);
    size_t got;
    const uint8_t *b = fz_bytes(&f->in, fz_u16(&f->in), &got);
    wdr_proto_header h = {.seq = f->seq};
    switch (k & 3) {
    case 0:
        memcpy(f->q, b, got < sizeof f->q ? got : sizeof f->q);
        f->q_len = got < sizeof f->q ? got : sizeof f->q;
        f->q_pos = 0;
        return 1;
    case 1:
        h.opcode = f->opcode, h.flags = WDR_FLAG_RESPONSE, h.status = got ? b[0] : 0;
        break;
    case 2:
        h.opcode = got && (b[0] & 1) ? WDR_CMD_ROW : WDR_CMD_FRAME_END, h.flags = WDR_FLAG_EVENT;
        break;
    default:
        h.opcode = got ? b[0] : 0, h.flags = got > 1 ? b[1] : 0;
        break;
    }
    size_t skip = (k & 3) == 3 ? 2 : 1;
    skip = skip < got ? skip : got;
    size_t plen = got - skip < WDR_PROTO_MAX_PAYLOAD ? got - skip : WDR_PROTO_MAX_PAYLOAD;
    f->q_len = wdr_proto_encode(f->q, sizeof f->q, &h, b + skip, (uint32_t)plen);
    f->q_pos = 0;
    return 1;
}

static int fz_recv(wdr_transport *t, uint8_t *buf, size_t cap, int timeout_ms)
{
    fz_transport *f = (fz_transport *)t;
    (void)timeout_ms;
    while (f->q_pos == f->q_len)
        if (!next_record(f))
            return WDR_E_IO;
    size_t n = f->q_len - f->q_pos < cap ? f->q_len - f->q_pos : cap;
    memcpy(buf, f->q + f->q_pos, n);
    f->q_pos += n;
    return (int)n;
}

static void fz_close(wdr_transport *t) { (void)t; }

static const wdr_transport_ops fz_ops = {fz_send, fz_recv, fz_close};

static int two_frames(void *ctx, const wdr_frame *fr)
{
    int *n = ctx;
    (void)fr;
    return ++*n >= 2 ? WDR_E_INVAL : WDR_OK;
}

static void session(wdr_client *c)
{
    wdr_status_report st;
    wdr_client_status(c, &st);
    static uint8_t table[6000];
    wdr_commit_reply reply;
    wdr_client_upload(c, WDR_KIND_LUT, table, sizeof table, NULL, NULL, &reply);
    wdr_fw_status_report fs; /* protocol 1.4: the firmware update's answers */
    wdr_fw_commit fc;
    wdr_client_fw_status(c, &fs);
    wdr_client_fw_upload(c, table, sizeof table, NULL, NULL, &fc);
    wdr_client_fw_request(c, WDR_CMD_FW_CONFIRM);
    size_t pixels = (size_t)c->info.width * c->info.height;
    if (pixels > (1u << 20))
        return;
    uint16_t *codes = malloc(pixels * sizeof *codes);
    int frames = 0;
    volatile int stop = 0;
    wdr_client_capture(c, 2, codes, NULL, NULL);
    wdr_client_stream(c, codes, two_frames, &frames, &stop);
    wdr_client_status(c, &st); /* after a stream cut short: no callback into its frame */
    free(codes);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static fz_transport f;
    static wdr_client c;
    memset(&f, 0, sizeof f);
    f.base.ops = &fz_ops;
    strcpy(f.base.name, "fuzz");
    f.in = (fz_input){data, size};
    memset(&c, 0, sizeof c);
    c.timeout_ms = 1000; /* never reached: the transport never blocks */
    c.retries = 1;
    if (wdr_client_connect(&c, &f.base) == WDR_OK)
        session(&c);
    return 0;
}
