/* Requests from the host: every packet gets exactly one response with a status, and a
 * request that fails changes nothing (SPEC.md, "Wire protocol"). */
#include "fw_internal.h"
#include <string.h>

/* ---- Responses ------------------------------------------------------------------------------ */

void wdr_fw_reply(wdr_fw *fw, const wdr_proto_header *req, int status, const uint8_t *payload, uint32_t len)
{
    uint8_t *p = wdr_fw_tx_reserve(fw);
    if (!p) /* wdr_fw_rx_service only takes a packet when a buffer is free */
        return;
    if (len)
        memcpy(p + WDR_PROTO_HEADER_SIZE, payload, len);
    wdr_proto_header h = {req->opcode, WDR_FLAG_RESPONSE, req->seq, (uint8_t)status, 0, 0};
    uint32_t frame_len = WDR_PROTO_HEADER_SIZE + len;
    wdr_fw_tx_commit(fw, &h, len);
    fw->last_seq = req->seq;
    fw->last_opcode = req->opcode;
    fw->last_response_len = frame_len <= sizeof fw->last_response ? frame_len : 0;
    if (fw->last_response_len)
        memcpy(fw->last_response, p, frame_len);
}

static void reply_status(wdr_fw *fw, const wdr_packet *pkt, int status)
{
    wdr_fw_reply(fw, &pkt->h, status, NULL, 0);
}


/* A retry of the request answered last: resend the answer, do not execute it twice.
 * INFO, STATUS and FW_STATUS only read, so they always run (a new host may reuse a number). */
static int resend_if_retry(wdr_fw *fw, const wdr_packet *pkt)
{
    if (!fw->last_response_len || pkt->h.seq != fw->last_seq || pkt->h.opcode != fw->last_opcode ||
        pkt->h.opcode == WDR_CMD_INFO || pkt->h.opcode == WDR_CMD_STATUS || pkt->h.opcode == WDR_CMD_FW_STATUS)
        return 0;
    uint8_t *p = wdr_fw_tx_reserve(fw);
    memcpy(p, fw->last_response, fw->last_response_len);
    wdr_fw_tx_commit_raw(fw, fw->last_response_len);
    return 1;
}

/* ---- Identity and state ------------------------------------------------------------------------ */

static void cmd_info(wdr_fw *fw, const wdr_packet *pkt)
{
    wdr_info in;
    uint8_t out[WDR_INFO_SIZE];
    if (pkt->h.length < 4) {
        reply_status(fw, pkt, WDR_ST_BAD_LENGTH);
        return;
    }
    memset(&in, 0, sizeof in);
    in.proto_major = WDR_PROTO_VERSION_MAJOR;
    in.proto_minor = WDR_PROTO_VERSION_MINOR;
    in.fw_major = WDR_FW_VERSION_MAJOR;
    in.fw_minor = WDR_FW_VERSION_MINOR;
    in.sensor_id = fw->board.sensor_id;
    in.width = fw->board.width;
    in.height = fw->board.height;
    in.adc_bits = fw->board.adc_bits;
    in.dac_bits = fw->board.dac_bits;
    in.caps = (fw->board.caps & HAL_CAP_ILLUMINANT) ? WDR_INFO_CAP_ILLUMINANT : 0;
    in.max_payload = WDR_PROTO_MAX_PAYLOAD;
    in.lut_capacity = fw->boot_err ? 0 : fw->store.slot[0][0].capacity;
    in.cal_capacity = fw->boot_err ? 0 : fw->store.slot[1][0].capacity;
    in.row_time_ns = fw->board.row_time_ns;
    memcpy(in.name, fw->board.name, sizeof in.name);
    wdr_fw_update_info(fw, &in);
    wdr_info_pack(&in, out);
    int same = wdr_get_u16(pkt->payload) == WDR_PROTO_VERSION_MAJOR;
    /* A new host session (1.1): the last host left without stopping what it started (a killed
     * process leaves no trace on the bus), so stop it now. */
    if (same && pkt->h.length >= WDR_INFO_REQUEST_SIZE &&
        (wdr_get_u32(pkt->payload + 4) & WDR_INFO_FLAG_NEW_SESSION)) {
        wdr_fw_frame_stop(fw);
        wdr_store_abort(&fw->store);
        wdr_fw_update_abort(fw);
    }
    wdr_fw_reply(fw, &pkt->h, same ? WDR_ST_OK : WDR_ST_BAD_VERSION, out, sizeof out);
}

