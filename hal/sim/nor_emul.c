/* NOR-flash emulator (see nor_emul.h). */
#include "nor_emul.h"
#include <string.h>

static int is_pow2(uint32_t x) { return x && !(x & (x - 1)); }

int nor_emul_init(nor_emul *f, const hal_flash_geometry *g, uint8_t *bytes, uint8_t *programmed)
{
    if (!is_pow2(g->block_size) || !is_pow2(g->prog_size) || g->prog_size > g->block_size || !g->block_count)
        return WDR_E_INVAL;
    memset(f, 0, sizeof *f);
    f->g = *g;
    f->bytes = bytes;
    f->programmed = programmed;
    f->size = (size_t)g->block_size * g->block_count;
    memset(bytes, 0xFF, f->size);
    memset(programmed, 0, f->size / g->prog_size);
    return WDR_OK;
}

void nor_emul_derive_programmed(nor_emul *f)
{
    for (size_t u = 0; u < f->size / f->g.prog_size; u++) {
        const uint8_t *p = f->bytes + u * f->g.prog_size;
        f->programmed[u] = 0;
        for (uint32_t i = 0; i < f->g.prog_size && !f->programmed[u]; i++)
            f->programmed[u] = p[i] != 0xFF;
    }
}

static void changed(nor_emul *f, uint32_t addr, uint32_t len)
{
    if (f->changed && len)
        f->changed(f->changed_ctx, addr, len);
}

/* Count an operation; the fault armed for it, or WDR_OK. */
static int count_op(nor_emul *f)
{
    f->ops++;
    if (f->cut_at && f->ops == f->cut_at) {
        f->cut_at = 0;
        f->power_lost = 1;
        return WDR_E_POWER;
    }
    if (f->fail_at && f->ops == f->fail_at) {
        f->fail_at = 0;
        return WDR_E_IO;
    }
    return WDR_OK;
}

int nor_emul_read(const nor_emul *f, uint32_t addr, void *buf, uint32_t len)
{
    if (f->power_lost)
        return WDR_E_POWER;
    if (!buf || (uint64_t)addr + len > f->size)
        return WDR_E_INVAL;
    memcpy(buf, f->bytes + addr, len);
    return WDR_OK;
}

/* Erase [addr, addr + len): bytes to 0xFF, their units free to program again. */
static void erase_range(nor_emul *f, uint32_t addr, uint32_t len)
{
    memset(f->bytes + addr, 0xFF, len);
    memset(f->programmed + addr / f->g.prog_size, 0, len / f->g.prog_size);
    changed(f, addr, len);
}

static void torn_erase(nor_emul *f, uint32_t addr)
{
    uint32_t half = f->g.block_size / 2;
    switch (f->tear) {
    case NOR_TEAR_FIRST_HALF: erase_range(f, addr, half); break;
    case NOR_TEAR_SECOND_HALF: erase_range(f, addr + half, half); break;
    case NOR_TEAR_BITS: /* some bits back to 1; no unit counts as erased */
        for (uint32_t i = 0; i < f->g.block_size; i++)
            f->bytes[addr + i] |= 0xAA;
        changed(f, addr, f->g.block_size);
        break;
    default: break;
    }
}

int nor_emul_erase(nor_emul *f, uint32_t block)
{
    if (f->power_lost)
        return WDR_E_POWER;
    if (block >= f->g.block_count)
        return WDR_E_INVAL;
    uint32_t addr = block * f->g.block_size;
    int fault = count_op(f);
    if (fault == WDR_E_POWER)
        torn_erase(f, addr);
    else if (fault == WDR_OK)
        erase_range(f, addr, f->g.block_size);
    return fault;
}

static int check_prog(const nor_emul *f, uint32_t addr, const void *buf, uint32_t len)
{
    if (!buf || addr % f->g.prog_size || len % f->g.prog_size || (uint64_t)addr + len > f->size)
        return WDR_E_INVAL;
    for (uint32_t u = addr / f->g.prog_size; u < (addr + len) / f->g.prog_size; u++)
        if (f->programmed[u])
            return WDR_E_IO; /* programming over programmed bits: refused, never ANDed in */
    for (uint32_t i = 0; i < len; i++)
        if (f->bytes[addr + i] != 0xFF)
            return WDR_E_IO;
    return WDR_OK;
}

/* Program [from, to) of the operation at addr; its units count as programmed. */
static void program_range(nor_emul *f, uint32_t addr, const uint8_t *src, uint32_t from, uint32_t to)
{
    memcpy(f->bytes + addr + from, src + from, to - from);
    changed(f, addr + from, to - from);
}

static void torn_prog(nor_emul *f, uint32_t addr, const uint8_t *src, uint32_t len)
{
    switch (f->tear) {
    case NOR_TEAR_FIRST_HALF: program_range(f, addr, src, 0, len / 2); break;
    case NOR_TEAR_SECOND_HALF: program_range(f, addr, src, len / 2, len); break;
    case NOR_TEAR_BITS: /* only bits 0, 2, 4, 6 of each byte reached their new value */
        for (uint32_t i = 0; i < len; i++)
            f->bytes[addr + i] &= (uint8_t)(src[i] | 0xAA);
        changed(f, addr, len);
        break;
    default: return; /* not started: nothing programmed */
    }
}

int nor_emul_prog(nor_emul *f, uint32_t addr, const void *buf, uint32_t len)
{
    if (f->power_lost)
        return WDR_E_POWER;
    int rc = check_prog(f, addr, buf, len);
    if (rc != WDR_OK)
        return rc;
    int fault = count_op(f);
    if (fault == WDR_E_IO)
        return fault;
    if (fault == WDR_E_POWER)
        torn_prog(f, addr, buf, len);
    else
        program_range(f, addr, buf, 0, len);
    /* Every unit the operation touched counts as programmed, even where a tear left 0xFF:
     * on a chip its cells may hold a partial charge, so it must be erased first. */
    if (fault == WDR_OK || f->tear != NOR_TEAR_NONE)
        memset(f->programmed + addr / f->g.prog_size, 1, len / f->g.prog_size);
    return fault;
}

void nor_emul_cut_power_at(nor_emul *f, uint64_t op, int tear)
{
    f->cut_at = op;
    f->tear = tear;
}

void nor_emul_fail_at(nor_emul *f, uint64_t op) { f->fail_at = op; }

void nor_emul_reboot(nor_emul *f) { f->power_lost = 0; }

void nor_emul_erase_all(nor_emul *f) { erase_range(f, 0, (uint32_t)f->size); }
