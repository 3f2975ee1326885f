/* The control lines' chip, whichever libgpiod the build found: one implementation file per
 * API (hal_linux_gpio_v1.c for libgpiod 1.x, hal_linux_gpio_v2.c for 2.x), chosen by CMake.
 * One chip and one request of output lines at a time; the callers (hal_linux_lines.c) resolve
 * labels and names through these calls, so neither backend knows the board's wiring.
 * Every call returns 0, or -1 with errno set by libgpiod or the kernel. */
#ifndef HAL_LINUX_GPIO_H
#define HAL_LINUX_GPIO_H
#include <stddef.h>

/* "libgpiod 2.1.3": the library the program runs on (for --version and the self-test). */
const char *lx_gpio_library(void);

int lx_gpio_chip_open(const char *path);
void lx_gpio_chip_close(void);
/* The open chip's label ("pinctrl-bcm2711", "wdrvb") and line count. */
int lx_gpio_chip_label(char *out, size_t cap);
unsigned lx_gpio_chip_lines(void);
/* The offset of the line named `name` on the open chip; -1 (errno ENOENT) when there is none. */
int lx_gpio_line_find(const char *name);

/* Request lines as outputs, all driven low; their values are then in this order. */
int lx_gpio_request_outputs(const unsigned *offsets, unsigned n, const char *consumer);
int lx_gpio_set(const int *values);
/* What the lines read back (a driven output reads its pin where the chip can). */
int lx_gpio_get(int *values);
void lx_gpio_release(void);

#endif
