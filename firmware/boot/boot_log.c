/* State and floor records: the 16-byte codec, the walk over a log block that skips torn units,
 * and the append (SPEC.md, "Records"). One program of one unit per change of state. */
#include "boot_internal.h"
#include "crc32.h"
#include "wdr_bytes.h"
#include "wdr_err.h"
#include <string.h>

void boot_record_encode(uint8_t type, uint32_t value, uint8_t out[WDR_BOOT_RECORD_SIZE])
{
    memset(out, 0, WDR_BOOT_RECORD_SIZE);
    wdr_put_u32(out, WDR_BOOT_RECORD_MAGIC);
    out[4] = type;
    wdr_put_u32(out + 8, value);
    wdr_put_u32(out + 12, wdr_crc32(0, out, 12));
}

int boot_record_decode(const uint8_t in[WDR_BOOT_RECORD_SIZE], uint8_t *type, uint32_t *value)
{
    bool erased = true;
    for (uint32_t i = 0; i < WDR_BOOT_RECORD_SIZE; i++)
        erased = erased && in[i] == 0xFF;
    if (erased)
        return BOOT_UNIT_ERASED;
    if (wdr_get_u32(in) != WDR_BOOT_RECORD_MAGIC || in[5] || wdr_get_u16(in + 6) ||
        wdr_get_u32(in + 12) != wdr_crc32(0, in, 12))
        return BOOT_UNIT_TORN;
    *type = in[4];
    *value = wdr_get_u32(in + 8);
    return BOOT_UNIT_RECORD;
}

int boot_log_walk(const wdr_boot_flash *f, uint32_t addr, uint32_t size, boot_record_visit visit, void *ctx,
                  uint32_t *next)
{
    uint8_t buf[BOOT_READ_CHUNK];
    for (uint32_t off = 0; off < size; off += BOOT_READ_CHUNK) {
        uint32_t n = size - off < BOOT_READ_CHUNK ? size - off : BOOT_READ_CHUNK;
        int rc = f->read(f->ctx, addr + off, buf, n);
        if (rc != WDR_OK)
            return rc;
        for (uint32_t u = 0; u + WDR_BOOT_RECORD_SIZE <= n; u += WDR_BOOT_RECORD_SIZE) {
            uint8_t type = 0;
            uint32_t value = 0;
            int what = boot_record_decode(buf + u, &type, &value);
            if (what == BOOT_UNIT_ERASED) {
                *next = off + u;
                return WDR_OK;
            }
            if (what == BOOT_UNIT_RECORD && visit)
                visit(ctx, type, value);
        }
    }
    *next = size;
    return WDR_OK;
}

int boot_log_put(const wdr_boot_flash *f, uint32_t addr, uint32_t size, uint32_t at, uint8_t type, uint32_t value)
{
    if (at + WDR_BOOT_RECORD_SIZE > size)
        return WDR_E_TOO_LARGE;
    uint8_t rec[WDR_BOOT_RECORD_SIZE];
    boot_record_encode(type, value, rec);
    return f->prog(f->ctx, addr + at, rec, WDR_BOOT_RECORD_SIZE);
}

int wdr_boot_log_append(const wdr_boot_flash *f, const wdr_boot_layout *l, int slot, uint8_t type, uint32_t value)
{
    if (!boot_slot_ok(slot))
        return WDR_E_INVAL;
    uint32_t next;
    int rc = boot_log_walk(f, l->state_addr[slot], l->block_size, NULL, NULL, &next);
    if (rc != WDR_OK)
        return rc;
    return boot_log_put(f, l->state_addr[slot], l->block_size, next, type, value);
}
