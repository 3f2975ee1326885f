/* Cortex-M7 entry: vector table, C runtime start, and the firmware's task loop.
 * Only built by the cortex-m7 preset, linked with whichever HAL backend the board uses
 * (hal/template for the footprint build). */
#include "wdr_boot.h"
#include "wdr_fw.h"
#include <stdint.h>
#include <string.h>

#if defined(WDR_BOARD_MPS2_AN500)
#include "mps2_board.h" /* the reset note: where a fault's cause survives the reset */
#define NOTE_RESET(cause, pc, status) mps2_reset_note_write(cause, pc, status)
#define NOTED_FAULT()                                                                                                  \
    (mps2_reset_note_at()->magic == MPS2_RESET_NOTE_MAGIC && mps2_reset_note_at()->cause == WDR_RESET_FAULT)
#else /* the footprint build: no bootloader to tell */
#define NOTE_RESET(cause, pc, status) ((void)(cause), (void)(pc), (void)(status))
#define NOTED_FAULT() 0
#endif
#define SCB_CFSR (*(volatile uint32_t *)0xe000ed28u)

extern uint32_t _stack_top, _data_load, _data_start, _data_end, _bss_start, _bss_end;

static wdr_fw fw; /* every buffer of the firmware, sized at compile time */

int main(void);
void wdr_reset_handler(void);
void wdr_fault_note(const uint32_t *frame);
void wdr_nmi_note(const uint32_t *frame);

static void wdr_default_handler(void)
{
    for (;;) {
    } /* an unexpected exception parks here; the watchdog resets the board */
}

/* The exception frame the core stacked (on MSP or PSP, as EXC_RETURN bit 2 says) goes to a C
 * function: its word 6 is the PC that faulted (or that was running when the NMI came). */
#define FRAME_TO(fn) __asm volatile("tst lr, #4\n ite eq\n mrseq r0, msp\n mrsne r0, psp\n b " #fn)

__attribute__((naked)) static void wdr_fault_handler(void)
{
    FRAME_TO(wdr_fault_note);
}

__attribute__((naked)) static void wdr_nmi_handler(void)
{
    FRAME_TO(wdr_nmi_note);
}

/* HardFault, MemManage, BusFault, UsageFault: note the cause, the faulting PC and the CFSR,
 * then wait; nothing feeds the watchdog any more, which resets the board. */
__attribute__((used)) void wdr_fault_note(const uint32_t *frame)
{
    NOTE_RESET(WDR_RESET_FAULT, frame[6], SCB_CFSR);
    wdr_default_handler();
}

/* The watchdog's early warning (its first expiry): the board is hung, the reset follows at the
 * second. A fault's note stays (its handler is the loop that stopped the feeding). */
__attribute__((used)) void wdr_nmi_note(const uint32_t *frame)
{
    if (!NOTED_FAULT())
        NOTE_RESET(WDR_RESET_WATCHDOG, frame[6], 0);
}

/* Initial stack pointer, reset, then the Cortex-M exceptions up to SysTick. */
__attribute__((section(".isr_vector"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))(uintptr_t)&_stack_top, wdr_reset_handler, wdr_nmi_handler, wdr_fault_handler,
    wdr_fault_handler, wdr_fault_handler, wdr_fault_handler, 0, 0, 0, 0,
    wdr_default_handler, wdr_default_handler, 0, wdr_default_handler, wdr_default_handler,
};

void wdr_reset_handler(void)
{
    memcpy(&_data_start, &_data_load, (size_t)((uint8_t *)&_data_end - (uint8_t *)&_data_start));
    memset(&_bss_start, 0, (size_t)((uint8_t *)&_bss_end - (uint8_t *)&_bss_start));
    /* The vector table is this image's wherever it was loaded (the bootloader sets VTOR too;
     * a debugger loading the ELF directly does not). */
    *(volatile uint32_t *)0xE000ED08u = (uint32_t)(uintptr_t)vectors;
    /* CP10/CP11 full access: the correction kernel uses the FPU. */
    *(volatile uint32_t *)0xE000ED88u |= 0xFu << 20;
    __asm volatile("dsb\n isb");
    main();
    wdr_default_handler();
}

int main(void)
{
    if (hal_init())
        wdr_default_handler();
    wdr_fw_init(&fw); /* without tables or flash it still answers INFO and STATUS */
    /* wdr_fw_task feeds the watchdog; hal_wait_for_event too, where it polls */
    for (;;)
        if (!wdr_fw_task(&fw))
            hal_wait_for_event();
}
