/* The simulated board's main loop: the firmware's task function and the HAL's wait, in turn,
 * exactly as a bare-metal main would run them (firmware/wdr_fw.h). */
#include "hal_sim_internal.h"
#include "wdr_fw.h"

static wdr_fw fw; /* the firmware owns its buffers; static as on the controller */

int hal_sim_serve(void)
{
    int rc = wdr_fw_init(&fw);
    /* A sensor too wide to capture still answers INFO and STATUS: keep serving then. */
    if (rc != WDR_OK && rc != WDR_E_UNSUPPORTED)
        return rc;
    while (!hal_sim_stop_requested())
        if (!wdr_fw_task(&fw))
            hal_wait_for_event();
    return WDR_OK;
}
