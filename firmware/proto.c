/* Wire protocol codec: framing with CRCs, a resynchronising decoder, payload packing. */
#include "wdr_proto.h"
#include "crc32.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <stdbool.h>
#include <string.h>

/* ---- Framing ----------------------------------------------------------------------------- */

size_t wdr_proto_seal(uint8_t *out, const wdr_proto_header *h, uint32_t len)
{
    if (len > WDR_PROTO_MAX_PAYLOAD)
        return 0;
    out[0] = WDR_PROTO_SYNC0;
    out[1] = WDR_PROTO_SYNC1;
    out[2] = h->opcode;
    out[3] = h->flags;
    wdr_put_u16(out + 4, h->seq);
    out[6] = h->status;
    out[7] = 0;
    wdr_put_u32(out + 8, len);
    wdr_put_u32(out + 12, wdr_crc32(0, out + WDR_PROTO_HEADER_SIZE, len));
    wdr_put_u32(out + 16, wdr_crc32(0, out, 16));
    return WDR_PROTO_HEADER_SIZE + len;
}

size_t wdr_proto_encode(uint8_t *out, size_t cap, const wdr_proto_header *h, const void *payload, uint32_t len)
{
    if (len > WDR_PROTO_MAX_PAYLOAD || cap < WDR_PROTO_HEADER_SIZE + (size_t)len)
        return 0;
    if (len)
        memmove(out + WDR_PROTO_HEADER_SIZE, payload, len);
    return wdr_proto_seal(out, h, len);
}

static void header_unpack(const uint8_t *p, wdr_proto_header *h)
{
    h->opcode = p[2];
    h->flags = p[3];
    h->seq = wdr_get_u16(p + 4);
    h->status = p[6];
    h->length = wdr_get_u32(p + 8);
    h->payload_crc = wdr_get_u32(p + 12);
}

/* ---- Decoder ----------------------------------------------------------------------------- */

/* The buffer only ever holds the frame being assembled, starting at buf[0]. A packet handed
 * out stays in place until the next feed, which is when its bytes are released. */

void wdr_proto_decoder_init(wdr_proto_decoder *d)
{
    memset(d, 0, sizeof *d);
}

static void drop_front(wdr_proto_decoder *d, uint32_t n)
{
    memmove(d->buf, d->buf + n, d->fill - n);
    d->fill -= n;
}

/* Drop bytes until buf starts with a sync pair or holds less than one; true if aligned. */
static int hunt_sync(wdr_proto_decoder *d)
{
    while (d->fill > 0) {
        const uint8_t *s = memchr(d->buf, WDR_PROTO_SYNC0, d->fill);
        uint32_t lead = s ? (uint32_t)(s - d->buf) : d->fill;
        d->skipped += lead;
        drop_front(d, lead);
        if (d->fill < 2 || d->buf[1] == WDR_PROTO_SYNC1)
            return d->fill > 0;
        d->skipped++;
        drop_front(d, 1);
    }
    return 0;
}

static int header_valid(const wdr_proto_decoder *d)
{
    return wdr_get_u32(d->buf + 16) == wdr_crc32(0, d->buf, 16) && d->buf[7] == 0;
}

/* Bytes still needed before buf can be judged again. */
static uint32_t bytes_wanted(const wdr_proto_decoder *d)
{
    if (d->fill < WDR_PROTO_HEADER_SIZE)
        return WDR_PROTO_HEADER_SIZE - d->fill;
    return WDR_PROTO_HEADER_SIZE + wdr_get_u32(d->buf + 8) - d->fill;
}

/* Judge what buf holds now: a result, or WDR_FEED_MORE if more bytes are needed. */
static int judge(wdr_proto_decoder *d, wdr_packet *out)
{
    for (;;) {
        if (!hunt_sync(d) || d->fill < WDR_PROTO_HEADER_SIZE)
            return WDR_FEED_MORE;
        if (!header_valid(d)) {
            d->skipped++;
            drop_front(d, 1);
            continue;
        }
        header_unpack(d->buf, &out->h);
        out->payload = d->buf + WDR_PROTO_HEADER_SIZE;
        if (out->h.length > WDR_PROTO_MAX_PAYLOAD) {
            drop_front(d, WDR_PROTO_HEADER_SIZE);
            return WDR_FEED_TOO_LARGE;
        }
        if (d->fill < WDR_PROTO_HEADER_SIZE + out->h.length)
            return WDR_FEED_MORE;
        if (wdr_crc32(0, out->payload, out->h.length) != out->h.payload_crc) {
            /* Keep the payload: a frame cut short may have the next one inside it. */
            d->bad_payloads++;
            drop_front(d, WDR_PROTO_HEADER_SIZE);
            return WDR_FEED_BAD_CRC;
        }
        d->pending = WDR_PROTO_HEADER_SIZE + out->h.length;
        return WDR_FEED_PACKET;
    }
}

