/* The Arm MPS2 board with the AN500 image (Cortex-M7 with FPU), as QEMU 7.2 emulates it
 * (`qemu-system-arm -M mps2-an500`): the memory map and peripherals hal/mps2 drives. A real
 * MPS2+ with AN500 has the same map; only the table flash and the sensor are stand-ins. */
#ifndef WDR_BOARD_MPS2_AN500_H
#define WDR_BOARD_MPS2_AN500_H

#define MPS2_SYSCLK_HZ 25000000u     /* SYSCLK: the CMSDK timers count at it (40 ns a tick) */
#define MPS2_TIMER0_BASE 0x40000000u /* CMSDK APB timer: CTRL +0, VALUE +4, RELOAD +8 */
#define MPS2_UART0_BASE 0x40004000u  /* CMSDK UART: DATA +0, STATE +4, CTRL +8, BAUDDIV +0x10 */
#define MPS2_UART_BAUDDIV 16u        /* the smallest divider; QEMU ignores the rate */

/* 16 MiB of PSRAM at 0x60000000: the table flash (NOR rules kept by the HAL), then the replayed
 * sensor frames, which the test loads with QEMU's `-device loader` (no physics on the target). */
#define MPS2_PSRAM_BASE 0x60000000u
#define MPS2_FLASH_BASE MPS2_PSRAM_BASE
#define MPS2_FLASH_BLOCK 4096u
#define MPS2_FLASH_BLOCKS 2048u /* 8 MiB */
#define MPS2_FLASH_PROG 16u
#define MPS2_FLASH_MARK 0x60fffff0u  /* a word that says the flash was erased once ("factory") */
#define MPS2_REPLAY_BASE 0x60800000u /* replay file: header, then frames of height rows of width u16 */
#define MPS2_REPLAY_MAX (0x60fffff0u - 0x60800000u)

/* The stand-in sensor: 12-bit ADC and DAC, as sim-vga; geometry from the replay header. */
#define MPS2_SENSOR_ID 0x4d505332u /* "2SPM": tables for this board carry it */
#define MPS2_ADC_BITS 12u
#define MPS2_DAC_BITS 12u
#define MPS2_ROW_TIME_NS 2000u

#endif
