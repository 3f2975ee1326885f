/* The simulated board's main loop (simboard_loop.c), for programs that run the firmware on the
 * simulated HAL. */
#ifndef SIMBOARD_LOOP_H
#define SIMBOARD_LOOP_H

/* Boot the firmware on the simulated HAL (hal_sim_setup and hal_init done) and serve until
 * hal_sim_request_stop. @retval WDR_OK, or wdr_fw_init's error */
int simboard_serve(void);

#endif
