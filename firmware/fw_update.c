/* Firmware images over the wire (protocol 1.4; SPEC.md, "Image flash and boot"): uploads into
 * the slot that is not running, the firmware status, confirm, revert and reboot. The flash
 * logic is the boot library's (boot/wdr_boot.h), run over hal_image_flash_*; this file only
 * gates the requests and turns the library's errors into statuses. */
#include "fw_internal.h"
#include "crc32.h"
#include "wdr_boot_crypto.h"
#include <string.h>

/* ---- The image flash, as the boot library sees it ------------------------------------------- */

static int img_read(void *ctx, uint32_t addr, void *buf, uint32_t len)
{
    (void)ctx;
    return hal_image_flash_read(addr, buf, len);
}

static int img_erase(void *ctx, uint32_t block)
{
    (void)ctx;
    return hal_image_flash_erase(block);
}

static int img_prog(void *ctx, uint32_t addr, const void *buf, uint32_t len)
{
    (void)ctx;
    return hal_image_flash_prog(addr, buf, len);
}

/* What an image must be to run here: the same rules the bootloader applies at every boot, so
 * nothing it would reject is ever marked pending. */
static void policy_of(const wdr_fw *fw, wdr_boot_policy *pol)
{
    pol->board = fw->board.name;
    pol->pubkey = wdr_boot_key();
    pol->load_lo = WDR_FW_IMAGE_LOAD_LO;
    pol->load_hi = WDR_FW_IMAGE_LOAD_HI;
    pol->check_signature = true;
}

/* At boot: the bootloader's record (none: not started by it) and the image flash's layout
 * (none: this board has no image flash, FW_* answer UNSUPPORTED). */
void wdr_fw_update_boot(wdr_fw *fw)
{
    hal_flash_geometry g = {0, 0, 0};
    fw->booted = hal_boot_record_get(&fw->boot_rec) == WDR_OK;
    if (fw->booted && fw->boot_rec.slot > 1)
        fw->booted = false; /* a record this firmware cannot act on: run as if unbooted */
    fw->img_flash = (wdr_boot_flash){.read = img_read, .erase = img_erase, .prog = img_prog};
    fw->img_ok = hal_image_flash_geometry_get(&g) == WDR_OK && wdr_boot_layout_init(&fw->img_layout, &g) == WDR_OK;
    fw->img_flash.geo = g;
    wdr_boot_upload_abort(&fw->img_up);
    fw->reboot_due = fw->reverted = false;
}

void wdr_fw_update_abort(wdr_fw *fw) { wdr_boot_upload_abort(&fw->img_up); }

bool wdr_fw_update_open(const wdr_fw *fw) { return fw->img_up.slot >= 0; }

static bool testing(const wdr_fw *fw) { return fw->booted && fw->boot_rec.testing; }

/* INFO 1.4: the running image's version, or the built-in one when not booted from a slot. */
void wdr_fw_update_info(const wdr_fw *fw, wdr_info *in)
{
    if (!fw->booted) {
        in->fw_slot = WDR_SLOT_NONE;
        return;
    }
    const wdr_image_version *v = &fw->boot_rec.hdr.version;
    in->fw_major = v->major;
    in->fw_minor = v->minor;
    in->fw_patch = v->patch;
    in->fw_build = v->build;
    in->fw_slot = fw->boot_rec.slot;
    in->fw_flags = testing(fw) ? 1u : 0u;
}

static void reply_status(wdr_fw *fw, const wdr_packet *pkt, int status) { wdr_fw_reply(fw, &pkt->h, status, NULL, 0); }

/* Errors of the image checks: structure errors are BAD_IMAGE here (BAD_TABLE is for tables). */
static int image_status(int err)
{
    switch (err) {
    case WDR_E_INVAL: case WDR_E_CORRUPT: return WDR_ST_BAD_IMAGE;
    default: return wdr_status_from_err(err);
    }
}

/* ---- Upload ------------------------------------------------------------------------------------ */

/* The slot an upload goes to: never the running one. Not booted from a slot (a debug load, a
 * blank image flash), the one that does not hold a confirmed image, A when neither does. */
static int target_slot(const wdr_fw *fw)
{
    if (fw->booted)
        return fw->boot_rec.slot ? 0 : 1;
    wdr_boot_policy pol;
    wdr_boot_slot s;
    uint32_t floor = 0;
    policy_of(fw, &pol);
    if (wdr_boot_floor_read(&fw->img_flash, &fw->img_layout, &floor) == WDR_OK &&
        wdr_boot_slot_read(&fw->img_flash, &fw->img_layout, 0, &pol, floor, &s) == WDR_OK &&
        s.state == WDR_SLOT_CONFIRMED)
        return 1;
    return 0;
}