int wdr_proto_feed(wdr_proto_decoder *d, const uint8_t *data, size_t len, size_t *used, wdr_packet *out)
{
    size_t taken = 0;
    drop_front(d, d->pending); /* the packet handed out last time */
    d->pending = 0;
    for (;;) {
        int r = judge(d, out);
        if (r != WDR_FEED_MORE || taken == len) {
            *used = taken;
            return r;
        }
        size_t n = bytes_wanted(d);
        if (n > len - taken)
            n = len - taken;
        memcpy(d->buf + d->fill, data + taken, n);
        d->fill += (uint32_t)n;
        taken += n;
    }
}

/* ---- Status codes ------------------------------------------------------------------------ */

const char *wdr_status_name(int status)
{
    static const char *const names[] = {
        "ok", "busy", "bad CRC", "bad sequence", "too large", "bad geometry", "no table",
        "unsupported", "bad kind", "bad length", "bad version", "truncated", "bad table",
        "bad argument", "flash error", "bad signature", "untrusted key", "downgrade refused",
        "bad image hash", "image for another board", "bad state", "bad image",
    };
    if (status < 0 || status >= (int)(sizeof names / sizeof names[0]))
        return "unknown status";
    return names[status];
}

int wdr_status_from_err(int err)
{
    switch (err) {
    case WDR_OK: return WDR_ST_OK;
    case WDR_E_CORRUPT: return WDR_ST_BAD_CRC;
    case WDR_E_VERSION: return WDR_ST_BAD_VERSION;
    case WDR_E_TRUNCATED: return WDR_ST_TRUNCATED;
    case WDR_E_TOO_LARGE: return WDR_ST_TOO_LARGE;
    case WDR_E_GEOMETRY: return WDR_ST_BAD_GEOMETRY;
    case WDR_E_KIND: return WDR_ST_BAD_KIND;
    case WDR_E_NO_TABLE: return WDR_ST_NO_TABLE;
    case WDR_E_BUSY: return WDR_ST_BUSY;
    case WDR_E_SEQUENCE: return WDR_ST_BAD_SEQUENCE;
    case WDR_E_UNSUPPORTED: return WDR_ST_UNSUPPORTED;
    case WDR_E_IO: case WDR_E_POWER: return WDR_ST_FLASH;
    case WDR_E_INVAL: case WDR_E_NUMERIC: return WDR_ST_BAD_TABLE;
    case WDR_E_SIGNATURE: return WDR_ST_BAD_SIGNATURE;
    case WDR_E_KEY: return WDR_ST_BAD_KEY;
    case WDR_E_DOWNGRADE: return WDR_ST_DOWNGRADE;
    case WDR_E_HASH: return WDR_ST_BAD_HASH;
    case WDR_E_BOARD: return WDR_ST_BAD_BOARD;
    case WDR_E_STATE: return WDR_ST_BAD_STATE;
    default: return WDR_ST_BAD_ARG;
    }
}

/* ---- Payloads ---------------------------------------------------------------------------- */

static void put_u64(uint8_t *p, uint64_t v)
{
    wdr_put_u32(p, (uint32_t)v);
    wdr_put_u32(p + 4, (uint32_t)(v >> 32));
}

static uint64_t get_u64(const uint8_t *p)
{
    return wdr_get_u32(p) | ((uint64_t)wdr_get_u32(p + 4) << 32);
}

void wdr_info_pack(const wdr_info *in, uint8_t *out)
{
    wdr_put_u16(out + 0, in->proto_major);
    wdr_put_u16(out + 2, in->proto_minor);
    wdr_put_u16(out + 4, in->fw_major);
    wdr_put_u16(out + 6, in->fw_minor);
    wdr_put_u32(out + 8, in->sensor_id);
    wdr_put_u16(out + 12, in->width);
    wdr_put_u16(out + 14, in->height);
    out[16] = in->adc_bits;
    out[17] = in->dac_bits;
    wdr_put_u16(out + 18, in->caps);
    wdr_put_u32(out + 20, in->max_payload);
    wdr_put_u32(out + 24, in->lut_capacity);
    wdr_put_u32(out + 28, in->cal_capacity);
    wdr_put_u32(out + 32, in->row_time_ns);
    memcpy(out + 36, in->name, sizeof in->name);
    out[36 + sizeof in->name - 1] = 0;
    wdr_put_u16(out + 68, in->fw_patch);
    out[70] = in->fw_slot;
    out[71] = in->fw_flags;
    wdr_put_u32(out + 72, in->fw_build);
}

