/* The simulated board's main loop, owned by the programs that run it (wdr-simboard, and the
 * tests and benchmarks that serve a board from a thread): the firmware's task function and the
 * HAL's wait, in turn, exactly as a bare-metal main runs them (firmware/wdr_fw.h). It lives
 * beside the backend but is not part of it: the backend never calls the firmware.
 * A hal_reset from the firmware (REBOOT) is a reset: hal_init runs the boot again, then the
 * firmware starts over on what the flash holds. */
#include "hal_sim_emul.h"
#include "simboard_loop.h"
#include "wdr_fw.h"

static wdr_fw fw; /* the firmware owns its buffers; static as on the controller */

/* A sensor too wide to capture still answers INFO and STATUS: keep serving then. */
static int start_firmware(void)
{
    int rc = wdr_fw_init(&fw);
    return rc == WDR_E_UNSUPPORTED ? WDR_OK : rc;
}

int simboard_serve(void)
{
    int rc = start_firmware();
    while (rc == WDR_OK && !hal_sim_stop_requested()) {
        if (hal_sim_take_reset()) {
            rc = hal_init();
            if (rc == WDR_OK)
                rc = start_firmware();
        } else if (!wdr_fw_task(&fw))
            hal_wait_for_event();
    }
    return rc;
}
