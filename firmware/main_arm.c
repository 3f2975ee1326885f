/* Cortex-M7 entry: vector table, C runtime start, and the firmware's task loop.
 * Only built by the cortex-m7 preset, linked with whichever HAL backend the board uses
 * (hal/template for the footprint build). */
#include "wdr_fw.h"
#include <stdint.h>
#include <string.h>

extern uint32_t _stack_top, _data_load, _data_start, _data_end, _bss_start, _bss_end;

static wdr_fw fw; /* every buffer of the firmware, sized at compile time */

int main(void);
void wdr_reset_handler(void);

static void wdr_default_handler(void)
{
    for (;;) {
    } /* an unexpected fault parks here for the debugger */
}

/* Initial stack pointer, reset, then the Cortex-M exceptions up to SysTick. */
__attribute__((section(".isr_vector"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))(uintptr_t)&_stack_top, wdr_reset_handler, wdr_default_handler, wdr_default_handler,
    wdr_default_handler, wdr_default_handler, wdr_default_handler, 0, 0, 0, 0,
    wdr_default_handler, wdr_default_handler, 0, wdr_default_handler, wdr_default_handler,
};

void wdr_reset_handler(void)
{
    memcpy(&_data_start, &_data_load, (size_t)((uint8_t *)&_data_end - (uint8_t *)&_data_start));
    memset(&_bss_start, 0, (size_t)((uint8_t *)&_bss_end - (uint8_t *)&_bss_start));
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
    for (;;)
        if (!wdr_fw_task(&fw))
            hal_wait_for_event();
}