static void cmd_status(wdr_fw *fw, const wdr_packet *pkt)
{
    wdr_status_report r;
    uint8_t out[WDR_STATUS_SIZE];
    wdr_fw_status(fw, &r);
    wdr_status_pack(&r, out);
    wdr_fw_reply(fw, &pkt->h, WDR_ST_OK, out, sizeof out);
}

/* ---- Table uploads ------------------------------------------------------------------------------ */

static int kind_of(uint8_t opcode) { return (opcode & 0xf0u) == 0x10u ? WDR_KIND_LUT : WDR_KIND_CAL; }

static int active_slot(const wdr_fw *fw, int kind) { return kind == WDR_KIND_LUT ? fw->lut_slot : fw->cal_slot; }

/* Status for a request that needs the store and an idle sensor; OK if it may go on. */
static int upload_gate(const wdr_fw *fw, const wdr_packet *pkt, uint32_t min_len, uint32_t max_len)
{
    if (pkt->h.length < min_len || pkt->h.length > max_len)
        return WDR_ST_BAD_LENGTH;
    if (fw->boot_err)
        return WDR_ST_UNSUPPORTED;
    return WDR_ST_OK;
}

static void cmd_begin(wdr_fw *fw, const wdr_packet *pkt)
{
    int kind = kind_of(pkt->h.opcode), st = upload_gate(fw, pkt, WDR_BEGIN_SIZE, WDR_BEGIN_SIZE);
    uint32_t len = st ? 0 : wdr_get_u32(pkt->payload);
    if (!st && wdr_fw_busy(fw))
        st = WDR_ST_BUSY;
    if (!st && len == 0)
        st = WDR_ST_BAD_LENGTH;
    if (!st)
        wdr_fw_update_abort(fw); /* one upload at a time: a BEGIN restarts it */
    if (!st)
        st = wdr_status_from_err(wdr_store_begin(&fw->store, kind, active_slot(fw, kind), len,
                                                 wdr_get_u32(pkt->payload + 4)));
    reply_status(fw, pkt, st);
}

static void cmd_chunk(wdr_fw *fw, const wdr_packet *pkt)
{
    int st = upload_gate(fw, pkt, WDR_CHUNK_OFFSET_SIZE + 1u, WDR_PROTO_MAX_PAYLOAD);
    if (!st && wdr_fw_update_open(fw))
        st = WDR_ST_BAD_KIND; /* an image upload is open */
    if (!st)
        st = wdr_status_from_err(wdr_store_chunk(&fw->store, kind_of(pkt->h.opcode), wdr_get_u32(pkt->payload),
                                                 pkt->payload + WDR_CHUNK_OFFSET_SIZE,
                                                 pkt->h.length - WDR_CHUNK_OFFSET_SIZE));
    reply_status(fw, pkt, st);
}

/* Finish, check content, seal, activate: any failure before the seal leaves the old table. */
static int commit_upload(wdr_fw *fw, int kind, wdr_commit_reply *out)
{
    int err = wdr_store_finish(&fw->store, kind);
    if (err == WDR_E_SEQUENCE || err == WDR_E_KIND)
        return err; /* not this upload's fault: leave it be */
    int slot = fw->store.up_slot;
    if (!err)
        err = wdr_fw_table_check(fw, kind, slot, fw->store.up_len);
    if (!err)
        err = wdr_store_seal(&fw->store);
    wdr_store_abort(&fw->store);
    if (err)
        return err;
    wdr_fw_table_activate(fw, kind, slot);
    const wdr_slot *s = &fw->store.slot[kind - 1][slot];
    out->crc = s->crc;
    out->seq = s->seq;
    out->slot = (uint8_t)slot;
    return WDR_OK;
}

static void cmd_commit(wdr_fw *fw, const wdr_packet *pkt)
{
    wdr_commit_reply c;
    uint8_t out[WDR_COMMIT_REPLY_SIZE];
    int st = upload_gate(fw, pkt, 0, 0);
    if (!st && wdr_fw_busy(fw))
        st = WDR_ST_BUSY;
    if (!st && wdr_fw_update_open(fw))
        st = WDR_ST_BAD_KIND; /* an image upload is open */
    if (!st)
        st = wdr_status_from_err(commit_upload(fw, kind_of(pkt->h.opcode), &c));
    if (st) {
        reply_status(fw, pkt, st);
        return;
    }
    wdr_commit_pack(&c, out);
    wdr_fw_reply(fw, &pkt->h, WDR_ST_OK, out, sizeof out);
}

