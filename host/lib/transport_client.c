/* Host protocol client: requests with retries, uploads, captures (see transport_client.h). */
#include "transport_client.h"
#include "crc32.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <stdio.h>
#include <string.h>
#include <unistd.h>

static const char *opcode_name(int op)
{
    switch (op) {
    case WDR_CMD_INFO: return "INFO";
    case WDR_CMD_STATUS: return "STATUS";
    case WDR_CMD_LUT_BEGIN: return "LUT_BEGIN";
    case WDR_CMD_LUT_CHUNK: return "LUT_CHUNK";
    case WDR_CMD_LUT_COMMIT: return "LUT_COMMIT";
    case WDR_CMD_LUT_SELECT: return "LUT_SELECT";
    case WDR_CMD_CAL_BEGIN: return "CAL_BEGIN";
    case WDR_CMD_CAL_CHUNK: return "CAL_CHUNK";
    case WDR_CMD_CAL_COMMIT: return "CAL_COMMIT";
    case WDR_CMD_SET_INTEGRATION: return "SET_INTEGRATION";
    case WDR_CMD_CAPTURE: return "CAPTURE";
    case WDR_CMD_STREAM: return "STREAM";
    case WDR_CMD_ABORT: return "ABORT";
    case WDR_CMD_SET_EXPOSURE: return "SET_EXPOSURE";
    case WDR_CMD_FW_BEGIN: return "FW_BEGIN";
    case WDR_CMD_FW_CHUNK: return "FW_CHUNK";
    case WDR_CMD_FW_COMMIT: return "FW_COMMIT";
    case WDR_CMD_FW_STATUS: return "FW_STATUS";
    case WDR_CMD_FW_CONFIRM: return "FW_CONFIRM";
    case WDR_CMD_FW_REVERT: return "FW_REVERT";
    case WDR_CMD_REBOOT: return "REBOOT";
    case WDR_CMD_SIM_SET_ILLUMINANT: return "SIM_SET_ILLUMINANT";
    default: return "request";
    }
}

const char *wdr_client_status_text(int status) { return wdr_status_name(status); }

const char *wdr_client_status_ident(int status)
{
    static const char *const names[] = {"OK", "BUSY", "BAD_CRC", "BAD_SEQUENCE", "TOO_LARGE", "BAD_GEOMETRY",
                                        "NO_TABLE", "UNSUPPORTED", "BAD_KIND", "BAD_LENGTH", "BAD_VERSION",
                                        "TRUNCATED", "BAD_TABLE", "BAD_ARG", "FLASH", "BAD_SIGNATURE", "BAD_KEY",
                                        "DOWNGRADE", "BAD_HASH", "BAD_BOARD", "BAD_STATE", "BAD_IMAGE"};
    return status >= 0 && status < (int)(sizeof names / sizeof names[0]) ? names[status] : "UNKNOWN";
}

/* ---- Receiving packets ------------------------------------------------------------------- */

/* Next decoder result before the deadline: enum wdr_feed_result (not MORE), or an error. */
static int next_packet(wdr_client *c, int64_t deadline, wdr_packet *p)
{
    for (;;) {
        while (c->rx_pos < c->rx_len) {
            size_t used = 0;
            int r = wdr_proto_feed(&c->dec, c->rx + c->rx_pos, c->rx_len - c->rx_pos, &used, p);
            c->rx_pos += used;
            if (r != WDR_FEED_MORE)
                return r;
        }
        int64_t left = deadline - wdr_transport_now_ms();
        if (left <= 0)
            return WDR_E_TIMEOUT;
        int n = wdr_transport_recv(c->t, c->rx, sizeof c->rx, (int)left);
        if (n < 0)
            return n;
        c->rx_pos = 0;
        c->rx_len = (size_t)n;
        c->rx_bytes += (uint64_t)n;
    }
}

static int fail(wdr_client *c, int code, const char *what)
{
    snprintf(c->err, sizeof c->err, "%s: %s", wdr_transport_name(c->t), what);
    return code;
}

static int transport_fail(wdr_client *c, int code, uint8_t opcode)
{
    char what[160];
    if (code == WDR_E_IO)
        snprintf(what, sizeof what, "board disconnected during %s", opcode_name(opcode));
    else if (code == WDR_E_TIMEOUT)
        snprintf(what, sizeof what, "no answer to %s after %d attempt(s) of %d ms", opcode_name(opcode),
                 c->retries + 1, c->timeout_ms);
    else
        snprintf(what, sizeof what, "%s failed: %s", opcode_name(opcode), wdr_transport_strerror(code));
    return fail(c, code, what);
}

