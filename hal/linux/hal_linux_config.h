/* What must stay fixed at build time on the Linux board: buffer sizes. Everything about the
 * wiring and the sensor is read at run time (hal_linux_board.h, boards/README.md). */
#ifndef HAL_LINUX_CONFIG_H
#define HAL_LINUX_CONFIG_H

/* A row is one spidev transfer of width 16-bit words; spidev's default bufsiz is 4096 bytes. */
#define HAL_LINUX_MAX_WIDTH 2048u
#define HAL_LINUX_MAX_ROW_ADDR_BITS 16u /* rows are 16-bit */
#define HAL_LINUX_PATH_MAX 128u         /* device paths, the FunctionFS mount, chip labels */
#define HAL_LINUX_NAME_MAX 32u          /* line names (the kernel's own limit is 32) */
#define HAL_LINUX_BOARD_FILE_MAX 65536u /* a board file larger than this is refused */

#endif
