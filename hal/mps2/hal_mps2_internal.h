/* What hal_mps2.c and hal_mps2_boot.c share beyond hal/hal.h. */
#ifndef HAL_MPS2_INTERNAL_H
#define HAL_MPS2_INTERNAL_H

/* Start the CMSDK watchdog (hal_init; hal_watchdog_feed keeps it quiet). */
void hal_mps2_watchdog_start(void);

#endif
