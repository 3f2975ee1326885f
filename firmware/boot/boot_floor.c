/* The security-counter floor: FLOOR records in two blocks, the floor their largest value.
 * Raising appends to the block that holds the largest; when it is full, the new value goes
 * first into the other block (erased just before) and only then is the full one erased, so a
 * cut at any point leaves a block holding a value at least the old floor. */
#include "boot_internal.h"
#include "wdr_err.h"

typedef struct floor_block {
    bool any;
    uint32_t max;   /* largest FLOOR value in it */
    uint32_t next;  /* offset of its first unused unit */
} floor_block;

static void fold_floor(void *ctx, uint8_t type, uint32_t value)
{
    floor_block *b = ctx;
    if (type != WDR_REC_FLOOR)
        return;
    if (!b->any || value > b->max)
        b->max = value;
    b->any = true;
}

static int read_blocks(const wdr_boot_flash *f, const wdr_boot_layout *l, floor_block b[WDR_BOOT_FLOOR_BLOCKS])
{
    for (uint32_t i = 0; i < WDR_BOOT_FLOOR_BLOCKS; i++) {
        b[i] = (floor_block){0};
        int rc = boot_log_walk(f, l->floor_addr[i], l->block_size, fold_floor, &b[i], &b[i].next);
        if (rc != WDR_OK)
            return rc;
    }
    return WDR_OK;
}

/* The block holding the floor (block 0 when neither holds any). */
static uint32_t floor_holder(const floor_block b[WDR_BOOT_FLOOR_BLOCKS])
{
    return b[1].any && (!b[0].any || b[1].max > b[0].max) ? 1u : 0u;
}

int wdr_boot_floor_read(const wdr_boot_flash *f, const wdr_boot_layout *l, uint32_t *floor)
{
    floor_block b[WDR_BOOT_FLOOR_BLOCKS];
    *floor = 0;
    int rc = read_blocks(f, l, b);
    if (rc == WDR_OK)
        *floor = b[floor_holder(b)].max;
    return rc;
}

static uint32_t block_of(const wdr_boot_layout *l, uint32_t addr) { return addr / l->block_size; }

int wdr_boot_floor_raise(const wdr_boot_flash *f, const wdr_boot_layout *l, uint32_t value)
{
    floor_block b[WDR_BOOT_FLOOR_BLOCKS];
    int rc = read_blocks(f, l, b);
    if (rc != WDR_OK)
        return rc;
    uint32_t k = floor_holder(b), j = 1u - k;
    if (b[k].any && b[k].max >= value)
        return WDR_OK;
    if (b[k].next + WDR_BOOT_RECORD_SIZE <= l->block_size)
        return boot_log_put(f, l->floor_addr[k], l->block_size, b[k].next, WDR_REC_FLOOR, value);
    /* Compaction: the new floor into the other block, then the full block erased. */
    rc = f->erase(f->ctx, block_of(l, l->floor_addr[j]));
    if (rc == WDR_OK)
        rc = boot_log_put(f, l->floor_addr[j], l->block_size, 0, WDR_REC_FLOOR, value);
    if (rc == WDR_OK)
        rc = f->erase(f->ctx, block_of(l, l->floor_addr[k]));
    return rc;
}
