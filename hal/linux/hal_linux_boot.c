/* Real board on embedded Linux: no bootloader and no image flash. The firmware is a program the
 * system's package manager updates, so FW_* answer UNSUPPORTED; a reset ends the process and
 * the service manager (systemd's Restart=always) starts it again, which is the reboot. */
#include "hal.h"
#include "wdr_boot.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int hal_image_flash_geometry_get(hal_flash_geometry *g)
{
    memset(g, 0, sizeof *g);
    return WDR_E_UNSUPPORTED;
}

int hal_image_flash_read(uint32_t addr, void *buf, uint32_t len)
{
    (void)addr, (void)buf, (void)len;
    return WDR_E_UNSUPPORTED;
}

int hal_image_flash_erase(uint32_t block)
{
    (void)block;
    return WDR_E_UNSUPPORTED;
}

int hal_image_flash_prog(uint32_t addr, const void *buf, uint32_t len)
{
    (void)addr, (void)buf, (void)len;
    return WDR_E_UNSUPPORTED;
}

int hal_boot_record_get(struct wdr_boot_record *out)
{
    (void)out;
    return WDR_E_UNSUPPORTED;
}

/* The answer to REBOOT has left through FunctionFS by now; exit so the service restarts us. */
void hal_reset(uint8_t cause)
{
    fprintf(stderr, "wdr-board: reset (%s): exiting; the service manager starts the firmware again\n",
            wdr_reset_cause_name(cause));
    exit(EXIT_SUCCESS);
}

void hal_watchdog_feed(void) {} /* the kernel's watchdog daemon watches the system, not us */
