/* Template backend: the shape of a port to a new board. It compiles and links (the ARM build
 * uses it), answers every question honestly and drives nothing: replace each body with the
 * board's register work. The event queue below is the part a real port keeps. */
#include "hal.h"
#include "hal_event_ring.h"
#include <string.h>

/* ---- Event queue: interrupt handlers post, the task loop polls ------------------------ */


static hal_event_ring events;

/* Called from interrupt context; an event that finds the queue full is dropped, which the
 * firmware survives because every event is also visible as state (FIFO level, flags). */
static void evq_post(uint8_t type, uint32_t arg) { hal_event_ring_post(&events, type, arg); }

int hal_event_poll(hal_event *ev)
{
    return hal_event_ring_take(&events, ev);
}

void hal_wait_for_event(void)
{
    /* A port executes WFI here, with interrupts that call evq_post. */
}

/* ---- Board identity ------------------------------------------------------------------- */

int hal_init(void)
{
    hal_event_ring_reset(&events);
    return WDR_OK;
}

int hal_board_info_get(hal_board_info *out)
{
    memset(out, 0, sizeof *out);
    out->sensor_id = 0;
    out->width = 640;
    out->height = 480;
    out->adc_bits = 12;
    out->dac_bits = 12;
    out->row_time_ns = 20000;
    memcpy(out->name, "template", sizeof "template");
    return WDR_OK;
}

/* ---- Time ------------------------------------------------------------------------------ */

static uint64_t now_ns;

uint64_t hal_time_ns(void) { return now_ns; }

void hal_delay_ns(uint32_t ns) { now_ns += ns; }

void hal_timer_arm(uint64_t deadline_ns)
{
    /* A port programs a compare channel; its interrupt posts HAL_EV_TIMER. */
    if (deadline_ns <= now_ns)
        evq_post(HAL_EV_TIMER, 0);
}

/* ---- Sensor control lines --------------------------------------------------------------- */

static int selected_row = -1;

int hal_pixel_reset(bool asserted)
{
    (void)asserted;
    return WDR_OK;
}

int hal_row_select(uint16_t row)
{
    if (row >= 480)
        return WDR_E_INVAL;
    selected_row = row;
    return WDR_OK;
}

void hal_row_deselect(void) { selected_row = -1; }

int hal_adc_convert(void) { return selected_row < 0 ? WDR_E_INVAL : WDR_OK; }

int hal_adc_read_row(uint16_t *codes, size_t n)
{
    if (n != 640)
        return WDR_E_INVAL;
    memset(codes, 0, n * sizeof *codes);
    return WDR_OK;
}

/* ---- Ramp DAC ----------------------------------------------------------------------------- */

int hal_ramp_start(const wdr_lut_view *lut)
{
    if (lut->h.dac_bits != 12)
        return WDR_E_GEOMETRY;
    evq_post(HAL_EV_RAMP_DONE, 0); /* a port posts this from the DMA-complete interrupt */
    return WDR_OK;
}

void hal_ramp_stop(void) {}

/* ---- Flash: none on the template board --------------------------------------------------- */

int hal_flash_geometry_get(hal_flash_geometry *g)
{
    g->block_size = 4096;
    g->block_count = 0;
    g->prog_size = 16;
    return WDR_OK;
}

int hal_flash_read(uint32_t addr, void *buf, uint32_t len)
{
    (void)addr, (void)buf, (void)len;
    return WDR_E_INVAL;
}

int hal_flash_erase(uint32_t block)
{
    (void)block;
    return WDR_E_INVAL;
}

int hal_flash_prog(uint32_t addr, const void *buf, uint32_t len)
{
    (void)addr, (void)buf, (void)len;
    return WDR_E_INVAL;
}

/* ---- USB: never connected ------------------------------------------------------------------ */

size_t hal_usb_max_transfer(void) { return 8192; }

int hal_usb_read(uint8_t *buf, size_t cap)
{
    (void)buf, (void)cap;
    return 0;
}

int hal_usb_write(const uint8_t *buf, size_t len)
{
    (void)buf, (void)len;
    return WDR_E_IO;
}

/* ---- Simulation hooks ------------------------------------------------------------------------ */

int hal_set_illuminant(double amps)
{
    (void)amps;
    return WDR_E_UNSUPPORTED;
}

int hal_restore_scene(void) { return WDR_E_UNSUPPORTED; }
/* ---- Firmware images, boot record, reset, watchdog: no bootloader on the template board ------ */

int hal_image_flash_geometry_get(hal_flash_geometry *g)
{
    memset(g, 0, sizeof *g);
    return WDR_E_UNSUPPORTED;
}

int hal_image_flash_read(uint32_t addr, void *buf, uint32_t len)
{
    (void)addr, (void)buf, (void)len;
    return WDR_E_UNSUPPORTED;
}

int hal_image_flash_erase(uint32_t block)
{
    (void)block;
    return WDR_E_UNSUPPORTED;
}

int hal_image_flash_prog(uint32_t addr, const void *buf, uint32_t len)
{
    (void)addr, (void)buf, (void)len;
    return WDR_E_UNSUPPORTED;
}

int hal_boot_record_get(struct wdr_boot_record *out)
{
    (void)out;
    return WDR_E_UNSUPPORTED;
}

/* A port writes the cause where its bootloader finds it, then asks the core for a system reset
 * (SCB->AIRCR = 0x05FA0004); the template has neither, so it parks like a real reset would stop
 * the program. */
void hal_reset(uint8_t cause)
{
    (void)cause;
    for (;;) {
    }
}

void hal_watchdog_feed(void) {}