/* ---- Requests ----------------------------------------------------------------------------- */

enum { GOT_RESPONSE = 1, RETRY = 2 };

/* Handle one decoder result while waiting for the answer to c->seq. */
static int on_result(wdr_client *c, int r, const wdr_packet *p, uint8_t opcode)
{
    int ours = (p->h.flags & WDR_FLAG_RESPONSE) && p->h.seq == c->seq;
    if (r != WDR_FEED_PACKET && ours) {
        c->garbled[r == WDR_FEED_TOO_LARGE]++;
        return RETRY; /* a garbled answer: ask again, the board resends it */
    }
    if (r != WDR_FEED_PACKET)
        return WDR_OK;
    if (p->h.flags & WDR_FLAG_EVENT)
        return c->on_event ? c->on_event(c->event_ctx, p) : WDR_OK;
    if (!ours)
        return WDR_OK; /* a late answer to an earlier attempt */
    if (p->h.opcode != opcode) {
        char what[128];
        snprintf(what, sizeof what, "answer to %s carries opcode 0x%02x", opcode_name(opcode), p->h.opcode);
        return fail(c, WDR_E_PROTOCOL, what);
    }
    c->status = p->h.status;
    c->reply_len = p->h.length;
    memcpy(c->reply, p->payload, p->h.length);
    return GOT_RESPONSE;
}

/* Send the encoded request in c->tx and wait for its answer; GOT_RESPONSE, RETRY or an error. */
static int one_attempt(wdr_client *c, size_t frame_len, uint8_t opcode)
{
    int rc = wdr_transport_send(c->t, c->tx, frame_len, c->timeout_ms);
    if (rc == WDR_E_TIMEOUT)
        return RETRY;
    if (rc != WDR_OK)
        return transport_fail(c, rc, opcode);
    c->tx_bytes += frame_len;
    int64_t deadline = wdr_transport_now_ms() + c->timeout_ms;
    for (;;) {
        wdr_packet p;
        int r = next_packet(c, deadline, &p);
        if (r == WDR_E_TIMEOUT)
            return RETRY;
        if (r < 0)
            return transport_fail(c, r, opcode);
        rc = on_result(c, r, &p, opcode);
        if (rc != WDR_OK)
            return rc;
    }
}

static size_t encode_request(wdr_client *c, uint8_t opcode, const void *payload, uint32_t len)
{
    wdr_proto_header h = {.opcode = opcode, .seq = c->seq};
    return wdr_proto_encode(c->tx, sizeof c->tx, &h, payload, len);
}

/* A BAD_CRC answer to anything but a commit means our request was damaged on the way (a
 * commit's BAD_CRC is about the uploaded bytes). */
static int request_was_damaged(const wdr_client *c, uint8_t opcode)
{
    return c->status == WDR_ST_BAD_CRC && opcode != WDR_CMD_LUT_COMMIT && opcode != WDR_CMD_CAL_COMMIT &&
           opcode != WDR_CMD_FW_COMMIT;
}

/* Every attempt ended without a usable answer: name what came back, if anything did. */
static int no_good_answer(wdr_client *c, uint8_t opcode)
{
    if (!c->garbled[0] && !c->garbled[1])
        return transport_fail(c, WDR_E_TIMEOUT, opcode);
    char what[224];
    snprintf(what, sizeof what, "no valid answer to %s after %d attempt(s) of %d ms: %u garbled (payload CRC wrong), "
             "%u oversize (length over %u bytes)", opcode_name(opcode), c->retries + 1, c->timeout_ms, c->garbled[0],
             c->garbled[1], WDR_PROTO_MAX_PAYLOAD);
    return fail(c, WDR_E_PROTOCOL, what);
}

