/* Uploads into a slot (the firmware's FW_BEGIN, FW_CHUNK, FW_COMMIT; SPEC.md, "Upload"). The
 * order of the writes is the safety: the old header goes first, so the slot can never look
 * like a factory image again; then the old log, then BEGIN; PENDING only after the whole image
 * verified on flash. Bytes are programmed as they arrive; a unit's worth that is not complete
 * yet waits in u->tail. */
#include "boot_internal.h"
#include "crc32.h"
#include "wdr_err.h"
#include <string.h>

static uint32_t block_of(const wdr_boot_layout *l, uint32_t addr) { return addr / l->block_size; }

int wdr_boot_upload_begin(const wdr_boot_flash *f, const wdr_boot_layout *l, wdr_boot_upload *u, int slot,
                          uint32_t len, uint32_t crc)
{
    wdr_boot_upload_abort(u);
    if (!boot_slot_ok(slot) || len == 0)
        return WDR_E_INVAL;
    if (len > l->image_capacity)
        return WDR_E_TOO_LARGE;
    int rc = f->erase(f->ctx, block_of(l, l->slot_addr[slot]));
    if (rc == WDR_OK)
        rc = f->erase(f->ctx, block_of(l, l->state_addr[slot]));
    if (rc == WDR_OK)
        rc = boot_log_put(f, l->state_addr[slot], l->block_size, 0, WDR_REC_BEGIN, len);
    if (rc != WDR_OK)
        return rc;
    *u = (wdr_boot_upload){.slot = slot, .len = len, .crc = crc, .erased_to = l->block_size};
    return WDR_OK;
}

/* Program n bytes (a multiple of WDR_BOOT_RECORD_SIZE) at u->programmed, erasing each block of
 * the slot just before its first byte. */
static int program(const wdr_boot_flash *f, const wdr_boot_layout *l, wdr_boot_upload *u, const uint8_t *p,
                   uint32_t n)
{
    while (u->programmed + n > u->erased_to) {
        int rc = f->erase(f->ctx, block_of(l, l->slot_addr[u->slot] + u->erased_to));
        if (rc != WDR_OK)
            return rc;
        u->erased_to += l->block_size;
    }
    int rc = f->prog(f->ctx, l->slot_addr[u->slot] + u->programmed, p, n);
    if (rc == WDR_OK)
        u->programmed += n;
    return rc;
}

/* Top up the tail from p; program it once it holds a whole unit. *used: bytes taken. */
static int fill_tail(const wdr_boot_flash *f, const wdr_boot_layout *l, wdr_boot_upload *u, const uint8_t *p,
                     uint32_t n, uint32_t *used)
{
    uint32_t take = WDR_BOOT_RECORD_SIZE - u->tail_fill;
    *used = take < n ? take : n;
    memcpy(u->tail + u->tail_fill, p, *used);
    u->tail_fill += *used;
    if (u->tail_fill < WDR_BOOT_RECORD_SIZE)
        return WDR_OK;
    u->tail_fill = 0;
    return program(f, l, u, u->tail, WDR_BOOT_RECORD_SIZE);
}

int wdr_boot_upload_chunk(const wdr_boot_flash *f, const wdr_boot_layout *l, wdr_boot_upload *u, uint32_t offset,
                          const uint8_t *data, uint32_t n)
{
    if (u->slot < 0 || offset != u->received)
        return WDR_E_SEQUENCE;
    if (n > u->len - u->received)
        return WDR_E_TOO_LARGE;
    uint32_t used = 0;
    int rc = WDR_OK;
    if (u->tail_fill && n)
        rc = fill_tail(f, l, u, data, n, &used);
    uint32_t whole = (n - used) / WDR_BOOT_RECORD_SIZE * WDR_BOOT_RECORD_SIZE;
    if (rc == WDR_OK && whole)
        rc = program(f, l, u, data + used, whole);
    if (rc == WDR_OK && n - used - whole) {
        uint32_t rest;
        rc = fill_tail(f, l, u, data + used + whole, n - used - whole, &rest);
    }
    if (rc != WDR_OK) {
        wdr_boot_upload_abort(u); /* the slot's bytes are unknown now: begin again */
        return rc;
    }
    u->received += n;
    return WDR_OK;
}

