/* Target linux_board: the Linux board description parser (hal/linux/hal_linux_board.c), on the
 * input as a board file. A file it accepts must keep its promises: every string terminated and
 * within its field, the geometry in range, enough address lines for the rows, no line twice;
 * a refused one must say why in a message naming the file. */
#include "hal_linux_board.h"
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static void check_accepted(const lx_board *b)
{
    if (!memchr(b->name, 0, sizeof b->name) || !memchr(b->gpio_chip, 0, sizeof b->gpio_chip) ||
        !memchr(b->mtd, 0, sizeof b->mtd) || !memchr(b->functionfs, 0, sizeof b->functionfs) ||
        b->dac.path[0] != '/' || b->adc.path[0] != '/' || b->functionfs[0] != '/')
        abort();
    if (b->width < 1 || b->width > HAL_LINUX_MAX_WIDTH || b->height < 1 || b->adc_bits < 4 || b->adc_bits > 16 ||
        b->dac_bits < 4 || b->dac_bits > 16)
        abort();
    if (b->n_lines < 4 || b->n_lines > LX_MAX_LINES || (1ul << (b->n_lines - 3)) < b->height)
        abort();
    for (unsigned i = 0; i < b->n_lines; i++) {
        const lx_line_ref *l = &b->lines[i];
        if (l->offset < 0 && (!l->name[0] || !memchr(l->name, 0, sizeof l->name)))
            abort();
        for (unsigned j = 0; j < i; j++)
            if (l->offset >= 0 ? l->offset == b->lines[j].offset
                               : b->lines[j].offset < 0 && !strcmp(l->name, b->lines[j].name))
                abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static lx_board b;
    char err[400];
    if (lx_board_parse((const char *)data, size, "fuzz.json", &b, err, sizeof err) == 0)
        check_accepted(&b);
    else if (strncmp(err, "fuzz.json: ", 11) != 0)
        abort(); /* every refusal names the file */
    return 0;
}