int wdr_info_unpack(const uint8_t *p, size_t len, wdr_info *out)
{
    if (len < WDR_INFO_SIZE_1_3)
        return WDR_E_TRUNCATED;
    out->proto_major = wdr_get_u16(p + 0);
    out->proto_minor = wdr_get_u16(p + 2);
    out->fw_major = wdr_get_u16(p + 4);
    out->fw_minor = wdr_get_u16(p + 6);
    out->sensor_id = wdr_get_u32(p + 8);
    out->width = wdr_get_u16(p + 12);
    out->height = wdr_get_u16(p + 14);
    out->adc_bits = p[16];
    out->dac_bits = p[17];
    out->caps = wdr_get_u16(p + 18);
    out->max_payload = wdr_get_u32(p + 20);
    out->lut_capacity = wdr_get_u32(p + 24);
    out->cal_capacity = wdr_get_u32(p + 28);
    out->row_time_ns = wdr_get_u32(p + 32);
    memcpy(out->name, p + 36, sizeof out->name);
    out->name[sizeof out->name - 1] = 0;
    bool has_image = len >= WDR_INFO_SIZE;
    out->fw_patch = has_image ? wdr_get_u16(p + 68) : 0;
    out->fw_slot = has_image ? p[70] : WDR_SLOT_NONE;
    out->fw_flags = has_image ? p[71] : 0;
    out->fw_build = has_image ? wdr_get_u32(p + 72) : 0;
    return WDR_OK;
}

void wdr_status_pack(const wdr_status_report *in, uint8_t *out)
{
    out[0] = in->state;
    out[1] = in->lut_slot;
    out[2] = in->cal_slot;
    out[3] = in->upload_kind;
    wdr_put_u32(out + 4, in->lut_seq);
    wdr_put_u32(out + 8, in->cal_seq);
    wdr_put_u32(out + 12, in->lut_crc);
    wdr_put_u32(out + 16, in->cal_crc);
    wdr_put_u32(out + 20, in->upload_received);
    wdr_put_u32(out + 24, in->frames);
    wdr_put_u32(out + 28, in->integration_ns);
    wdr_put_u32(out + 32, in->frame_time_ns);
    put_u64(out + 36, in->time_ns);
    wdr_put_u32(out + 44, in->rx_skipped);
    wdr_put_u32(out + 48, in->rx_bad_crc);
    out[52] = in->exposure_auto;
    out[53] = in->exposure_flags;
    wdr_put_u16(out + 54, 0);
    wdr_put_u32(out + 56, (uint32_t)in->key_gain_q8);
    wdr_put_u32(out + 60, in->tick_ps);
    wdr_put_u32(out + 64, (uint32_t)in->last_error_q8);
}

int wdr_status_unpack(const uint8_t *p, size_t len, wdr_status_report *out)
{
    if (len < WDR_STATUS_SIZE_1_0)
        return WDR_E_TRUNCATED;
    out->state = p[0];
    out->lut_slot = p[1];
    out->cal_slot = p[2];
    out->upload_kind = p[3];
    out->lut_seq = wdr_get_u32(p + 4);
    out->cal_seq = wdr_get_u32(p + 8);
    out->lut_crc = wdr_get_u32(p + 12);
    out->cal_crc = wdr_get_u32(p + 16);
    out->upload_received = wdr_get_u32(p + 20);
    out->frames = wdr_get_u32(p + 24);
    out->integration_ns = wdr_get_u32(p + 28);
    out->frame_time_ns = wdr_get_u32(p + 32);
    out->time_ns = get_u64(p + 36);
    out->rx_skipped = wdr_get_u32(p + 44);
    out->rx_bad_crc = wdr_get_u32(p + 48);
    int v11 = len >= WDR_STATUS_SIZE;
    out->exposure_auto = v11 ? p[52] : 0;
    out->exposure_flags = v11 ? p[53] : 0;
    out->key_gain_q8 = v11 ? (int32_t)wdr_get_u32(p + 56) : 0;
    out->tick_ps = v11 ? wdr_get_u32(p + 60) : 0;
    out->last_error_q8 = v11 ? (int32_t)wdr_get_u32(p + 64) : 0;
    return WDR_OK;
}