int wdr_client_request(wdr_client *c, uint8_t opcode, const void *payload, uint32_t len)
{
    if (len > WDR_PROTO_MAX_PAYLOAD)
        return fail(c, WDR_E_TOO_LARGE, "request payload too large");
    c->seq++;
    c->garbled[0] = c->garbled[1] = 0;
    size_t frame_len = encode_request(c, opcode, payload, len);
    for (int attempt = 0; attempt <= c->retries; attempt++) {
        if (attempt)
            c->retries_used++;
        int rc = one_attempt(c, frame_len, opcode);
        if (rc == GOT_RESPONSE && request_was_damaged(c, opcode) && attempt < c->retries) {
            c->seq++; /* a fresh number, so the board executes it rather than replaying BAD_CRC */
            frame_len = encode_request(c, opcode, payload, len);
            continue;
        }
        if (rc == GOT_RESPONSE && c->status == WDR_ST_OK)
            return WDR_OK;
        if (rc == GOT_RESPONSE) {
            char what[128];
            snprintf(what, sizeof what, "board refused %s: %s", opcode_name(opcode), wdr_status_name(c->status));
            return fail(c, WDR_E_STATUS, what);
        }
        if (rc != RETRY)
            return rc; /* c->err says why */
    }
    return no_good_answer(c, opcode);
}

/* ---- Connect, status, illuminant ------------------------------------------------------------ */

typedef struct field_limit {
    const char *name;
    uint64_t value, lo, hi;
} field_limit;

static int check_fields(wdr_client *c, const char *answer, const field_limit *f, size_t n)
{
    for (size_t k = 0; k < n; k++)
        if (f[k].value < f[k].lo || f[k].value > f[k].hi) {
            char what[192];
            snprintf(what, sizeof what, "%s answer: field '%s' is %llu, not %llu..%llu (firmware/SPEC.md, field limits)",
                     answer, f[k].name, (unsigned long long)f[k].value, (unsigned long long)f[k].lo,
                     (unsigned long long)f[k].hi);
            return fail(c, WDR_E_PROTOCOL, what);
        }
    return WDR_OK;
}

/* Every INFO field later code sizes, shifts or waits with, checked once here: a hostile or broken
 * board's adc_bits of 40 was an undefined shift, a 0x0 sensor a 0x0 image written with exit 0, a
 * row time of 4 s on 65535 rows a 78-hour wait. */
static int info_check(wdr_client *c)
{
    const wdr_info *i = &c->info;
    const field_limit f[] = {
        {"width", i->width, 1, WDR_PROTO_MAX_ROW_WIDTH},
        {"height", i->height, 1, WDR_PROTO_MAX_HEIGHT},
        {"adc_bits", i->adc_bits, 1, 16},
        {"dac_bits", i->dac_bits, 1, 16},
        {"row_time_ns", i->row_time_ns, 0, WDR_PROTO_MAX_ROW_TIME_NS},
        {"height x row_time_ns", (uint64_t)i->height * i->row_time_ns, 0, WDR_PROTO_MAX_READOUT_NS},
    };
    return check_fields(c, "INFO", f, sizeof f / sizeof f[0]);
}

/* The STATUS fields a capture's wait is sized with. */
static int status_check(wdr_client *c, const wdr_status_report *s)
{
    const field_limit f[] = {
        {"integration_ns", s->integration_ns, 0, WDR_PROTO_MAX_INTEGRATION_NS},
    };
    return check_fields(c, "STATUS", f, sizeof f / sizeof f[0]);
}

/* A connection the board never answers: it serves one host at a time, so the likeliest reason
 * is another host holding it. Say so instead of only "no answer". */
static int connect_timed_out(wdr_client *c)
{
    char what[224];
    snprintf(what, sizeof what, "no answer to INFO after %d attempt(s) of %d ms: another host may hold the board "
             "(it serves one host at a time), or it is not running", c->retries + 1, c->timeout_ms);
    return fail(c, WDR_E_TIMEOUT, what);
}

