/* Shared state of the simulated board's parts (core, flash, USB socket); not for tests. */
#ifndef HAL_SIM_INTERNAL_H
#define HAL_SIM_INTERNAL_H
#include "hal.h"
#include "hal_sim_emul.h"

/* Post an event to the firmware's queue (dropped when full, as on a real board). */
void hal_sim_post(uint8_t type, uint32_t arg);

/* Flash part (hal_sim_flash.c). */
int hal_sim_flash_setup(const hal_sim_config *cfg, char *err, int errlen);
void hal_sim_flash_teardown(void);
void hal_sim_flash_reboot(void);

/* USB-over-socket part (hal_sim_usb.c). */
int hal_sim_usb_setup(const char *path, char *err, int errlen);
void hal_sim_usb_teardown(void);
void hal_sim_usb_reboot(void);
/* Move bytes without blocking, or wait up to timeout_ms of real time for the socket;
 * posts USB_RX, USB_TX_DONE and USB_RESET as things happen. */
void hal_sim_usb_pump(int timeout_ms);
/* 1 while a bulk IN transfer is still being written to the host. */
int hal_sim_usb_tx_pending(void);

/* Loop control shared with the USB part. */
extern int hal_sim_exit_on_disconnect;
extern int hal_sim_eof_fd;

#endif