static int select_lut(wdr_fw *fw, uint8_t which)
{
    if (which != WDR_SLOT_NEWEST && which > 1)
        return WDR_E_INVAL;
    int slot = which == WDR_SLOT_NEWEST ? wdr_store_newest(&fw->store, WDR_KIND_LUT, -1) : which;
    if (slot < 0 || !fw->store.slot[0][slot].valid)
        return WDR_E_NO_TABLE;
    if (wdr_fw_table_check(fw, WDR_KIND_LUT, slot, fw->store.slot[0][slot].length))
        return WDR_E_NO_TABLE;
    wdr_fw_table_activate(fw, WDR_KIND_LUT, slot);
    return WDR_OK;
}

static void cmd_lut_select(wdr_fw *fw, const wdr_packet *pkt)
{
    int st = upload_gate(fw, pkt, 1, 1);
    if (!st && wdr_fw_busy(fw))
        st = WDR_ST_BUSY;
    if (!st) {
        int err = select_lut(fw, pkt->payload[0]);
        st = err == WDR_E_INVAL ? WDR_ST_BAD_ARG : wdr_status_from_err(err);
    }
    reply_status(fw, pkt, st);
}

/* ---- Frames ------------------------------------------------------------------------------------- */

static void cmd_set_integration(wdr_fw *fw, const wdr_packet *pkt)
{
    int st = pkt->h.length == 4 ? WDR_ST_OK : WDR_ST_BAD_LENGTH;
    if (!st && wdr_fw_busy(fw))
        st = WDR_ST_BUSY;
    if (!st) {
        int err = wdr_fw_set_integration(fw, wdr_get_u32(pkt->payload));
        st = err == WDR_E_INVAL ? WDR_ST_BAD_ARG : wdr_status_from_err(err);
    }
    reply_status(fw, pkt, st);
}

static void cmd_set_exposure(wdr_fw *fw, const wdr_packet *pkt)
{
    int st = pkt->h.length == 1 ? WDR_ST_OK : WDR_ST_BAD_LENGTH;
    if (!st && wdr_fw_busy(fw))
        st = WDR_ST_BUSY;
    if (!st) {
        int err = wdr_fw_set_exposure(fw, pkt->payload[0]);
        st = err == WDR_E_INVAL ? WDR_ST_BAD_ARG : wdr_status_from_err(err);
    }
    reply_status(fw, pkt, st);
}

/* u32 frames, then (protocol 1.3) an optional u8 of WDR_CAPTURE_* flags. */
static void cmd_capture(wdr_fw *fw, const wdr_packet *pkt)
{
    int st = pkt->h.length == 4 || pkt->h.length == 5 ? WDR_ST_OK : WDR_ST_BAD_LENGTH;
    uint32_t n = st ? 0 : wdr_get_u32(pkt->payload);
    uint8_t flags = !st && pkt->h.length == 5 ? pkt->payload[4] : 0;
    if (!st && (n == 0 || n > 65535u || (flags & ~WDR_CAPTURE_RAW)))
        st = WDR_ST_BAD_ARG;
    if (!st && wdr_fw_busy(fw))
        st = WDR_ST_BUSY; /* the running frames keep their own form */
    if (!st) {
        fw->raw_frames = (flags & WDR_CAPTURE_RAW) != 0;
        st = wdr_status_from_err(wdr_fw_frame_start(fw, n, false, pkt->h.seq));
    }
    reply_status(fw, pkt, st);
}

static void cmd_stream(wdr_fw *fw, const wdr_packet *pkt)
{
    int st = pkt->h.length == 1 && pkt->payload[0] <= 1 ? WDR_ST_OK : WDR_ST_BAD_LENGTH;
    if (!st && pkt->payload[0] && !wdr_fw_busy(fw))
        fw->raw_frames = false;
    if (!st && pkt->payload[0])
        st = wdr_status_from_err(wdr_fw_frame_start(fw, 0, true, pkt->h.seq));
    else if (!st)
        wdr_fw_frame_stop(fw);
    reply_status(fw, pkt, st);
}

