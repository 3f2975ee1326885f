#include "fuzz_board.h"
#include "crc32.h"
#include "wdr_proto.h"
#include <string.h>

static wdr_proto_decoder host_dec;
static uint16_t seq;
static int want_seq, got_status;

static void drain(void)
{
    static uint8_t buf[65536];
    size_t n;
    while ((n = fb_host_read(buf, sizeof buf)) > 0)
        for (size_t off = 0; off < n;) {
            wdr_packet p;
            size_t used = 0;
            int r = wdr_proto_feed(&host_dec, buf + off, n - off, &used, &p);
            off += used;
            if (r == WDR_FEED_PACKET && (p.h.flags & WDR_FLAG_RESPONSE) && p.h.seq == want_seq)
                got_status = p.h.status;
        }
}

void fz_board_run(wdr_fw *fw, long steps)
{
    for (long i = 0; i < steps; i++) {
        if (!wdr_fw_task(fw)) {
            drain();
            if (!fb_scheduled() || fb_power_lost())
                break;
            hal_wait_for_event();
        }
        if ((i & 63) == 0)
            drain();
    }
    drain();
}

void fz_board_fresh(wdr_fw *fw)
{
    fb_init();
    wdr_proto_decoder_init(&host_dec);
    wdr_fw_init(fw);
    fz_board_run(fw, 1000);
}

void fz_board_reboot(wdr_fw *fw)
{
    fb_power_cycle();
    wdr_proto_decoder_init(&host_dec);
    wdr_fw_init(fw);
    fz_board_run(fw, 1000);
}

void fz_board_send_raw(wdr_fw *fw, const uint8_t *bytes, size_t n)
{
    fb_host_write(bytes, n);
    fz_board_run(fw, 4000); /* a one-frame capture takes a few hundred steps; a stream never ends */
}

int fz_board_request(wdr_fw *fw, uint8_t op, const uint8_t *payload, uint32_t len)
{
    static uint8_t frame[WDR_PROTO_MAX_FRAME];
    if (len > WDR_PROTO_MAX_PAYLOAD)
        len = WDR_PROTO_MAX_PAYLOAD;
    seq++;
    wdr_proto_header h = {.opcode = op, .seq = seq};
    size_t n = wdr_proto_encode(frame, sizeof frame, &h, payload, len);
    want_seq = h.seq;
    got_status = -1;
    fz_board_send_raw(fw, frame, n);
    return got_status;
}

int fz_board_upload(wdr_fw *fw, int kind, const uint8_t *table, uint32_t len)
{
    static uint8_t pl[WDR_PROTO_MAX_PAYLOAD];
    uint8_t base = kind == WDR_KIND_LUT ? WDR_CMD_LUT_BEGIN : WDR_CMD_CAL_BEGIN;
    wdr_put_u32(pl, len);
    wdr_put_u32(pl + 4, wdr_crc32(0, table, len));
    int st = fz_board_request(fw, base, pl, WDR_BEGIN_SIZE);
    for (uint32_t off = 0; !st && off < len; off += WDR_PROTO_CHUNK_DATA_MAX) {
        uint32_t n = len - off < WDR_PROTO_CHUNK_DATA_MAX ? len - off : WDR_PROTO_CHUNK_DATA_MAX;
        wdr_put_u32(pl, off);
        memcpy(pl + 4, table + off, n);
        st = fz_board_request(fw, (uint8_t)(base + 1), pl, 4 + n);
    }
    return st ? st : fz_board_request(fw, (uint8_t)(base + 2), NULL, 0);
}

int fz_board_store_raw(wdr_fw *fw, int kind, const uint8_t *table, uint32_t len)
{
    int active = kind == WDR_KIND_LUT ? fw->lut_slot : fw->cal_slot;
    int err = wdr_store_begin(&fw->store, kind, active, len, wdr_crc32(0, table, len));
    for (uint32_t off = 0; !err && off < len; off += 4096)
        err = wdr_store_chunk(&fw->store, kind, off, table + off, len - off < 4096 ? len - off : 4096);
    if (!err)
        err = wdr_store_finish(&fw->store, kind);
    if (!err)
        err = wdr_store_seal(&fw->store);
    wdr_store_abort(&fw->store);
    return err;
}
