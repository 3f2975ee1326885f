/* A PSRAM region of the mps2-an500 kept to hal.h's strict NOR rules: the table flash and the
 * image flash are two of them (hal_mps2.c, hal_mps2_boot.c). Internal to hal/mps2. */
#ifndef WDR_MPS2_PSRAM_NOR_H
#define WDR_MPS2_PSRAM_NOR_H
#include "hal.h"
#include <stdint.h>

typedef struct psram_nor {
    uint32_t base; /* first byte, in the PSRAM at 0x60000000 */
    hal_flash_geometry geo;
} psram_nor;

/* As hal_flash_read / erase / prog over the region (the same retvals). */
int psram_nor_read(const psram_nor *r, uint32_t addr, void *buf, uint32_t len);
int psram_nor_erase(const psram_nor *r, uint32_t block);
int psram_nor_prog(const psram_nor *r, uint32_t addr, const void *buf, uint32_t len);

#endif
