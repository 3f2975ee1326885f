/* hal_linux_gpio.h on libgpiod 1.x (Debian 12's 1.6): a line bulk on one chip. */
#include "hal_linux_gpio.h"
#include <errno.h>
#include <gpiod.h>
#include <stdio.h>
#include <string.h>

static struct gpiod_chip *chip;
static struct gpiod_line_bulk bulk;
static int requested;

const char *lx_gpio_library(void)
{
    static char text[48];
    snprintf(text, sizeof text, "libgpiod %s", gpiod_version_string());
    return text;
}

int lx_gpio_chip_open(const char *path)
{
    lx_gpio_chip_close();
    chip = gpiod_chip_open(path);
    return chip ? 0 : -1;
}

void lx_gpio_chip_close(void)
{
    lx_gpio_release();
    if (chip)
        gpiod_chip_close(chip);
    chip = NULL;
}

int lx_gpio_chip_label(char *out, size_t cap)
{
    snprintf(out, cap, "%s", gpiod_chip_label(chip));
    return 0;
}

unsigned lx_gpio_chip_lines(void) { return gpiod_chip_num_lines(chip); }

int lx_gpio_line_find(const char *name)
{
    struct gpiod_line *line = gpiod_chip_find_line(chip, name);
    if (!line) {
        errno = ENOENT;
        return -1;
    }
    return (int)gpiod_line_offset(line);
}

int lx_gpio_request_outputs(const unsigned *offsets, unsigned n, const char *consumer)
{
    int zeros[GPIOD_LINE_BULK_MAX_LINES] = {0};
    if (n > GPIOD_LINE_BULK_MAX_LINES) {
        errno = E2BIG;
        return -1;
    }
    if (gpiod_chip_get_lines(chip, (unsigned *)offsets, n, &bulk) != 0)
        return -1;
    if (gpiod_line_request_bulk_output(&bulk, consumer, zeros) != 0)
        return -1;
    requested = 1;
    return 0;
}

int lx_gpio_set(const int *values) { return gpiod_line_set_value_bulk(&bulk, (int *)values); }

int lx_gpio_get(int *values) { return gpiod_line_get_value_bulk(&bulk, values); }

void lx_gpio_release(void)
{
    if (requested)
        gpiod_line_release_bulk(&bulk);
    requested = 0;
}
