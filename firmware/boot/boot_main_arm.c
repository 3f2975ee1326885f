/* The bootloader for the mps2-an500 (Cortex-M7), its own image at the reset vector
 * (wdr_boot_mps2.elf, boards/mps2-an500/mps2-an500-boot.ld). At every reset: learn why the
 * board reset (the reset note), let wdr_boot_decide pick the slot over the image flash, copy
 * that slot's application to its load address (RAM load), leave the boot record for it, point
 * VTOR and MSP at its vector table and jump. Nothing bootable: one line on UART0, then wait for
 * the debugger. Built twice: with the signature check (the only one ever flashed) and "hash
 * only" (WDR_BOOT_CHECK_SIGNATURE=0), which only measures what the check costs. */
#include "hal.h"
#include "mps2_board.h"
#include "wdr_boot.h"
#include "wdr_err.h"
#include <string.h>

#ifndef WDR_BOOT_CHECK_SIGNATURE
#define WDR_BOOT_CHECK_SIGNATURE 1
#endif

#define REG(addr) (*(volatile uint32_t *)(uintptr_t)(addr))
#define UART_DATA REG(MPS2_UART0_BASE + 0x0u)
#define UART_STATE REG(MPS2_UART0_BASE + 0x4u)
#define UART_CTRL REG(MPS2_UART0_BASE + 0x8u)
#define UART_BAUDDIV REG(MPS2_UART0_BASE + 0x10u)
#define UART_TX_FULL 0x1u
#define TIMER_CTRL REG(MPS2_TIMER0_BASE + 0x0u)
#define TIMER_VALUE REG(MPS2_TIMER0_BASE + 0x4u)
#define TIMER_RELOAD REG(MPS2_TIMER0_BASE + 0x8u)
#define NS_PER_TICK (1000000000u / MPS2_SYSCLK_HZ)

_Static_assert(sizeof(wdr_boot_record) <= MPS2_RESET_NOTE_ADDR - MPS2_BOOT_RECORD_ADDR,
               "the boot record overlaps the reset note");

extern uint32_t _stack_top, _data_load, _data_start, _data_end, _bss_start, _bss_end;

void wdr_boot_reset_handler(void);
int main(void);

static void park(void)
{
    for (;;)
        __asm volatile("wfi");
}

__attribute__((section(".isr_vector"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))(uintptr_t)&_stack_top, wdr_boot_reset_handler, park, park, park, park, park, 0, 0, 0, 0,
    park, park, 0, park, park,
};

/* Timer 0 counts the bootloader's time from its first instructions (boot_ns in the record;
 * with QEMU's -icount shift=0 that is its instruction count, tests/target/boot_bench.sh). */
static void timer_start(void)
{
    TIMER_CTRL = 0;
    TIMER_RELOAD = 0xffffffffu;
    TIMER_VALUE = 0xffffffffu;
    TIMER_CTRL = 1u;
}

void wdr_boot_reset_handler(void)
{
    timer_start();
    memcpy(&_data_start, &_data_load, (size_t)((uint8_t *)&_data_end - (uint8_t *)&_data_start));
    memset(&_bss_start, 0, (size_t)((uint8_t *)&_bss_end - (uint8_t *)&_bss_start));
    REG(MPS2_SCB_CPACR) |= 0xFu << 20; /* CP10/CP11: the compiler may move blocks through FPU registers */
    __asm volatile("dsb\n isb");
    main();
    park();
}

/* ---- UART0: the one line a board that boots nothing says ------------------------------------- */

static void uart_puts(const char *s)
{
    UART_BAUDDIV = MPS2_UART_BAUDDIV;
    UART_CTRL = 0x1u; /* TX */
    for (; *s; s++) {
        while (UART_STATE & UART_TX_FULL) {
        }
        UART_DATA = (uint8_t)*s;
    }
}

/* ---- The image flash, through hal/mps2's NOR rules -------------------------------------------- */

static int flash_read(void *ctx, uint32_t addr, void *buf, uint32_t len)
{
    (void)ctx;
    return hal_image_flash_read(addr, buf, len);
}

static int flash_erase(void *ctx, uint32_t block)
{
    (void)ctx;
    return hal_image_flash_erase(block);
}

static int flash_prog(void *ctx, uint32_t addr, const void *buf, uint32_t len)
{
    (void)ctx;
    return hal_image_flash_prog(addr, buf, len);
}

/* ---- Why this boot: the note whoever reset the board left, consumed here ------------------------ */

