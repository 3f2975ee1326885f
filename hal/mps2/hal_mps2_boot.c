/* hal/hal.h's boot chain part on the MPS2 AN500: the image flash (PSRAM at 0x60600000 kept to
 * NOR rules, as the table flash), the boot record the bootloader left in RAM, reset with a
 * cause, and the CMSDK watchdog. The bootloader (firmware/boot/boot_main_arm.c) links this file
 * too, for the image flash: one implementation of its NOR rules. Bare metal, no state. */
#include "hal.h"
#include "psram_nor.h"
#include "mps2_board.h"
#include "wdr_boot.h"
#include <string.h>

#define REG(addr) (*(volatile uint32_t *)(uintptr_t)(addr))
#define WDOG_LOAD REG(MPS2_WDOG_BASE + 0x0u)
#define WDOG_CTRL REG(MPS2_WDOG_BASE + 0x8u)
#define WDOG_INTCLR REG(MPS2_WDOG_BASE + 0xcu)
#define WDOG_LOCK REG(MPS2_WDOG_BASE + 0xc00u)

/* ---- Image flash: PSRAM with NOR rules ------------------------------------------------------- */

static const psram_nor image_flash_region = {MPS2_IMAGE_FLASH_BASE,
                                             {MPS2_IMAGE_FLASH_BLOCK, MPS2_IMAGE_FLASH_BLOCKS, MPS2_IMAGE_FLASH_PROG}};

int hal_image_flash_geometry_get(hal_flash_geometry *g)
{
    *g = image_flash_region.geo;
    return WDR_OK;
}

int hal_image_flash_read(uint32_t addr, void *buf, uint32_t len)
{
    return psram_nor_read(&image_flash_region, addr, buf, len);
}

int hal_image_flash_erase(uint32_t block)
{
    return psram_nor_erase(&image_flash_region, block);
}

int hal_image_flash_prog(uint32_t addr, const void *buf, uint32_t len)
{
    return psram_nor_prog(&image_flash_region, addr, buf, len);
}

/* ---- Boot record, reset ---------------------------------------------------------------------- */

int hal_boot_record_get(struct wdr_boot_record *out)
{
    memcpy(out, (const void *)(uintptr_t)MPS2_BOOT_RECORD_ADDR, sizeof *out);
    return wdr_boot_record_ok(out) ? WDR_OK : WDR_E_UNSUPPORTED;
}

/* The note first (the bootloader reads it after the reset), then SYSRESETREQ, which resets the
 * whole board (QEMU: a system reset; RAM is kept). */
void hal_reset(uint8_t cause)
{
    mps2_reset_note_write(cause, 0, 0);
    __asm volatile("dsb" ::: "memory");
    REG(MPS2_SCB_AIRCR) = MPS2_AIRCR_SYSRESETREQ;
    __asm volatile("dsb" ::: "memory");
    for (;;) {
    }
}

/* ---- Watchdog ----------------------------------------------------------------------------------- */

/* Started by hal_init: a hang or a fault stops the feeding; the first expiry raises the NMI
 * (firmware/main_arm.c notes the cause), the second resets the board. Locked between feeds, so
 * a runaway store cannot stop it. */
void hal_mps2_watchdog_start(void)
{
    WDOG_LOCK = MPS2_WDOG_UNLOCK;
    WDOG_LOAD = MPS2_WDOG_TICKS;
    WDOG_CTRL = MPS2_WDOG_CTRL_INTEN | MPS2_WDOG_CTRL_RESEN;
    WDOG_LOCK = 0;
}

/* INTCLR clears a pending early warning and reloads the count from LOAD. */
void hal_watchdog_feed(void)
{
    WDOG_LOCK = MPS2_WDOG_UNLOCK;
    WDOG_INTCLR = 1u;
    WDOG_LOCK = 0;
}
