/* Build-time description of a real board on embedded Linux: which GPIO lines, SPI devices,
 * FunctionFS mount and MTD partition the HAL drives, and the sensor behind them. A board may
 * point WDR_HAL_LINUX_CONFIG_FILE at its own header defining some of these first; impossible
 * combinations stop the build here. */
#ifndef HAL_LINUX_CONFIG_H
#define HAL_LINUX_CONFIG_H
#ifdef WDR_HAL_LINUX_CONFIG_FILE
#include WDR_HAL_LINUX_CONFIG_FILE
#endif

#ifndef HAL_LINUX_BOARD_NAME
#define HAL_LINUX_BOARD_NAME "wdrcam-linux"
#endif
#ifndef HAL_LINUX_SENSOR_ID
#define HAL_LINUX_SENSOR_ID 13569u
#endif
#ifndef HAL_LINUX_WIDTH
#define HAL_LINUX_WIDTH 640u
#endif
#ifndef HAL_LINUX_HEIGHT
#define HAL_LINUX_HEIGHT 480u
#endif
#ifndef HAL_LINUX_ADC_BITS
#define HAL_LINUX_ADC_BITS 12u
#endif
#ifndef HAL_LINUX_DAC_BITS
#define HAL_LINUX_DAC_BITS 12u
#endif
#ifndef HAL_LINUX_ROW_TIME_NS
#define HAL_LINUX_ROW_TIME_NS 20000u
#endif
#ifndef HAL_LINUX_ADC_CONVERT_NS
#define HAL_LINUX_ADC_CONVERT_NS 2000u /* convert pulse until the column ADCs hold their codes */
#endif

/* Control lines: one gpiochip; reset, row select, ADC convert, then the row address bits. */
#ifndef HAL_LINUX_GPIOCHIP
#define HAL_LINUX_GPIOCHIP "/dev/gpiochip0"
#endif
#ifndef HAL_LINUX_LINE_RESET
#define HAL_LINUX_LINE_RESET 5u
#endif
#ifndef HAL_LINUX_LINE_ROW_SELECT
#define HAL_LINUX_LINE_ROW_SELECT 6u
#endif
#ifndef HAL_LINUX_LINE_ADC_CONVERT
#define HAL_LINUX_LINE_ADC_CONVERT 13u
#endif
#ifndef HAL_LINUX_LINE_ROW_ADDR0
#define HAL_LINUX_LINE_ROW_ADDR0 16u /* address bit i is line ROW_ADDR0 + i */
#endif
#ifndef HAL_LINUX_ROW_ADDR_BITS
#define HAL_LINUX_ROW_ADDR_BITS 9u
#endif

/* SPI: the ramp DAC takes one 16-bit big-endian word per code; the column ADC shifts out one
 * 16-bit big-endian word per column after a convert pulse. */
#ifndef HAL_LINUX_SPI_DAC
#define HAL_LINUX_SPI_DAC "/dev/spidev0.0"
#endif
#ifndef HAL_LINUX_SPI_ADC
#define HAL_LINUX_SPI_ADC "/dev/spidev0.1"
#endif
#ifndef HAL_LINUX_SPI_HZ
#define HAL_LINUX_SPI_HZ 20000000u
#endif

/* USB: the FunctionFS instance of the gadget (see hal/linux/README.md), and the table flash. */
#ifndef HAL_LINUX_FFS_DIR
#define HAL_LINUX_FFS_DIR "/dev/ffs-wdrcam"
#endif
#ifndef HAL_LINUX_MTD
#define HAL_LINUX_MTD "/dev/mtd2"
#endif

#if (1u << HAL_LINUX_ROW_ADDR_BITS) < HAL_LINUX_HEIGHT
#error "HAL_LINUX_ROW_ADDR_BITS cannot address every row"
#endif
#if HAL_LINUX_ROW_ADDR_BITS > 16
#error "HAL_LINUX_ROW_ADDR_BITS: rows are 16-bit"
#endif
#if HAL_LINUX_ADC_BITS > 16 || HAL_LINUX_DAC_BITS > 16
#error "ADC and DAC words are 16 bits"
#endif
#if HAL_LINUX_WIDTH * 2u > 4096u
#error "a row must fit one spidev transfer (4096 bytes by default)"
#endif

#endif