int wdr_client_connect(wdr_client *c, wdr_transport *t)
{
    wdr_event_fn keep_fn = c->on_event;
    void *keep_ctx = c->event_ctx;
    int timeout = c->timeout_ms > 0 ? c->timeout_ms : WDR_CLIENT_TIMEOUT_MS;
    int retries = c->retries >= 0 ? c->retries : WDR_CLIENT_RETRIES; /* 0: exactly one attempt */
    memset(c, 0, sizeof *c);
    c->t = t;
    c->timeout_ms = timeout;
    c->retries = retries;
    c->on_event = keep_fn;
    c->event_ctx = keep_ctx;
    /* A random first number: a board that remembers the last request of an earlier host
     * must not take our first request for a retry of it. */
    c->seq = (uint16_t)(getpid() * 2654435761u ^ (uint32_t)wdr_transport_now_ms());
    wdr_proto_decoder_init(&c->dec);
    /* A new session: the board stops whatever an earlier host left running (SPEC.md, INFO). */
    uint8_t ver[WDR_INFO_REQUEST_SIZE];
    wdr_put_u16(ver, WDR_PROTO_VERSION_MAJOR);
    wdr_put_u16(ver + 2, WDR_PROTO_VERSION_MINOR);
    wdr_put_u32(ver + 4, WDR_INFO_FLAG_NEW_SESSION);
    int rc = wdr_client_request(c, WDR_CMD_INFO, ver, sizeof ver);
    if (rc == WDR_E_TIMEOUT)
        return connect_timed_out(c);
    if (rc != WDR_OK && !(rc == WDR_E_STATUS && c->status == WDR_ST_BAD_VERSION))
        return rc;
    if (wdr_info_unpack(c->reply, c->reply_len, &c->info) != WDR_OK)
        return fail(c, WDR_E_PROTOCOL, "INFO answer too short");
    if (rc != WDR_OK || c->info.proto_major != WDR_PROTO_VERSION_MAJOR) {
        char what[160];
        snprintf(what, sizeof what, "board speaks protocol %u.%u, this wdrctl speaks %d.%d", c->info.proto_major,
                 c->info.proto_minor, WDR_PROTO_VERSION_MAJOR, WDR_PROTO_VERSION_MINOR);
        return fail(c, WDR_E_VERSION, what);
    }
    return info_check(c);
}

int wdr_client_status(wdr_client *c, wdr_status_report *out)
{
    int rc = wdr_client_request(c, WDR_CMD_STATUS, NULL, 0);
    if (rc == WDR_OK && wdr_status_unpack(c->reply, c->reply_len, out) != WDR_OK)
        return fail(c, WDR_E_PROTOCOL, "STATUS answer too short");
    return rc == WDR_OK ? status_check(c, out) : rc;
}

int wdr_client_set_illuminant(wdr_client *c, double amps)
{
    uint8_t p[8];
    uint64_t bits;
    memcpy(&bits, &amps, sizeof bits);
    wdr_put_u32(p, (uint32_t)bits);
    wdr_put_u32(p + 4, (uint32_t)(bits >> 32));
    return wdr_client_request(c, WDR_CMD_SIM_SET_ILLUMINANT, p, sizeof p);
}

int wdr_client_restore_scene(wdr_client *c)
{
    if (c->info.proto_minor < 4) {
        char what[96];
        snprintf(what, sizeof what, "putting the scene back needs protocol 1.4; the board speaks %u.%u",
                 c->info.proto_major, c->info.proto_minor);
        return fail(c, WDR_E_UNSUPPORTED, what);
    }
    return wdr_client_request(c, WDR_CMD_SIM_SET_ILLUMINANT, NULL, 0);
}

/* ---- Uploads ------------------------------------------------------------------------------ */

static void abort_quietly(wdr_client *c)
{
    char keep[sizeof c->err];
    int keep_status = c->status;
    memcpy(keep, c->err, sizeof keep);
    int retries = c->retries;
    c->retries = 0;
    wdr_client_request(c, WDR_CMD_ABORT, NULL, 0);
    c->retries = retries;
    c->status = keep_status;
    memcpy(c->err, keep, sizeof keep);
}

static int upload_chunks(wdr_client *c, uint8_t op_chunk, const uint8_t *table, size_t len, wdr_progress_fn progress,
                         void *progress_ctx)
{
    uint8_t p[WDR_CHUNK_OFFSET_SIZE + WDR_PROTO_CHUNK_DATA_MAX];
    for (size_t off = 0; off < len; off += WDR_PROTO_CHUNK_DATA_MAX) {
        size_t n = len - off < WDR_PROTO_CHUNK_DATA_MAX ? len - off : WDR_PROTO_CHUNK_DATA_MAX;
        wdr_put_u32(p, (uint32_t)off);
        memcpy(p + WDR_CHUNK_OFFSET_SIZE, table + off, n);
        int rc = wdr_client_request(c, op_chunk, p, (uint32_t)(WDR_CHUNK_OFFSET_SIZE + n));
        if (rc != WDR_OK) {
            size_t used = strlen(c->err);
            snprintf(c->err + used, sizeof c->err - used, " (chunk at byte %zu of %zu)", off, len);
            return rc;
        }
        if (progress)
            progress(progress_ctx, off + n, len);
    }
    return WDR_OK;
}