static void cmd_abort(wdr_fw *fw, const wdr_packet *pkt)
{
    wdr_fw_frame_stop(fw);
    wdr_store_abort(&fw->store);
    wdr_fw_update_abort(fw);
    reply_status(fw, pkt, WDR_ST_OK);
}

/* ---- Simulation hook ------------------------------------------------------------------------------ */

/* Finite and not negative, judged on the bits: no floating-point compare needed. */
static int illuminant_decode(const wdr_packet *pkt, double *amps)
{
    if (pkt->h.length == 4) {
        uint32_t u = wdr_get_u32(pkt->payload);
        float f;
        memcpy(&f, &u, sizeof f);
        *amps = f;
        return !(u >> 31) && ((u >> 23) & 0xffu) != 0xffu;
    }
    uint64_t u = wdr_get_u32(pkt->payload) | ((uint64_t)wdr_get_u32(pkt->payload + 4) << 32);
    memcpy(amps, &u, sizeof *amps);
    return !(u >> 63) && ((u >> 52) & 0x7ffu) != 0x7ffu;
}

/* A photocurrent lights every pixel uniformly; an empty payload (1.4) puts the scene back. */
static void cmd_illuminant(wdr_fw *fw, const wdr_packet *pkt)
{
    double amps = 0;
    uint32_t len = pkt->h.length;
    int st = len == 0 || len == 4 || len == 8 ? WDR_ST_OK : WDR_ST_BAD_LENGTH;
    if (!st && !(fw->board.caps & HAL_CAP_ILLUMINANT))
        st = WDR_ST_UNSUPPORTED;
    if (!st && len && !illuminant_decode(pkt, &amps))
        st = WDR_ST_BAD_ARG;
    if (!st) {
        int err = len ? hal_set_illuminant(amps) : hal_restore_scene();
        st = err == WDR_E_INVAL ? WDR_ST_BAD_ARG : wdr_status_from_err(err);
    }
    reply_status(fw, pkt, st);
}

/* ---- Dispatch ----------------------------------------------------------------------------------- */

typedef void (*cmd_fn)(wdr_fw *fw, const wdr_packet *pkt);

static cmd_fn handler_for(uint8_t opcode)
{
    switch (opcode) {
    case WDR_CMD_INFO: return cmd_info;
    case WDR_CMD_STATUS: return cmd_status;
    case WDR_CMD_LUT_BEGIN: case WDR_CMD_CAL_BEGIN: return cmd_begin;
    case WDR_CMD_LUT_CHUNK: case WDR_CMD_CAL_CHUNK: return cmd_chunk;
    case WDR_CMD_LUT_COMMIT: case WDR_CMD_CAL_COMMIT: return cmd_commit;
    case WDR_CMD_LUT_SELECT: return cmd_lut_select;
    case WDR_CMD_SET_INTEGRATION: return cmd_set_integration;
    case WDR_CMD_SET_EXPOSURE: return cmd_set_exposure;
    case WDR_CMD_CAPTURE: return cmd_capture;
    case WDR_CMD_STREAM: return cmd_stream;
    case WDR_CMD_ABORT: return cmd_abort;
    case WDR_CMD_FW_BEGIN: return wdr_fw_cmd_fw_begin;
    case WDR_CMD_FW_CHUNK: return wdr_fw_cmd_fw_chunk;
    case WDR_CMD_FW_COMMIT: return wdr_fw_cmd_fw_commit;
    case WDR_CMD_FW_STATUS: return wdr_fw_cmd_fw_status;
    case WDR_CMD_FW_CONFIRM: return wdr_fw_cmd_fw_confirm;
    case WDR_CMD_FW_REVERT: return wdr_fw_cmd_fw_revert;
    case WDR_CMD_REBOOT: return wdr_fw_cmd_reboot;
    case WDR_CMD_SIM_SET_ILLUMINANT: return cmd_illuminant;
    default: return NULL;
    }
}

void wdr_fw_handle(wdr_fw *fw, const wdr_packet *pkt)
{
    if (pkt->h.flags & (WDR_FLAG_RESPONSE | WDR_FLAG_EVENT))
        return; /* only the board answers: never reply to a reply */
    if (resend_if_retry(fw, pkt))
        return;
    cmd_fn fn = handler_for(pkt->h.opcode);
    if (fn)
        fn(fw, pkt);
    else
        reply_status(fw, pkt, WDR_ST_UNSUPPORTED);
}
