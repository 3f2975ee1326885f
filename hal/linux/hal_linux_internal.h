/* Shared state of the Linux board's parts (core, lines, USB, flash, self-test); not for the
 * firmware. */
#ifndef HAL_LINUX_INTERNAL_H
#define HAL_LINUX_INTERNAL_H
#include "hal.h"
#include "hal_linux_board.h"
#include "hal_linux_gpio.h"
#include <signal.h>
#include <stdio.h>

/* The board hal_init brings up: set before it (wdr-board --config). */
void lx_board_use(const lx_board *b);
const lx_board *lx_board_get(void);

/* Post an event from any thread; wakes hal_wait_for_event. */
void lx_post(uint8_t type, uint32_t arg);

/* The control lines (hal_linux_lines.c), values in lx_board's line order. */
int lx_lines_open(const lx_board *b);
int lx_lines_set(const int *values);
int lx_lines_get(int *values);
unsigned lx_lines_offset(unsigned i);
const char *lx_lines_chip(void); /* the chip's path once found */
void lx_lines_close(void);

int lx_usb_init(void);
void lx_usb_close(void);
int lx_flash_init(void);
void lx_flash_close(void);
const char *lx_flash_device(void); /* the MTD device once found ("/dev/mtd0") */

/* Bring-up failed in call on what (a device path, usually): remember "call what: strerror(errno)"
 * for lx_bringup_error and return WDR_E_IO. Keeps errno. */
int lx_fail(const char *call, const char *what);

/* Why hal_init failed ("" if it did not): the device path, the call and errno. For wdr-board. */
const char *lx_bringup_error(void);

/* The devices hal_init opens, without the USB gadget: for the self-test. */
int lx_devices_open(void);
void lx_devices_close(void);
int lx_spi_fd(int adc); /* the DAC's (0) or the column ADC's (1) spidev */

/* Stop everything hal_init started, in the order that leaves the flash and the host consistent:
 * the ramp, the USB threads and endpoints, the devices. */
void lx_shutdown(void);

/* hal_reset's exit status (EX_TEMPFAIL), which wdr-board.service restarts. */
#define LX_EXIT_RESET 75
/* Wakes the USB threads out of a blocking FunctionFS call when the board stops (hal_linux_usb.c). */
#define LX_USB_WAKE_SIGNAL SIGUSR2

/* Wake hal_wait_for_event from a signal handler (async-signal-safe). */
void lx_wake_from_signal(void);

/* systemd's notification protocol over $NOTIFY_SOCKET (hal_linux_notify.c); no-op without it. */
void lx_notify(const char *state);

/* wdr-board --self-test (hal_linux_selftest.c): 0 when every line and converter answered. */
int lx_self_test(FILE *out);

#endif