static int check_commit(wdr_client *c, uint32_t crc, wdr_commit_reply *out)
{
    wdr_commit_reply r;
    if (wdr_commit_unpack(c->reply, c->reply_len, &r) != WDR_OK)
        return fail(c, WDR_E_PROTOCOL, "COMMIT answer too short");
    if (r.crc != crc) {
        char what[128];
        snprintf(what, sizeof what, "board read back CRC %08x, the table sent has %08x", r.crc, crc);
        return fail(c, WDR_E_CORRUPT, what);
    }
    if (out)
        *out = r;
    return WDR_OK;
}

/* BEGIN, CHUNKs, COMMIT of one kind (op_begin; CHUNK and COMMIT follow it in every kind's
 * opcodes); the COMMIT's answer is left in c->reply. A refusal ends with an ABORT. */
static int upload_bytes(wdr_client *c, uint8_t op_begin, const uint8_t *data, size_t len, uint32_t crc,
                        wdr_progress_fn progress, void *progress_ctx)
{
    if (len == 0 || len > 0xffffffffu)
        return fail(c, WDR_E_INVAL, "nothing to upload, or more than 4 GiB");
    uint8_t begin[WDR_BEGIN_SIZE];
    wdr_put_u32(begin, (uint32_t)len);
    wdr_put_u32(begin + 4, crc);
    int rc = wdr_client_request(c, op_begin, begin, sizeof begin);
    if (rc == WDR_OK)
        rc = upload_chunks(c, (uint8_t)(op_begin + 1), data, len, progress, progress_ctx);
    c->commit_unknown = 0;
    if (rc == WDR_OK) {
        rc = wdr_client_request(c, (uint8_t)(op_begin + 2), NULL, 0);
        c->commit_unknown = rc == WDR_E_IO || rc == WDR_E_TIMEOUT; /* sent, maybe done, no answer */
    }
    if (rc != WDR_OK && rc != WDR_E_IO)
        abort_quietly(c);
    return rc;
}

int wdr_client_upload(wdr_client *c, int kind, const uint8_t *table, size_t len, wdr_progress_fn progress,
                      void *progress_ctx, wdr_commit_reply *out)
{
    uint8_t op = kind == WDR_KIND_CAL ? WDR_CMD_CAL_BEGIN : WDR_CMD_LUT_BEGIN;
    uint32_t crc = len ? wdr_crc32(0, table, len) : 0;
    int rc = upload_bytes(c, op, table, len, crc, progress, progress_ctx);
    return rc == WDR_OK ? check_commit(c, crc, out) : rc;
}

/* ---- Firmware images (protocol 1.4) ------------------------------------------------------------ */

static int need_fw_protocol(wdr_client *c)
{
    if (c->info.proto_major == WDR_PROTO_VERSION_MAJOR && c->info.proto_minor >= 4)
        return WDR_OK;
    char what[160];
    snprintf(what, sizeof what, "board speaks protocol %u.%u: firmware update needs 1.4 (flash it with a debugger)",
             c->info.proto_major, c->info.proto_minor);
    return fail(c, WDR_E_UNSUPPORTED, what);
}

int wdr_client_fw_upload(wdr_client *c, const uint8_t *img, size_t len, wdr_progress_fn progress, void *progress_ctx,
                         wdr_fw_commit *out)
{
    int rc = need_fw_protocol(c);
    if (rc == WDR_OK)
        rc = upload_bytes(c, WDR_CMD_FW_BEGIN, img, len, len ? wdr_crc32(0, img, len) : 0, progress, progress_ctx);
    if (rc != WDR_OK)
        return rc;
    wdr_fw_commit r = {.slot = c->reply_len ? c->reply[0] : 0xff};
    if (c->reply_len < WDR_FW_COMMIT_REPLY_SIZE || r.slot > 1 ||
        wdr_image_header_parse(c->reply + 4, UINT32_MAX, &r.hdr) != WDR_OK)
        return fail(c, WDR_E_PROTOCOL, "FW_COMMIT answer is not a slot and an image header");
    if (out)
        *out = r;
    return WDR_OK;
}

