/* The Arm MPS2 board with the AN500 image (Cortex-M7 with FPU), as QEMU 7.2 emulates it
 * (`qemu-system-arm -M mps2-an500`): the memory map and peripherals hal/mps2 drives. A real
 * MPS2+ with AN500 has the same map; only the table flash and the sensor are stand-ins. */
#ifndef WDR_BOARD_MPS2_AN500_H
#define WDR_BOARD_MPS2_AN500_H
#include <stdint.h>

#define MPS2_SYSCLK_HZ 25000000u     /* SYSCLK: the CMSDK timers count at it (40 ns a tick) */
#define MPS2_TIMER0_BASE 0x40000000u /* CMSDK APB timer: CTRL +0, VALUE +4, RELOAD +8 */
#define MPS2_UART0_BASE 0x40004000u  /* CMSDK UART: DATA +0, STATE +4, CTRL +8, BAUDDIV +0x10 */
#define MPS2_UART_BAUDDIV 16u        /* the smallest divider; QEMU ignores the rate */

/* Code memory, ZBT SSRAM1 at 0 (4 MiB, the board's boot memory): the bootloader at the reset
 * vector (mps2-an500-boot.ld), then the application, which the bootloader copies there from its
 * image slot at every boot (RAM load; mps2-an500-app.ld links it to run there). */
#define MPS2_BOOT_BASE 0x00000000u
#define MPS2_BOOT_SIZE 0x00020000u /* 128 KiB */
#define MPS2_APP_BASE 0x00020000u  /* every application image's load_addr */
#define MPS2_APP_LIMIT 0x00400000u /* end of SSRAM1: an application lies in [BASE, LIMIT) */

/* Data memory, SSRAM2/3 at 0x20000000 (4 MiB). Its last 256 bytes belong to neither image's
 * linker script: the boot record the bootloader leaves for the application (wdr_boot_record,
 * wdr_boot.h), and the reset note that whoever causes a reset (hal_reset, a fault handler, the
 * watchdog's early warning) leaves for the bootloader. A reset keeps RAM; power-on does not. */
#define MPS2_RAM_BASE 0x20000000u
#define MPS2_RAM_KEPT 0x203fff00u /* the images' RAM ends here */
#define MPS2_BOOT_RECORD_ADDR 0x203fff00u
#define MPS2_RESET_NOTE_ADDR 0x203fffe0u

#define MPS2_RESET_NOTE_MAGIC 0x544e5257u /* "WRNT" */

/* The reset note: the cause (enum wdr_reset_cause), and a fault's stacked PC and CFSR. check is
 * magic ^ cause ^ fault_pc ^ fault_status ^ 0xffffffff, so RAM's power-on garbage is no note. */
typedef struct mps2_reset_note {
    uint32_t magic, cause, fault_pc, fault_status, check;
} mps2_reset_note;

static inline volatile mps2_reset_note *mps2_reset_note_at(void)
{
    return (volatile mps2_reset_note *)(uintptr_t)MPS2_RESET_NOTE_ADDR;
}

static inline uint32_t mps2_reset_note_check(uint32_t cause, uint32_t pc, uint32_t status)
{
    return MPS2_RESET_NOTE_MAGIC ^ cause ^ pc ^ status ^ 0xffffffffu;
}

static inline void mps2_reset_note_write(uint32_t cause, uint32_t pc, uint32_t status)
{
    volatile mps2_reset_note *n = mps2_reset_note_at();
    n->magic = MPS2_RESET_NOTE_MAGIC;
    n->cause = cause;
    n->fault_pc = pc;
    n->fault_status = status;
    n->check = mps2_reset_note_check(cause, pc, status);
}

/* Cortex-M7 system control (the core's, the same on every M7). */
#define MPS2_SCB_VTOR 0xe000ed08u
#define MPS2_SCB_AIRCR 0xe000ed0cu
#define MPS2_SCB_CFSR 0xe000ed28u
#define MPS2_SCB_CPACR 0xe000ed88u
#define MPS2_AIRCR_SYSRESETREQ 0x05fa0004u /* VECTKEY | SYSRESETREQ */

/* CMSDK APB watchdog, clocked at SYSCLK: the first expiry raises the NMI (the early warning,
 * which notes the cause), the second resets the board. */
#define MPS2_WDOG_BASE 0x40008000u /* LOAD +0, VALUE +4, CTRL +8, INTCLR +0xC, LOCK +0xC00 */
#define MPS2_WDOG_CTRL_INTEN 0x1u
#define MPS2_WDOG_CTRL_RESEN 0x2u
#define MPS2_WDOG_UNLOCK 0x1acce551u
#define MPS2_WDOG_TICKS (2u * MPS2_SYSCLK_HZ) /* 2 s to the NMI, 2 more to the reset */

/* 16 MiB of PSRAM at 0x60000000: the table flash and the image flash (NOR rules kept by the
 * HAL and the bootloader), then the replayed sensor frames, which the test loads with QEMU's
 * `-device loader` (no physics on the target). As a file (`memory-backend-file`) it keeps
 * what a flash would across a power cut. */
#define MPS2_PSRAM_BASE 0x60000000u
#define MPS2_FLASH_BASE MPS2_PSRAM_BASE
#define MPS2_FLASH_BLOCK 4096u
#define MPS2_FLASH_BLOCKS 1536u /* 6 MiB */
#define MPS2_FLASH_PROG 16u
#define MPS2_IMAGE_FLASH_BASE 0x60600000u /* floor log and the two image slots (SPEC.md) */
#define MPS2_IMAGE_FLASH_BLOCK 4096u
#define MPS2_IMAGE_FLASH_BLOCKS 512u /* 2 MiB: two slots of 255 blocks, 1016 KiB images */
#define MPS2_IMAGE_FLASH_PROG 16u
#define MPS2_FLASH_MARK 0x60fffff0u  /* a word that says the table flash was erased once ("factory") */
#define MPS2_REPLAY_BASE 0x60800000u /* replay file: header, then frames of height rows of width u16 */
#define MPS2_REPLAY_MAX (0x60fffff0u - 0x60800000u)

/* The stand-in sensor: 12-bit ADC and DAC, as sim-vga; geometry from the replay header. */
#define MPS2_SENSOR_ID 0x4d505332u /* "2SPM": tables for this board carry it */
#define MPS2_ADC_BITS 12u
#define MPS2_DAC_BITS 12u
#define MPS2_ROW_TIME_NS 2000u

#endif
