/* hal_linux_gpio.h on libgpiod 2.x (Debian 13, bookworm-backports, Raspberry Pi OS): one line
 * request on one chip, its values in the order the offsets were given. */
#include "hal_linux_gpio.h"
#include <errno.h>
#include <gpiod.h>
#include <stdio.h>
#include <string.h>

#define MAX_LINES 64u

static struct gpiod_chip *chip;
static struct gpiod_line_request *request;
static unsigned n_requested;

const char *lx_gpio_library(void)
{
    static char text[48];
    snprintf(text, sizeof text, "libgpiod %s", gpiod_api_version());
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
    struct gpiod_chip_info *info = gpiod_chip_get_info(chip);
    if (!info)
        return -1;
    snprintf(out, cap, "%s", gpiod_chip_info_get_label(info));
    gpiod_chip_info_free(info);
    return 0;
}

unsigned lx_gpio_chip_lines(void)
{
    struct gpiod_chip_info *info = gpiod_chip_get_info(chip);
    unsigned n = info ? (unsigned)gpiod_chip_info_get_num_lines(info) : 0;
    gpiod_chip_info_free(info);
    return n;
}

int lx_gpio_line_find(const char *name) { return gpiod_chip_get_line_offset_from_name(chip, name); }

/* The request: every line an output, driven low (inactive, active-high) from the start. */
static struct gpiod_line_request *request_lines(const unsigned *offsets, unsigned n, const char *consumer)
{
    struct gpiod_line_settings *settings = gpiod_line_settings_new();
    struct gpiod_line_config *lines = gpiod_line_config_new();
    struct gpiod_request_config *config = gpiod_request_config_new();
    struct gpiod_line_request *req = NULL;
    if (settings && lines && config &&
        gpiod_line_settings_set_direction(settings, GPIOD_LINE_DIRECTION_OUTPUT) == 0 &&
        gpiod_line_settings_set_output_value(settings, GPIOD_LINE_VALUE_INACTIVE) == 0 &&
        gpiod_line_config_add_line_settings(lines, offsets, n, settings) == 0) {
        gpiod_request_config_set_consumer(config, consumer);
        req = gpiod_chip_request_lines(chip, config, lines);
    }
    int err = errno;
    gpiod_request_config_free(config);
    gpiod_line_config_free(lines);
    gpiod_line_settings_free(settings);
    errno = err;
    return req;
}

int lx_gpio_request_outputs(const unsigned *offsets, unsigned n, const char *consumer)
{
    lx_gpio_release();
    if (n > MAX_LINES) {
        errno = E2BIG;
        return -1;
    }
    request = request_lines(offsets, n, consumer);
    n_requested = request ? n : 0;
    return request ? 0 : -1;
}

int lx_gpio_set(const int *values)
{
    enum gpiod_line_value v[MAX_LINES];
    for (unsigned i = 0; i < n_requested; i++)
        v[i] = values[i] ? GPIOD_LINE_VALUE_ACTIVE : GPIOD_LINE_VALUE_INACTIVE;
    return gpiod_line_request_set_values(request, v);
}

int lx_gpio_get(int *values)
{
    enum gpiod_line_value v[MAX_LINES];
    if (gpiod_line_request_get_values(request, v) != 0)
        return -1;
    for (unsigned i = 0; i < n_requested; i++)
        values[i] = v[i] == GPIOD_LINE_VALUE_ACTIVE;
    return 0;
}

void lx_gpio_release(void)
{
    if (request)
        gpiod_line_request_release(request);
    request = NULL;
    n_requested = 0;
}