static void reset_cause(const wdr_boot_record *prev, wdr_boot_record *rec)
{
    volatile mps2_reset_note *n = mps2_reset_note_at();
    bool prev_ok = wdr_boot_record_ok(prev);
    if (n->magic == MPS2_RESET_NOTE_MAGIC &&
        n->check == mps2_reset_note_check(n->cause, n->fault_pc, n->fault_status) && n->cause <= WDR_RESET_UNKNOWN) {
        rec->reset_cause = (uint8_t)n->cause;
        rec->fault_pc = n->fault_pc;
        rec->fault_status = n->fault_status;
    } else {
        /* RAM kept a record but nobody left a note: a reset the firmware did not cause (the
         * debugger's, a reset button). Neither: RAM lost its content, a power-on. */
        rec->reset_cause = prev_ok ? WDR_RESET_UNKNOWN : WDR_RESET_POWER_ON;
    }
    rec->boots = prev_ok ? prev->boots + 1u : 0u;
    n->magic = 0; /* consumed: the next reset leaves its own */
}

/* ---- Into the application ------------------------------------------------------------------------ */

static uint64_t elapsed_ns(void)
{
    return (uint64_t)(0xffffffffu - TIMER_VALUE) * NS_PER_TICK;
}

/* VTOR, then MSP from the application's vector table, then its reset handler; nothing of the
 * bootloader's stack is used after the MSR. (No cache is enabled, so the copied code needs no
 * cache maintenance: DSB/ISB order the copy before the fetch.) */
__attribute__((noreturn)) static void jump(uint32_t vtor)
{
    const volatile uint32_t *v = (const volatile uint32_t *)(uintptr_t)vtor;
    uint32_t sp = v[0], pc = v[1];
    REG(MPS2_SCB_VTOR) = vtor;
    __asm volatile("dsb\n isb\n msr msp, %0\n bx %1" : : "r"(sp), "r"(pc) : "memory");
    __builtin_unreachable();
}

static void report_nothing_bootable(const wdr_boot_decision *d, int err)
{
    uart_puts("wdr-boot: no bootable image (slot A ");
    uart_puts(wdr_slot_state_name(d->slots[0].state));
    uart_puts(", slot B ");
    uart_puts(wdr_slot_state_name(d->slots[1].state));
    uart_puts(err ? "; image flash error): waiting for the debugger\r\n" : "): waiting for the debugger\r\n");
}

static wdr_boot_decision decision; /* large (two headers and trailers): static, not on the stack */

int main(void)
{
    wdr_boot_record rec, prev;
    memset(&rec, 0, sizeof rec);
    memcpy(&prev, (const void *)(uintptr_t)MPS2_BOOT_RECORD_ADDR, sizeof prev);
    reset_cause(&prev, &rec);

    wdr_boot_flash flash = {.ctx = 0, .read = flash_read, .erase = flash_erase, .prog = flash_prog};
    wdr_boot_layout layout;
    const wdr_boot_policy policy = {.board = "mps2-an500",
                                    .pubkey = wdr_boot_key(),
                                    .load_lo = MPS2_APP_BASE,
                                    .load_hi = MPS2_APP_LIMIT,
                                    .check_signature = WDR_BOOT_CHECK_SIGNATURE};
    int err = hal_image_flash_geometry_get(&flash.geo);
    if (!err)
        err = wdr_boot_layout_init(&layout, &flash.geo);
    memset(&decision, 0, sizeof decision);
    decision.slot = -1;
    if (!err)
        err = wdr_boot_decide(&flash, &layout, &policy, &decision);
    if (err || decision.slot < 0) {
        report_nothing_bootable(&decision, err);
        park();
    }

    const wdr_boot_slot *s = &decision.slots[decision.slot];
    if (hal_image_flash_read(layout.slot_addr[decision.slot] + WDR_IMAGE_HEADER_SIZE,
                             (void *)(uintptr_t)s->hdr.load_addr, s->hdr.image_size)) {
        report_nothing_bootable(&decision, WDR_E_IO);
        park();
    }
    rec.slot = (uint8_t)decision.slot;
    rec.testing = decision.testing;
    rec.attempts = s->attempts;
    rec.floor = decision.floor;
    rec.hdr = s->hdr;
    rec.boot_ns = elapsed_ns();
    wdr_boot_record_seal(&rec);
    memcpy((void *)(uintptr_t)MPS2_BOOT_RECORD_ADDR, &rec, sizeof rec);
    jump(s->hdr.load_addr);
}