/* The last partial unit, padded with erased bytes. */
static int flush_tail(const wdr_boot_flash *f, const wdr_boot_layout *l, wdr_boot_upload *u)
{
    if (!u->tail_fill)
        return WDR_OK;
    memset(u->tail + u->tail_fill, 0xFF, WDR_BOOT_RECORD_SIZE - u->tail_fill);
    u->tail_fill = 0;
    return program(f, l, u, u->tail, WDR_BOOT_RECORD_SIZE);
}

/* CRC-32 of what the flash now holds, not of what arrived: a bad write shows up here. */
static int crc_of_flash(const wdr_boot_flash *f, uint32_t addr, uint32_t len, uint32_t *crc)
{
    uint8_t buf[BOOT_READ_CHUNK];
    *crc = 0;
    for (uint32_t off = 0; off < len; off += BOOT_READ_CHUNK) {
        uint32_t n = len - off < BOOT_READ_CHUNK ? len - off : BOOT_READ_CHUNK;
        int rc = f->read(f->ctx, addr + off, buf, n);
        if (rc != WDR_OK)
            return rc;
        *crc = wdr_crc32(*crc, buf, n);
    }
    return WDR_OK;
}

/* Whole, as declared, and exactly one image long (a truncated image file is the image's fault:
 * its header promises more than was sent). */
static int check_upload(const wdr_boot_flash *f, const wdr_boot_layout *l, const wdr_boot_upload *u)
{
    if (u->received != u->len)
        return WDR_E_TRUNCATED;
    uint32_t crc;
    int rc = crc_of_flash(f, l->slot_addr[u->slot], u->len, &crc);
    if (rc != WDR_OK)
        return rc;
    if (crc != u->crc)
        return WDR_E_CORRUPT;
    uint8_t buf[WDR_IMAGE_HEADER_SIZE];
    wdr_image_header h;
    if (u->len < sizeof buf)
        return WDR_E_INVAL;
    rc = f->read(f->ctx, l->slot_addr[u->slot], buf, sizeof buf);
    if (rc == WDR_OK)
        rc = wdr_image_header_parse(buf, l->image_capacity, &h);
    if (rc == WDR_OK && wdr_image_total_size(&h) != u->len)
        rc = WDR_E_INVAL;
    return rc;
}

int wdr_boot_upload_finish(const wdr_boot_flash *f, const wdr_boot_layout *l, wdr_boot_upload *u,
                           const wdr_boot_policy *pol, wdr_image_header *hdr)
{
    wdr_image_header h;
    wdr_image_trailer trl;
    if (!hdr)
        hdr = &h;
    memset(hdr, 0, sizeof *hdr);
    if (u->slot < 0)
        return WDR_E_SEQUENCE;
    int slot = u->slot, rc = u->received == u->len ? flush_tail(f, l, u) : WDR_OK;
    uint32_t floor = 0;
    if (rc == WDR_OK)
        rc = check_upload(f, l, u);
    if (rc == WDR_OK)
        rc = wdr_boot_floor_read(f, l, &floor);
    if (rc == WDR_OK)
        rc = wdr_image_verify(f, l->slot_addr[slot], l->image_capacity, pol, floor, hdr, &trl);
    if (rc == WDR_OK)
        rc = wdr_boot_log_append(f, l, slot, WDR_REC_PENDING, hdr->security_counter);
    wdr_boot_upload_abort(u);
    return rc;
}

void wdr_boot_upload_abort(wdr_boot_upload *u)
{
    memset(u, 0, sizeof *u);
    u->slot = -1;
}
