/* NOR rules over a PSRAM region: erase sets a block to 0xFF; a program needs alignment and
 * erased units, and only clears bits (what a real NOR part would do). */
#include "psram_nor.h"
#include <string.h>

static uint32_t region_bytes(const psram_nor *r)
{
    return r->geo.block_size * r->geo.block_count;
}

static uint8_t *at(const psram_nor *r, uint32_t addr)
{
    return (uint8_t *)(uintptr_t)(r->base + addr);
}

int psram_nor_read(const psram_nor *r, uint32_t addr, void *buf, uint32_t len)
{
    if (addr > region_bytes(r) || len > region_bytes(r) - addr)
        return WDR_E_INVAL;
    memcpy(buf, at(r, addr), len);
    return WDR_OK;
}

int psram_nor_erase(const psram_nor *r, uint32_t block)
{
    if (block >= r->geo.block_count)
        return WDR_E_INVAL;
    memset(at(r, block * r->geo.block_size), 0xff, r->geo.block_size);
    return WDR_OK;
}

int psram_nor_prog(const psram_nor *r, uint32_t addr, const void *buf, uint32_t len)
{
    if ((addr | len) % r->geo.prog_size || addr > region_bytes(r) || len > region_bytes(r) - addr)
        return WDR_E_INVAL;
    uint8_t *p = at(r, addr);
    for (uint32_t i = 0; i < len; i++)
        if (p[i] != 0xffu)
            return WDR_E_IO;
    const uint8_t *s = buf;
    for (uint32_t i = 0; i < len; i++)
        p[i] &= s[i];
    return WDR_OK;
}