void wdr_commit_pack(const wdr_commit_reply *in, uint8_t *out)
{
    wdr_put_u32(out, in->crc);
    wdr_put_u32(out + 4, in->seq);
    out[8] = in->slot;
    out[9] = out[10] = out[11] = 0;
}

int wdr_commit_unpack(const uint8_t *p, size_t len, wdr_commit_reply *out)
{
    if (len < WDR_COMMIT_REPLY_SIZE)
        return WDR_E_TRUNCATED;
    out->crc = wdr_get_u32(p);
    out->seq = wdr_get_u32(p + 4);
    out->slot = p[8];
    return WDR_OK;
}

void wdr_frame_end_pack(const wdr_frame_end *in, uint8_t *out)
{
    wdr_put_u32(out, in->frame);
    wdr_put_u16(out + 4, in->rows);
    wdr_put_u16(out + 6, in->flags);
    wdr_put_u32(out + 8, in->integration_ns);
    put_u64(out + 12, in->t_start_ns);
}

int wdr_frame_end_unpack(const uint8_t *p, size_t len, wdr_frame_end *out)
{
    if (len < WDR_FRAME_END_SIZE)
        return WDR_E_TRUNCATED;
    out->frame = wdr_get_u32(p);
    out->rows = wdr_get_u16(p + 4);
    out->flags = wdr_get_u16(p + 6);
    out->integration_ns = wdr_get_u32(p + 8);
    out->t_start_ns = get_u64(p + 12);
    return WDR_OK;
}

/* ---- Firmware status (1.4) ------------------------------------------------------------------- */

static void fw_slot_pack(const wdr_fw_slot_report *s, uint8_t *out)
{
    out[0] = s->state;
    out[1] = s->attempts;
    out[2] = s->reject_reason;
    out[3] = (uint8_t)s->verify_err;
    out[4] = s->ver_major;
    out[5] = s->ver_minor;
    wdr_put_u16(out + 6, s->ver_patch);
    wdr_put_u32(out + 8, s->ver_build);
    wdr_put_u32(out + 12, s->security_counter);
    wdr_put_u32(out + 16, s->image_size);
    memcpy(out + 20, s->sha256, sizeof s->sha256);
    memset(out + 52, 0, WDR_FW_SLOT_REPORT_SIZE - 52);
}

static void fw_slot_unpack(const uint8_t *p, wdr_fw_slot_report *s)
{
    s->state = p[0];
    s->attempts = p[1];
    s->reject_reason = p[2];
    s->verify_err = (int8_t)p[3];
    s->ver_major = p[4];
    s->ver_minor = p[5];
    s->ver_patch = wdr_get_u16(p + 6);
    s->ver_build = wdr_get_u32(p + 8);
    s->security_counter = wdr_get_u32(p + 12);
    s->image_size = wdr_get_u32(p + 16);
    memcpy(s->sha256, p + 20, sizeof s->sha256);
}

void wdr_fw_status_pack(const wdr_fw_status_report *in, uint8_t *out)
{
    out[0] = in->running;
    out[1] = in->reset_cause;
    out[2] = in->flags;
    out[3] = in->max_attempts;
    wdr_put_u32(out + 4, in->fault_pc);
    wdr_put_u32(out + 8, in->fault_status);
    wdr_put_u32(out + 12, in->floor);
    wdr_put_u32(out + 16, in->boots);
    memcpy(out + 20, in->key_hash, sizeof in->key_hash);
    for (int i = 0; i < 2; i++)
        fw_slot_pack(&in->slot[i], out + 24 + i * WDR_FW_SLOT_REPORT_SIZE);
}

int wdr_fw_status_unpack(const uint8_t *p, size_t len, wdr_fw_status_report *out)
{
    if (len < WDR_FW_STATUS_SIZE)
        return WDR_E_TRUNCATED;
    out->running = p[0];
    out->reset_cause = p[1];
    out->flags = p[2];
    out->max_attempts = p[3];
    out->fault_pc = wdr_get_u32(p + 4);
    out->fault_status = wdr_get_u32(p + 8);
    out->floor = wdr_get_u32(p + 12);
    out->boots = wdr_get_u32(p + 16);
    memcpy(out->key_hash, p + 20, sizeof out->key_hash);
    for (int i = 0; i < 2; i++)
        fw_slot_unpack(p + 24 + i * WDR_FW_SLOT_REPORT_SIZE, &out->slot[i]);
    return WDR_OK;
}
