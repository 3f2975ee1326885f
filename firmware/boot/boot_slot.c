/* One slot's state: the fold of its state log, then its image (SPEC.md, "Slot state"). */
#include "boot_internal.h"
#include "wdr_bytes.h"
#include "wdr_err.h"
#include <string.h>

typedef struct log_fold {
    bool begun, pending, confirmed, rejected;
    uint8_t attempts, reason;
} log_fold;

/* The writer erases the state block before BEGIN, so BEGIN comes first; a BEGIN found later
 * (only on a hostile flash) starts over, except that REJECTED is never forgotten. */
static void fold_record(void *ctx, uint8_t type, uint32_t value)
{
    log_fold *s = ctx;
    switch (type) {
    case WDR_REC_BEGIN:
        s->begun = true;
        s->pending = s->confirmed = false;
        s->attempts = 0;
        break;
    case WDR_REC_PENDING: s->pending = true; break;
    case WDR_REC_ATTEMPT:
        if (s->pending && s->attempts < 255)
            s->attempts++;
        break;
    case WDR_REC_CONFIRMED: s->confirmed = s->confirmed || s->pending; break;
    case WDR_REC_REJECTED:
        if (!s->rejected)
            s->reason = (uint8_t)value;
        s->rejected = true;
        break;
    default: break; /* FLOOR or a type this version does not know: no state change */
    }
}

/* Header and trailer structure only (what fw status shows of a slot that never boots). */
static int read_structure(const wdr_boot_flash *f, const wdr_boot_layout *l, int slot, wdr_boot_slot *out)
{
    uint8_t buf[WDR_IMAGE_TRAILER_SIZE];
    int rc = f->read(f->ctx, l->slot_addr[slot], buf, WDR_IMAGE_HEADER_SIZE);
    if (rc != WDR_OK)
        return rc;
    if (wdr_image_header_parse(buf, l->image_capacity, &out->hdr) != WDR_OK)
        return WDR_OK;
    out->has_header = true;
    rc = f->read(f->ctx, l->slot_addr[slot] + WDR_IMAGE_HEADER_SIZE + out->hdr.image_size, buf,
                 WDR_IMAGE_TRAILER_SIZE);
    wdr_image_trailer trl;
    if (rc == WDR_OK && wdr_image_trailer_parse(buf, &trl) == WDR_OK)
        memcpy(out->sha256, trl.sha256, WDR_SHA256_SIZE);
    return rc;
}

/* An image header's magic at the slot's start: an empty log over anything else is EMPTY. */
static bool has_magic(const wdr_boot_flash *f, const wdr_boot_layout *l, int slot, int *rc)
{
    uint8_t m[4];
    *rc = f->read(f->ctx, l->slot_addr[slot], m, sizeof m);
    return *rc == WDR_OK && wdr_get_u32(m) == WDR_IMAGE_MAGIC;
}

/* Verify an image the log lets boot; its state follows from the result. */
static int verify_bootable(const wdr_boot_flash *f, const wdr_boot_layout *l, int slot, const wdr_boot_policy *pol,
                           uint32_t floor, const log_fold *s, wdr_boot_slot *out)
{
    wdr_image_trailer trl;
    int v = wdr_image_verify(f, l->slot_addr[slot], l->image_capacity, pol, floor, &out->hdr, &trl);
    if (v == WDR_E_IO || v == WDR_E_POWER)
        return v;
    out->verify_err = v;
    out->has_header = out->hdr.header_size != 0;
    memcpy(out->sha256, trl.sha256, WDR_SHA256_SIZE);
    if (v != WDR_OK)
        out->state = WDR_SLOT_INVALID;
    else if (s->confirmed || !s->pending)
        out->state = WDR_SLOT_CONFIRMED; /* confirmed, or a factory image (empty log) */
    else
        out->state = s->attempts ? WDR_SLOT_TESTING : WDR_SLOT_PENDING;
    return WDR_OK;
}

int wdr_boot_slot_read(const wdr_boot_flash *f, const wdr_boot_layout *l, int slot, const wdr_boot_policy *pol,
                       uint32_t floor, wdr_boot_slot *out)
{
    memset(out, 0, sizeof *out);
    if (!boot_slot_ok(slot))
        return WDR_E_INVAL;
    log_fold s = {0};
    int rc = boot_log_walk(f, l->state_addr[slot], l->block_size, fold_record, &s, &out->log_next);
    if (rc != WDR_OK)
        return rc;
    out->attempts = s.attempts;
    out->verify_err = WDR_E_STATE; /* not verified: the log says it never boots */
    if (s.rejected) {
        out->state = WDR_SLOT_REJECTED;
        out->reject_reason = s.reason;
        return read_structure(f, l, slot, out);
    }
    if (s.begun && !s.pending) {
        out->state = WDR_SLOT_INCOMPLETE;
        return read_structure(f, l, slot, out);
    }
    if (!s.pending && !has_magic(f, l, slot, &rc)) {
        out->state = WDR_SLOT_EMPTY;
        return rc;
    }
    return verify_bootable(f, l, slot, pol, floor, &s, out);
}
