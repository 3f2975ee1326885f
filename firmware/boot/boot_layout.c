/* Where the floor log and the two slots lie in the image flash, from its geometry (SPEC.md,
 * "Image flash and boot"). */
#include "wdr_boot.h"
#include "wdr_err.h"
#include <string.h>

static bool pow2(uint32_t x) { return x && !(x & (x - 1)); }

int wdr_boot_layout_init(wdr_boot_layout *l, const hal_flash_geometry *g)
{
    memset(l, 0, sizeof *l);
    if (g->block_count < 6 || !pow2(g->block_size) || !pow2(g->prog_size) ||
        g->prog_size > WDR_BOOT_RECORD_SIZE || WDR_BOOT_RECORD_SIZE % g->prog_size ||
        g->block_size < WDR_IMAGE_HEADER_SIZE + WDR_IMAGE_TRAILER_SIZE)
        return WDR_E_UNSUPPORTED;
    uint32_t bs = g->block_size, n = (g->block_count - WDR_BOOT_FLOOR_BLOCKS) / 2;
    if ((uint64_t)bs * g->block_count > 0xFFFFFFFFu)
        return WDR_E_UNSUPPORTED; /* addresses are 32-bit */
    l->block_size = bs;
    l->prog_size = g->prog_size;
    for (uint32_t i = 0; i < WDR_BOOT_FLOOR_BLOCKS; i++)
        l->floor_addr[i] = i * bs;
    for (uint32_t s = 0; s < 2; s++) {
        uint32_t first = WDR_BOOT_FLOOR_BLOCKS + s * n;
        l->slot_addr[s] = first * bs;
        l->state_addr[s] = (first + n - 1) * bs;
    }
    l->image_capacity = (n - 1) * bs;
    return WDR_OK;
}
