/* The Linux board's description at run time (`wdr-board --config board.json`, schema in
 * boards/README.md): the sensor, the GPIO chip and its lines, the SPI converters, the table
 * flash and the FunctionFS mount. Parsing only checks the text; the devices are looked up at
 * bring-up (a chip label, line names, an MTD partition name in /proc/mtd). */
#ifndef HAL_LINUX_BOARD_H
#define HAL_LINUX_BOARD_H
#include "hal_linux_config.h"
#include <stddef.h>
#include <stdint.h>

/* The control lines, in request order: three fixed roles, then the row address bits. */
enum { LX_LINE_RESET, LX_LINE_ROW_SELECT, LX_LINE_ADC_CONVERT, LX_LINE_ROW_ADDR0 };
#define LX_MAX_LINES (3u + HAL_LINUX_MAX_ROW_ADDR_BITS)

typedef struct lx_line_ref {
    int offset;                    /* >= 0: by offset; -1: by name */
    char name[HAL_LINUX_NAME_MAX]; /* the line's name on the chip (gpioinfo shows it) */
} lx_line_ref;

typedef struct lx_spi_ref {
    char path[HAL_LINUX_PATH_MAX];
    uint32_t speed_hz;
} lx_spi_ref;

typedef struct lx_board {
    char name[32]; /* HAL_BOARD_NAME_MAX (hal.h), checked in hal_linux.c */
    uint32_t sensor_id;
    uint16_t width, height;
    uint8_t adc_bits, dac_bits;
    uint32_t row_time_ns, adc_convert_ns;
    char gpio_chip[HAL_LINUX_PATH_MAX]; /* "/dev/gpiochip0" (a path) or "pinctrl-bcm2711" (a label) */
    unsigned n_lines;                   /* 3 + row address bits */
    lx_line_ref lines[LX_MAX_LINES];
    lx_spi_ref dac, adc;
    char mtd[HAL_LINUX_PATH_MAX];        /* "/dev/mtd2" (a path) or "wdr-tables" (a name in /proc/mtd) */
    char functionfs[HAL_LINUX_PATH_MAX]; /* the FunctionFS mount of the gadget */
} lx_board;

/* What a line is for, in messages: "reset", "row_select", "adc_convert", "row_address[3]". */
const char *lx_line_role(unsigned i, char *buf, size_t cap);

/* Parse a board description. On error, err says "FILE: field 'F': value V: why". No device is
 * touched. @return 0, or -1 with err set */
int lx_board_parse(const char *text, size_t len, const char *file, lx_board *out, char *err, size_t errlen);
/* Read and parse FILE. @return 0, -1 (bad content), -2 (cannot read; err says why) */
int lx_board_load(const char *file, lx_board *out, char *err, size_t errlen);

#endif