/* Why an upload may not start now; OK if it may. */
static int begin_gate(const wdr_fw *fw, const wdr_packet *pkt)
{
    if (pkt->h.length != WDR_BEGIN_SIZE)
        return WDR_ST_BAD_LENGTH;
    if (!fw->img_ok)
        return WDR_ST_UNSUPPORTED;
    if (wdr_fw_busy(fw))
        return WDR_ST_BUSY;
    if (testing(fw) || fw->reverted)
        return WDR_ST_BAD_STATE; /* confirm or revert first, and reboot after a revert: until then the
                                    other slot is the only way back */
    if (wdr_get_u32(pkt->payload) == 0)
        return WDR_ST_BAD_LENGTH;
    return WDR_ST_OK;
}

void wdr_fw_cmd_fw_begin(wdr_fw *fw, const wdr_packet *pkt)
{
    int st = begin_gate(fw, pkt);
    if (!st) {
        wdr_store_abort(&fw->store); /* one upload at a time: a BEGIN restarts it */
        wdr_boot_upload_abort(&fw->img_up);
        fw->img_crc = 0;
        st = wdr_status_from_err(wdr_boot_upload_begin(&fw->img_flash, &fw->img_layout, &fw->img_up, target_slot(fw),
                                                       wdr_get_u32(pkt->payload), wdr_get_u32(pkt->payload + 4)));
    }
    reply_status(fw, pkt, st);
}

/* A chunk or commit of an image while a table upload is open, or of nothing. */
static int open_gate(const wdr_fw *fw)
{
    if (!fw->img_ok)
        return WDR_ST_UNSUPPORTED;
    if (!wdr_fw_update_open(fw) && fw->store.up_kind)
        return WDR_ST_BAD_KIND;
    return WDR_ST_OK;
}

void wdr_fw_cmd_fw_chunk(wdr_fw *fw, const wdr_packet *pkt)
{
    int st = pkt->h.length > WDR_CHUNK_OFFSET_SIZE ? open_gate(fw) : WDR_ST_BAD_LENGTH;
    const uint8_t *data = pkt->payload + WDR_CHUNK_OFFSET_SIZE;
    uint32_t n = pkt->h.length - WDR_CHUNK_OFFSET_SIZE;
    if (!st) {
        int err = wdr_boot_upload_chunk(&fw->img_flash, &fw->img_layout, &fw->img_up, wdr_get_u32(pkt->payload),
                                        data, n);
        if (!err)
            fw->img_crc = wdr_crc32(fw->img_crc, data, n);
        st = wdr_status_from_err(err);
    }
    reply_status(fw, pkt, st);
}

/* Length, CRC, verification, PENDING (the library's order). A CRC that differs from the
 * chunks' is the link's fault (BAD_CRC); a CRC failure after the chunks matched is the image's. */
static int commit_image(wdr_fw *fw, wdr_image_header *hdr)
{
    wdr_boot_policy pol;
    policy_of(fw, &pol);
    bool crc_matched = fw->img_crc == fw->img_up.crc;
    int err = wdr_boot_upload_finish(&fw->img_flash, &fw->img_layout, &fw->img_up, &pol, hdr);
    wdr_boot_upload_abort(&fw->img_up);
    if (err == WDR_E_CORRUPT && !crc_matched)
        return WDR_ST_BAD_CRC;
    if (err == WDR_E_SEQUENCE || err == WDR_E_TRUNCATED || err == WDR_E_IO || err == WDR_E_POWER)
        return wdr_status_from_err(err);
    return image_status(err);
}

void wdr_fw_cmd_fw_commit(wdr_fw *fw, const wdr_packet *pkt)
{
    uint8_t out[WDR_FW_COMMIT_REPLY_SIZE];
    wdr_image_header hdr;
    int st = pkt->h.length == 0 ? open_gate(fw) : WDR_ST_BAD_LENGTH;
    if (!st && wdr_fw_busy(fw))
        st = WDR_ST_BUSY; /* hashing the whole image would stall the frames */
    if (!st && !wdr_fw_update_open(fw))
        st = WDR_ST_BAD_SEQUENCE;
    int slot = fw->img_up.slot;
    if (!st)
        st = commit_image(fw, &hdr);
    if (st) {
        reply_status(fw, pkt, st);
        return;
    }
    memset(out, 0, sizeof out);
    out[0] = (uint8_t)slot;
    wdr_image_header_pack(&hdr, out + 4);
    wdr_fw_reply(fw, &pkt->h, WDR_ST_OK, out, sizeof out);
}

/* ---- Status -------------------------------------------------------------------------------------- */

static void slot_report(const wdr_boot_slot *s, wdr_fw_slot_report *r)
{
    memset(r, 0, sizeof *r);
    r->state = s->state;
    r->attempts = s->attempts;
    r->reject_reason = s->reject_reason;
    r->verify_err = (int8_t)s->verify_err;
    if (s->has_header) {
        r->ver_major = s->hdr.version.major;
        r->ver_minor = s->hdr.version.minor;
        r->ver_patch = s->hdr.version.patch;
        r->ver_build = s->hdr.version.build;
        r->security_counter = s->hdr.security_counter;
        r->image_size = s->hdr.image_size;
        memcpy(r->sha256, s->sha256, sizeof r->sha256);
    }
}