int wdr_client_fw_status(wdr_client *c, wdr_fw_status_report *out)
{
    int rc = need_fw_protocol(c);
    if (rc == WDR_OK)
        rc = wdr_client_request(c, WDR_CMD_FW_STATUS, NULL, 0);
    if (rc == WDR_OK && wdr_fw_status_unpack(c->reply, c->reply_len, out) != WDR_OK)
        return fail(c, WDR_E_PROTOCOL, "FW_STATUS answer too short");
    return rc;
}

int wdr_client_fw_request(wdr_client *c, uint8_t opcode)
{
    int rc = need_fw_protocol(c);
    return rc == WDR_OK ? wdr_client_request(c, opcode, NULL, 0) : rc;
}

/* ---- Capture and stream ------------------------------------------------------------------------ */

/* What arrived since the last complete frame, for the message when none completes in time. */
typedef struct capture_seen {
    uint32_t packets;  /* decoded packets and garbled frames */
    uint32_t rows;     /* ROW events of this request */
    uint32_t foreign;  /* events of another request's sequence number */
    uint32_t garbled;  /* frames with a bad payload CRC or over the length limit */
} capture_seen;

typedef struct capture_ctx {
    wdr_client *c;
    wdr_frame frame;
    uint32_t frames_done, frames_wanted;
    wdr_frame_fn on_frame;
    void *ctx;
    int stopping;          /* stream: frames after the stop are dropped */
    int open;              /* rows of frame `number` arrived, its FRAME_END not yet */
    uint32_t number;       /* the frame number those rows carry */
    capture_seen seen;
    uint8_t row_seen[WDR_PROTO_MAX_HEIGHT / 8]; /* bit per row of the open frame: each must come once */
} capture_ctx;

static int row_was_seen(const capture_ctx *k, uint32_t row) { return k->row_seen[row / 8] >> (row % 8) & 1; }

static int refuse_frame(capture_ctx *k, const char *why)
{
    char what[224];
    snprintf(what, sizeof what, "frame %u refused: %s", k->number, why);
    return fail(k->c, WDR_E_FRAME, what);
}

/* The rows of the open frame that did not arrive, as ranges ("rows 1-3, 7 missing"). */
static void missing_rows(const capture_ctx *k, char *out, size_t cap)
{
    size_t len = (size_t)snprintf(out, cap, "rows");
    uint32_t h = k->frame.height, ranges = 0;
    for (uint32_t r = 0; r < h && len < cap; r++) {
        if (row_was_seen(k, r))
            continue;
        uint32_t last = r;
        while (last + 1 < h && !row_was_seen(k, last + 1))
            last++;
        if (++ranges > 6) {
            snprintf(out + len, cap - len, " ...");
            return;
        }
        len += (size_t)(last == r ? snprintf(out + len, cap - len, "%s %u", ranges > 1 ? "," : "", r)
                                  : snprintf(out + len, cap - len, "%s %u-%u", ranges > 1 ? "," : "", r, last));
        r = last;
    }
}

/* A new frame begins with its first row: the bitmap starts empty. */
static int open_frame(capture_ctx *k, uint32_t number)
{
    if (k->open && number != k->number) {
        char why[96];
        snprintf(why, sizeof why, "rows of frame %u began before its FRAME_END (%u of %u rows)", number,
                 k->frame.rows_seen, k->frame.height);
        return refuse_frame(k, why);
    }
    if (!k->open) {
        memset(k->row_seen, 0, (k->frame.height + 7u) / 8u);
        k->frame.rows_seen = 0;
        k->number = number;
        k->open = 1;
    }
    return WDR_OK;
}

