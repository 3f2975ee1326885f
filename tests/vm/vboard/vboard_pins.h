/* The virtual board's wiring and sensor (wdrvb.ko and the VM test's frame checker): what
 * boards/vm-wdrvb/wdr-board.json describes to wdr-board at run time. Plain C, no headers:
 * the kernel and user space both include it. */
#ifndef VBOARD_PINS_H
#define VBOARD_PINS_H

#define VB_SENSOR_ID 13569u
#define VB_WIDTH 640u
#define VB_HEIGHT 480u
#define VB_ADC_BITS 12u
#define VB_DAC_BITS 12u
#define VB_SPI_HZ 20000000u

/* Line offsets on the "wdrvb" gpiochip; the first three also carry the names below. */
#define VB_LINE_RESET 5u
#define VB_LINE_ROW_SELECT 6u
#define VB_LINE_ADC_CONVERT 13u
#define VB_LINE_ROW_ADDR0 16u /* address bit i is line ROW_ADDR0 + i */
#define VB_ROW_ADDR_BITS 9u

#define VB_NAME_RESET "SENSOR_RESET"
#define VB_NAME_ROW_SELECT "ROW_SELECT"
#define VB_NAME_ADC_CONVERT "ADC_CONVERT"

#endif
