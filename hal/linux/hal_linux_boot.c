/* Real board on embedded Linux: no bootloader and no image flash. The firmware is a program the
 * system's package manager updates, so FW_* answer UNSUPPORTED; a reset ends the process and
 * the service manager (wdr-board.service, RestartForceExitStatus=75) starts it again: the reboot. */
#include "hal_linux_internal.h"
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

/* The answer to REBOOT has left through FunctionFS by now: stop as on SIGTERM (the gadget
 * unbinds), then exit with the status wdr-board.service restarts (RestartForceExitStatus=75). */
void hal_reset(uint8_t cause)
{
    fprintf(stderr, "wdr-board: reset (%s): exiting with 75; the service manager starts the firmware again\n",
            wdr_reset_cause_name(cause));
    lx_shutdown();
    exit(LX_EXIT_RESET);
}

void hal_watchdog_feed(void) {} /* the kernel's watchdog daemon watches the system, not us */