static int take_row(capture_ctx *k, const wdr_packet *p)
{
    const uint8_t *q = p->payload;
    if (p->h.length < WDR_PROTO_ROW_HEADER)
        return fail(k->c, WDR_E_PROTOCOL, "ROW event too short");
    uint16_t row = wdr_get_u16(q + 4), width = wdr_get_u16(q + 6);
    if (width != k->frame.width || p->h.length != WDR_PROTO_ROW_HEADER + 2u * width) {
        char what[128];
        snprintf(what, sizeof what, "ROW event of width %u and %u bytes does not fit the %u-pixel rows", width,
                 p->h.length, k->frame.width);
        return fail(k->c, WDR_E_PROTOCOL, what);
    }
    int rc = open_frame(k, wdr_get_u32(q));
    if (rc != WDR_OK)
        return rc;
    char why[96];
    if (row >= k->frame.height) {
        snprintf(why, sizeof why, "row %u is outside the sensor's rows 0-%u", row, k->frame.height - 1u);
        return refuse_frame(k, why);
    }
    if (row_was_seen(k, row)) {
        snprintf(why, sizeof why, "row %u arrived twice", row);
        return refuse_frame(k, why);
    }
    k->row_seen[row / 8] |= (uint8_t)(1u << (row % 8));
    uint16_t *dst = k->frame.codes + (size_t)row * width;
    for (uint16_t i = 0; i < width; i++)
        dst[i] = wdr_get_u16(q + WDR_PROTO_ROW_HEADER + 2u * i);
    k->frame.rows_seen++;
    k->seen.rows++;
    return WDR_OK;
}

/* Complete only when every row arrived once, and the FRAME_END agrees. */
static int take_frame_end(capture_ctx *k, const wdr_packet *p)
{
    if (wdr_frame_end_unpack(p->payload, p->h.length, &k->frame.end) != WDR_OK)
        return fail(k->c, WDR_E_PROTOCOL, "FRAME_END event too short");
    const wdr_frame_end *e = &k->frame.end;
    char why[192];
    if (!k->open) {
        k->number = e->frame;
        memset(k->row_seen, 0, (k->frame.height + 7u) / 8u);
        k->frame.rows_seen = 0;
    }
    k->open = 0;
    if (e->frame != k->number) {
        snprintf(why, sizeof why, "its FRAME_END carries frame number %u", e->frame);
        return refuse_frame(k, why);
    }
    if (k->frame.rows_seen != k->frame.height) {
        char rows[128];
        missing_rows(k, rows, sizeof rows);
        snprintf(why, sizeof why, "%s missing (%u of %u rows arrived)", rows, k->frame.rows_seen, k->frame.height);
        return refuse_frame(k, why);
    }
    if (e->rows != k->frame.height) {
        snprintf(why, sizeof why, "its FRAME_END counts %u rows, the sensor has %u", e->rows, k->frame.height);
        return refuse_frame(k, why);
    }
    k->frames_done++;
    k->seen = (capture_seen){0};
    return k->on_frame ? k->on_frame(k->ctx, &k->frame) : WDR_OK;
}

static int capture_event(void *ctx, const wdr_packet *p)
{
    capture_ctx *k = ctx;
    k->seen.packets++;
    if (k->stopping)
        return WDR_OK; /* rows still in flight belong to a frame nobody wants */
    if (p->h.seq != k->c->seq) {
        k->seen.foreign++;
        return WDR_OK; /* left over from an earlier capture */
    }
    if (p->h.opcode == WDR_CMD_ROW)
        return take_row(k, p);
    if (p->h.opcode == WDR_CMD_FRAME_END)
        return take_frame_end(k, p);
    return WDR_OK;
}

static int frame_overdue(capture_ctx *k, int64_t frame_ms)
{
    char what[200];
    snprintf(what, sizeof what, "no complete frame within %lld ms (the board's frame time and --timeout): %u frame(s) "
             "received, then %u packet(s): %u row(s) of this request, %u event(s) of another request, %u garbled",
             (long long)frame_ms, k->frames_done, k->seen.packets, k->seen.rows, k->seen.foreign, k->seen.garbled);
    return fail(k->c, WDR_E_TIMEOUT, what);
}

/* Events until the frames wanted (or *stop). One deadline per frame, frame_ms after the last
 * complete one: packets that keep coming (another request's rows, garbage) do not extend it. */
static int pump_events(capture_ctx *k, int64_t frame_ms, volatile int *stop)
{
    wdr_client *c = k->c;
    int64_t deadline = wdr_transport_now_ms() + frame_ms;
    while (k->frames_done < k->frames_wanted && !(stop && *stop)) {
        wdr_packet p;
        uint32_t done = k->frames_done;
        int r = next_packet(c, deadline, &p);
        if (r == WDR_E_TIMEOUT)
            return frame_overdue(k, frame_ms);
        if (r < 0)
            return transport_fail(c, r, WDR_CMD_CAPTURE);
        if (r != WDR_FEED_PACKET) {
            k->seen.packets++;
            k->seen.garbled++; /* garbled events cannot be asked for again; the frame check catches gaps */
            continue;
        }
        if (!(p.h.flags & WDR_FLAG_EVENT))
            continue;
        int rc = capture_event(k, &p);
        if (rc != WDR_OK)
            return rc;
        if (k->frames_done != done)
            deadline = wdr_transport_now_ms() + frame_ms;
    }
    return WDR_OK;
}