/* What this boot was told, then what the image flash holds now. */
static int fw_status_fill(const wdr_fw *fw, wdr_fw_status_report *r)
{
    uint8_t key_sha[WDR_SHA256_SIZE];
    memset(r, 0, sizeof *r);
    r->running = fw->booted ? fw->boot_rec.slot : WDR_SLOT_NONE;
    r->reset_cause = fw->booted ? fw->boot_rec.reset_cause : (uint8_t)WDR_RESET_UNKNOWN;
    r->flags = (uint8_t)((wdr_boot_key_is_dev() ? WDR_FW_STATUS_F_DEV_KEY : 0u) |
                         (testing(fw) ? WDR_FW_STATUS_F_TESTING : 0u) | (fw->booted ? 0u : WDR_FW_STATUS_F_NO_BOOT));
    r->max_attempts = WDR_BOOT_MAX_ATTEMPTS;
    if (fw->booted) {
        r->fault_pc = fw->boot_rec.fault_pc;
        r->fault_status = fw->boot_rec.fault_status;
        r->boots = fw->boot_rec.boots;
    }
    wdr_sha256_of(wdr_boot_key(), WDR_P256_PUBKEY_SIZE, key_sha);
    memcpy(r->key_hash, key_sha, sizeof r->key_hash);
    wdr_boot_policy pol;
    policy_of(fw, &pol);
    int err = wdr_boot_floor_read(&fw->img_flash, &fw->img_layout, &r->floor);
    for (int i = 0; i < 2 && !err; i++) {
        wdr_boot_slot s;
        err = wdr_boot_slot_read(&fw->img_flash, &fw->img_layout, i, &pol, r->floor, &s);
        if (!err)
            slot_report(&s, &r->slot[i]);
    }
    return err;
}

void wdr_fw_cmd_fw_status(wdr_fw *fw, const wdr_packet *pkt)
{
    wdr_fw_status_report r;
    uint8_t out[WDR_FW_STATUS_SIZE];
    int st = pkt->h.length == 0 ? WDR_ST_OK : WDR_ST_BAD_LENGTH;
    if (!st && !fw->img_ok)
        st = WDR_ST_UNSUPPORTED;
    if (!st)
        st = wdr_status_from_err(fw_status_fill(fw, &r));
    if (st) {
        reply_status(fw, pkt, st);
        return;
    }
    wdr_fw_status_pack(&r, out);
    wdr_fw_reply(fw, &pkt->h, WDR_ST_OK, out, sizeof out);
}

/* ---- Confirm, revert, reboot ---------------------------------------------------------------------- */

/* Why the running slot's state may not change now; OK if it may. */
static int running_gate(const wdr_fw *fw, const wdr_packet *pkt)
{
    if (pkt->h.length != 0)
        return WDR_ST_BAD_LENGTH;
    if (!fw->img_ok)
        return WDR_ST_UNSUPPORTED;
    if (!fw->booted)
        return WDR_ST_BAD_STATE; /* not started from a slot: nothing to confirm or leave */
    return WDR_ST_OK;
}

void wdr_fw_cmd_fw_confirm(wdr_fw *fw, const wdr_packet *pkt)
{
    wdr_boot_policy pol;
    policy_of(fw, &pol);
    int st = running_gate(fw, pkt);
    if (!st)
        st = wdr_status_from_err(wdr_boot_confirm(&fw->img_flash, &fw->img_layout, &pol, fw->boot_rec.slot));
    if (!st)
        fw->boot_rec.testing = 0; /* uploads are allowed again */
    reply_status(fw, pkt, st);
}

void wdr_fw_cmd_fw_revert(wdr_fw *fw, const wdr_packet *pkt)
{
    wdr_boot_policy pol;
    policy_of(fw, &pol);
    int st = running_gate(fw, pkt);
    if (!st)
        st = wdr_status_from_err(wdr_boot_revert(&fw->img_flash, &fw->img_layout, &pol, fw->boot_rec.slot));
    if (!st)
        fw->reverted = true; /* an upload now would erase the slot the next boot needs */
    reply_status(fw, pkt, st);
}

void wdr_fw_cmd_reboot(wdr_fw *fw, const wdr_packet *pkt)
{
    int st = pkt->h.length == 0 ? WDR_ST_OK : WDR_ST_BAD_LENGTH;
    if (!st) {
        wdr_fw_frame_stop(fw);
        fw->reboot_due = true;
    }
    reply_status(fw, pkt, st);
}

/* The reset REBOOT asked for, once its answer has left the board (nothing queued or in flight).
 * @return 1 if it reset (a simulated board returns and reboots when the task returns) */
int wdr_fw_reboot_service(wdr_fw *fw)
{
    if (!fw->reboot_due || fw->tx_count || fw->tx_in_flight)
        return 0;
    fw->reboot_due = false;
    hal_reset(WDR_RESET_SOFTWARE);
    return 1;
}
