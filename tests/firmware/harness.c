#include "harness.h"
#include "crc32.h"
#include <stdlib.h>
#include <string.h>

th_capture th_cap;

static wdr_proto_decoder host_dec;
static uint16_t next_seq = 1000;
static int want_seq, got_status = TH_NO_RESPONSE;
static uint8_t *resp_buf;
static uint32_t resp_cap;

static void collect(void);

/* Until idle; a stream never idles, so with one on, until the request was answered. */
void th_run(wdr_fw *fw)
{
    for (long i = 0; i < 50000000L; i++) {
        if (wdr_fw_task(fw))
            continue;
        collect();
        if (fw->streaming && got_status != TH_NO_RESPONSE)
            return;
        if (!fb_scheduled() || fb_power_lost())
            return;
        hal_wait_for_event();
    }
    abort(); /* the firmware never went idle */
}

static void on_row(const wdr_packet *p)
{
    if (p->h.length < WDR_PROTO_ROW_HEADER)
        return;
    uint16_t row = wdr_get_u16(p->payload + 4), w = wdr_get_u16(p->payload + 6);
    th_cap.rows++;
    if (row < FB_HEIGHT && w == FB_WIDTH && p->h.length == WDR_PROTO_ROW_HEADER + 2u * w)
        for (int c = 0; c < w; c++)
            th_cap.px[row][c] = wdr_get_u16(p->payload + WDR_PROTO_ROW_HEADER + 2 * c);
}

static void on_packet(const wdr_packet *p)
{
    if (p->h.opcode == WDR_CMD_ROW && (p->h.flags & WDR_FLAG_EVENT))
        on_row(p);
    else if (p->h.opcode == WDR_CMD_FRAME_END && (p->h.flags & WDR_FLAG_EVENT)) {
        th_cap.frame_ends++;
        wdr_frame_end_unpack(p->payload, p->h.length, &th_cap.last_end);
    } else if ((p->h.flags & WDR_FLAG_RESPONSE) && p->h.seq == want_seq) {
        got_status = p->h.status;
        if (resp_buf)
            memcpy(resp_buf, p->payload, p->h.length < resp_cap ? p->h.length : resp_cap);
    }
}

static void collect(void)
{
    static uint8_t buf[65536];
    size_t n;
    while ((n = fb_host_read(buf, sizeof buf)) > 0) {
        for (size_t off = 0; off < n;) {
            wdr_packet p;
            size_t used;
            int r = wdr_proto_feed(&host_dec, buf + off, n - off, &used, &p);
            off += used;
            if (r == WDR_FEED_PACKET)
                on_packet(&p);
        }
    }
}

int th_boot(wdr_fw *fw)
{
    wdr_proto_decoder_init(&host_dec);
    int err = wdr_fw_init(fw);
    th_run(fw);
    collect();
    return err;
}

void th_send_raw(wdr_fw *fw, const void *bytes, size_t n)
{
    fb_host_write(bytes, n);
    th_run(fw);
    collect();
}

int th_last_seq(void) { return (uint16_t)(next_seq - 1); }

int th_request_seq(wdr_fw *fw, int seq, uint8_t op, const void *payload, uint32_t len, uint8_t *resp, uint32_t cap)
{
    static uint8_t frame[WDR_PROTO_MAX_FRAME];
    wdr_proto_header h = {op, 0, (uint16_t)(seq >= 0 ? seq : next_seq++), 0, 0, 0};
    size_t n = wdr_proto_encode(frame, sizeof frame, &h, payload, len);
    want_seq = h.seq;
    got_status = TH_NO_RESPONSE;
    resp_buf = resp;
    resp_cap = cap;
    memset(&th_cap, 0, sizeof th_cap);
    th_send_raw(fw, frame, n);
    resp_buf = NULL;
    return got_status;
}

int th_request(wdr_fw *fw, uint8_t op, const void *payload, uint32_t len, uint8_t *resp, uint32_t cap)
{
    return th_request_seq(fw, -1, op, payload, len, resp, cap);
}

int th_upload(wdr_fw *fw, int kind, const uint8_t *data, uint32_t len, uint32_t chunk, wdr_commit_reply *reply)
{
    static uint8_t pl[WDR_PROTO_MAX_PAYLOAD];
    uint8_t base = kind == WDR_KIND_LUT ? WDR_CMD_LUT_BEGIN : WDR_CMD_CAL_BEGIN, out[WDR_COMMIT_REPLY_SIZE];
    wdr_put_u32(pl, len);
    wdr_put_u32(pl + 4, wdr_crc32(0, data, len));
    int st = th_request(fw, base, pl, WDR_BEGIN_SIZE, NULL, 0);
    for (uint32_t off = 0; !st && off < len; off += chunk) {
        uint32_t n = len - off < chunk ? len - off : chunk;
        wdr_put_u32(pl, off);
        memcpy(pl + 4, data + off, n);
        st = th_request(fw, base + 1, pl, 4 + n, NULL, 0);
    }
    if (st)
        return st;
    st = th_request(fw, base + 2, NULL, 0, out, sizeof out);
    if (!st && reply)
        wdr_commit_unpack(out, sizeof out, reply);
    return st;
}

wdr_status_report th_status(wdr_fw *fw)
{
    uint8_t out[WDR_STATUS_SIZE];
    wdr_status_report r;
    memset(&r, 0, sizeof r);
    if (th_request(fw, WDR_CMD_STATUS, NULL, 0, out, sizeof out) == WDR_ST_OK)
        wdr_status_unpack(out, sizeof out, &r);
    return r;
}

int th_capture_frames(wdr_fw *fw, uint32_t n)
{
    uint8_t pl[4];
    wdr_put_u32(pl, n);
    return th_request(fw, WDR_CMD_CAPTURE, pl, 4, NULL, 0);
}
