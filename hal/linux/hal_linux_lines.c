/* The sensor's control lines (hal_linux_board.h): the chip found by path or by label, each line
 * by offset or by name, one output request for them all. The library calls are behind
 * hal_linux_gpio.h, so this file is the same on libgpiod 1.x and 2.x. */
#include "hal_linux_internal.h"
#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char chip_path[HAL_LINUX_PATH_MAX + 16];
static unsigned offsets[LX_MAX_LINES], n_lines;

/* Chips in /dev in name order, so that the first of two equal labels is always the same one. */
static int by_name(const struct dirent **a, const struct dirent **b)
{
    return atoi((*a)->d_name + 8) - atoi((*b)->d_name + 8); /* gpiochip10 after gpiochip9 */
}
static int is_chip(const struct dirent *d) { return !strncmp(d->d_name, "gpiochip", 8); }

/* Open the chip whose label is `label`; ENOENT when no chip has it. */
static int open_by_label(const char *label)
{
    struct dirent **names;
    int n = scandir("/dev", &names, is_chip, by_name), found = 0;
    for (int i = 0; i < n; i++) {
        char got[HAL_LINUX_PATH_MAX];
        snprintf(chip_path, sizeof chip_path, "/dev/%.100s", names[i]->d_name);
        if (!found && lx_gpio_chip_open(chip_path) == 0) {
            found = lx_gpio_chip_label(got, sizeof got) == 0 && !strcmp(got, label);
            if (!found)
                lx_gpio_chip_close();
        }
        free(names[i]);
    }
    free(n >= 0 ? names : NULL);
    if (found)
        return 0;
    errno = ENOENT;
    snprintf(chip_path, sizeof chip_path, "%s", label);
    return -1;
}

const char *lx_lines_chip(void) { return chip_path; }

static int open_chip(const char *spec)
{
    if (spec[0] == '/') {
        snprintf(chip_path, sizeof chip_path, "%s", spec);
        return lx_gpio_chip_open(spec) == 0 ? WDR_OK : lx_fail("gpiod_chip_open", spec);
    }
    if (open_by_label(spec) == 0)
        return WDR_OK;
    char what[HAL_LINUX_PATH_MAX + 48];
    snprintf(what, sizeof what, "'%s' (no /dev/gpiochip* has that label)", spec);
    return lx_fail("gpio chip label", what);
}

/* The offset of line i of the board, looked up by name when the board names it. */
static int resolve(const lx_board *b, unsigned i, unsigned *out)
{
    char role[32], what[HAL_LINUX_PATH_MAX + 96];
    lx_line_role(i, role, sizeof role);
    if (b->lines[i].offset >= 0) {
        *out = (unsigned)b->lines[i].offset;
        if (*out < lx_gpio_chip_lines())
            return WDR_OK;
        errno = EINVAL;
        snprintf(what, sizeof what, "%s line %u (%s: the chip has %u lines)", chip_path, *out, role,
                 lx_gpio_chip_lines());
        return lx_fail("gpio line offset", what);
    }
    int off = lx_gpio_line_find(b->lines[i].name);
    if (off >= 0) {
        *out = (unsigned)off;
        return WDR_OK;
    }
    snprintf(what, sizeof what, "%s line '%s' (%s)", chip_path, b->lines[i].name, role);
    return lx_fail("gpio line name", what);
}

int lx_lines_open(const lx_board *b)
{
    if (open_chip(b->gpio_chip) != WDR_OK)
        return WDR_E_IO;
    for (unsigned i = 0; i < b->n_lines; i++)
        if (resolve(b, i, &offsets[i]) != WDR_OK)
            return WDR_E_IO;
    n_lines = b->n_lines;
    if (lx_gpio_request_outputs(offsets, n_lines, "wdrcam") != 0) {
        char what[HAL_LINUX_PATH_MAX + 48];
        snprintf(what, sizeof what, "%s (%u lines as outputs)", chip_path, n_lines);
        return lx_fail("gpio line request", what);
    }
    return WDR_OK;
}

unsigned lx_lines_offset(unsigned i) { return i < n_lines ? offsets[i] : 0; }

int lx_lines_set(const int *values) { return lx_gpio_set(values) == 0 ? WDR_OK : WDR_E_IO; }

int lx_lines_get(int *values) { return lx_gpio_get(values) == 0 ? WDR_OK : WDR_E_IO; }

void lx_lines_close(void)
{
    lx_gpio_chip_close();
    n_lines = 0;
}
