/* wdr-board: the controller firmware on an embedded-Linux board (hal/linux). The same loop as
 * a bare-metal main: the firmware's task, then sleep until an event. Built here, never run
 * here (no board): see hal/linux/README.md. */
#include "hal.h"
#include "wdr_err.h"
#include "wdr_fw.h"
#include <stdio.h>

static wdr_fw fw; /* every buffer of the firmware: static, as on the controller */

int main(void)
{
    int rc = hal_init();
    if (rc != WDR_OK) {
        fprintf(stderr, "wdr-board: board bring-up failed: %s (GPIO, SPI, FunctionFS or MTD missing?)\n",
                wdr_strerror(rc));
        return 1;
    }
    rc = wdr_fw_init(&fw);
    if (rc != WDR_OK)
        fprintf(stderr, "wdr-board: firmware started with: %s\n", wdr_strerror(rc));
    for (;;)
        if (!wdr_fw_task(&fw))
            hal_wait_for_event();
}
