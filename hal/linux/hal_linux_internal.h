/* Shared state of the Linux board's parts (core, USB, flash); not for the firmware. */
#ifndef HAL_LINUX_INTERNAL_H
#define HAL_LINUX_INTERNAL_H
#include "hal.h"
#include "hal_linux_config.h"

/* Post an event from any thread; wakes hal_wait_for_event. */
void lx_post(uint8_t type, uint32_t arg);

int lx_usb_init(void);
int lx_flash_init(void);

/* Bring-up failed in call on what (a device path, usually): remember "call what: strerror(errno)"
 * for lx_bringup_error and return WDR_E_IO. Keeps errno. */
int lx_fail(const char *call, const char *what);

/* Why hal_init failed ("" if it did not): the device path, the call and errno. For wdr-board. */
const char *lx_bringup_error(void);

#endif