/* Time a frame may take: reset, the integration in force (STATUS) and the readout (INFO), each
 * within the protocol's limits (checked at connect and in wdr_client_status), plus one
 * --timeout for the link. */
static int frame_wait_ms(wdr_client *c, int64_t *out)
{
    wdr_status_report st;
    int rc = wdr_client_status(c, &st);
    if (rc != WDR_OK)
        return rc;
    uint64_t ns = 1000000u + (uint64_t)st.integration_ns + (uint64_t)c->info.height * c->info.row_time_ns;
    *out = c->timeout_ms + (int64_t)((ns + 999999u) / 1000000u);
    return WDR_OK;
}

static int run_capture(wdr_client *c, capture_ctx *k, uint8_t opcode, const uint8_t *arg, uint32_t arg_len,
                       volatile int *stop)
{
    int64_t frame_ms;
    int rc = frame_wait_ms(c, &frame_ms);
    if (rc != WDR_OK)
        return rc;
    k->c = c;
    k->frame.width = c->info.width;
    k->frame.height = c->info.height;
    c->on_event = capture_event;
    c->event_ctx = k;
    rc = wdr_client_request(c, opcode, arg, arg_len);
    if (rc == WDR_OK)
        rc = pump_events(k, frame_ms, stop);
    return rc;
}

static int capture(wdr_client *c, uint32_t n, int raw, uint16_t *codes, wdr_frame_fn on_frame, void *ctx)
{
    if (n == 0 || n > 65535)
        return fail(c, WDR_E_INVAL, "frame count must be 1..65535");
    if (raw && c->info.proto_minor < 1) {
        char what[160];
        snprintf(what, sizeof what, "board speaks protocol %u.%u: raw frames need 1.1 (update its firmware)",
                 c->info.proto_major, c->info.proto_minor);
        return fail(c, WDR_E_UNSUPPORTED, what);
    }
    capture_ctx k = {.frame.codes = codes, .frames_wanted = n, .on_frame = on_frame, .ctx = ctx};
    uint8_t arg[5];
    wdr_put_u32(arg, n);
    arg[4] = WDR_CAPTURE_RAW;
    int rc = run_capture(c, &k, WDR_CMD_CAPTURE, arg, raw ? 5u : 4u, NULL);
    c->on_event = NULL;
    if (rc != WDR_OK && rc != WDR_E_IO)
        abort_quietly(c);
    return rc;
}

int wdr_client_capture(wdr_client *c, uint32_t n, uint16_t *codes, wdr_frame_fn on_frame, void *ctx)
{
    return capture(c, n, 0, codes, on_frame, ctx);
}

int wdr_client_capture_raw(wdr_client *c, uint32_t n, uint16_t *codes, wdr_frame_fn on_frame, void *ctx)
{
    return capture(c, n, 1, codes, on_frame, ctx);
}

int wdr_client_stream(wdr_client *c, uint16_t *codes, wdr_frame_fn on_frame, void *ctx, volatile int *stop)
{
    capture_ctx k = {.frame.codes = codes, .frames_wanted = UINT32_MAX, .on_frame = on_frame, .ctx = ctx};
    uint8_t on = 1, off = 0;
    int rc = run_capture(c, &k, WDR_CMD_STREAM, &on, 1, stop);
    if (rc == WDR_E_IO) {
        c->on_event = NULL; /* k dies with this frame: a later request must not call into it */
        return rc;
    }
    k.stopping = 1; /* capture_event drops what is still in flight */
    char why[sizeof c->err];
    memcpy(why, c->err, sizeof why);
    int rc_off = wdr_client_request(c, WDR_CMD_STREAM, &off, 1);
    c->on_event = NULL;
    if (rc != WDR_OK)
        memcpy(c->err, why, sizeof why); /* what stopped the stream, not the stop's own failure */
    return rc != WDR_OK ? rc : rc_off;
}
