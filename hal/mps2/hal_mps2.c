/* hal/hal.h on the Arm MPS2 AN500 board (Cortex-M7; QEMU's mps2-an500): the wire protocol over
 * CMSDK UART0, time from CMSDK timer 0, table flash as a PSRAM region kept to NOR rules, and the
 * sensor as a replay of raw ADC frames that the test put in PSRAM (the boot chain's part, image
 * flash, boot record, reset and watchdog: hal_mps2_boot.c). Bare metal: registers,
 * static state, nothing else. Everything is polled; hal_event_poll turns what the registers show
 * into queued events, as interrupt handlers would. */
#include "hal.h"
#include "psram_nor.h"
#include "hal_event_ring.h"
#include "hal_mps2_internal.h"
#include "mps2_board.h"
#include "wdr_proto.h"
#include <string.h>

#define REG(addr) (*(volatile uint32_t *)(uintptr_t)(addr))
#define UART_DATA REG(MPS2_UART0_BASE + 0x0u)
#define UART_STATE REG(MPS2_UART0_BASE + 0x4u)
#define UART_CTRL REG(MPS2_UART0_BASE + 0x8u)
#define UART_BAUDDIV REG(MPS2_UART0_BASE + 0x10u)
#define UART_TX_FULL 0x1u
#define UART_RX_FULL 0x2u
#define TIMER_CTRL REG(MPS2_TIMER0_BASE + 0x0u)
#define TIMER_VALUE REG(MPS2_TIMER0_BASE + 0x4u)
#define TIMER_RELOAD REG(MPS2_TIMER0_BASE + 0x8u)
#define NS_PER_TICK (1000000000u / MPS2_SYSCLK_HZ)

#define REPLAY_MAGIC 0x4c505257u /* "WRPL" */
#define FLASH_MARK_VALUE 0x464c5348u
#define FLASH_BYTES (MPS2_FLASH_BLOCK * MPS2_FLASH_BLOCKS)

/* The replay file's header (little-endian, as the test writes it; SPEC: boards/mps2-an500/README.md). */
typedef struct replay_header {
    uint32_t magic;
    uint16_t width, height;
    uint32_t frames;
    uint32_t reserved;
} replay_header;

static struct {
    uint64_t now_ticks; /* 64-bit time, from the 32-bit down counter */
    uint32_t last_value;
    uint64_t timer_deadline, ramp_deadline; /* ns; 0: none */
    bool timer_armed, ramp_playing, reset_asserted, rx_posted, converted;
    int row;        /* selected row, -1: none */
    uint32_t frame; /* replay frame being exposed */
    replay_header replay;
} hal;

/* ---- Event queue ----------------------------------------------------------------------- */

static hal_event_ring events;

static void evq_post(uint8_t type, uint32_t arg) { hal_event_ring_post(&events, type, arg); }

/* What interrupts would post: bytes waiting, a deadline passed, the ramp done. */
static void poll_sources(void)
{
    uint64_t now = hal_time_ns();
    if ((UART_STATE & UART_RX_FULL) && !hal.rx_posted) {
        hal.rx_posted = true;
        evq_post(HAL_EV_USB_RX, 0);
    }
    if (hal.timer_armed && now >= hal.timer_deadline) {
        hal.timer_armed = false;
        evq_post(HAL_EV_TIMER, 0);
    }
    if (hal.ramp_playing && now >= hal.ramp_deadline) {
        hal.ramp_playing = false;
        evq_post(HAL_EV_RAMP_DONE, 0);
    }
}

int hal_event_poll(hal_event *ev)
{
    poll_sources();
    return hal_event_ring_take(&events, ev);
}

/* Waiting for the host is not a hang: the idle loop feeds the watchdog (a loop anywhere else,
 * or a fault, does not). */
void hal_wait_for_event(void)
{
    while (hal_event_ring_empty(&events)) {
        hal_watchdog_feed();
        poll_sources();
    }
}

/* ---- Time -------------------------------------------------------------------------------- */

uint64_t hal_time_ns(void)
{
    uint32_t v = TIMER_VALUE; /* counts down; wraps every 171 s, far longer than any wait here */
    hal.now_ticks += hal.last_value - v;
    hal.last_value = v;
    return hal.now_ticks * NS_PER_TICK;
}

void hal_delay_ns(uint32_t ns)
{
    uint64_t end = hal_time_ns() + ns;
    while (hal_time_ns() < end) {
    }
}

void hal_timer_arm(uint64_t deadline_ns)
{
    hal.timer_deadline = deadline_ns;
    hal.timer_armed = true;
}

/* ---- Board, flash format ------------------------------------------------------------------ */

static const replay_header *replay(void)
{
    return (const replay_header *)(uintptr_t)MPS2_REPLAY_BASE;
}

/* A fresh part reads 0xFF; PSRAM starts at zero, so erase it once and leave a mark that
 * survives a firmware reset (the test's reboots keep PSRAM). */
static void flash_factory(void)
{
    if (REG(MPS2_FLASH_MARK) == FLASH_MARK_VALUE)
        return;
    memset((void *)(uintptr_t)MPS2_FLASH_BASE, 0xff, FLASH_BYTES);
    REG(MPS2_FLASH_MARK) = FLASH_MARK_VALUE;
}

int hal_init(void)
{
    memset(&hal, 0, sizeof hal);
    hal.row = -1;
    TIMER_CTRL = 0;
    TIMER_RELOAD = 0xffffffffu;
    TIMER_VALUE = 0xffffffffu;
    TIMER_CTRL = 1u; /* enable, no interrupt */
    hal.last_value = TIMER_VALUE;
    UART_BAUDDIV = MPS2_UART_BAUDDIV;
    UART_CTRL = 0x3u; /* TX and RX enabled */
    flash_factory();
    hal_mps2_watchdog_start();
    hal.replay = *replay();
    if (hal.replay.magic != REPLAY_MAGIC || hal.replay.width == 0 || hal.replay.height == 0 || hal.replay.frames == 0 ||
        (uint64_t)hal.replay.frames * hal.replay.height * hal.replay.width * 2u + sizeof(replay_header) >
            MPS2_REPLAY_MAX)
        memset(&hal.replay, 0, sizeof hal.replay); /* no sensor: INFO and STATUS still answer */
    return WDR_OK;
}

int hal_board_info_get(hal_board_info *out)
{
    memset(out, 0, sizeof *out);
    out->sensor_id = MPS2_SENSOR_ID;
    out->width = hal.replay.width;
    out->height = hal.replay.height;
    out->adc_bits = MPS2_ADC_BITS;
    out->dac_bits = MPS2_DAC_BITS;
    out->row_time_ns = MPS2_ROW_TIME_NS;
    memcpy(out->name, "mps2-an500", sizeof "mps2-an500");
    return out->width ? WDR_OK : WDR_E_IO;
}

/* ---- Sensor: replayed frames ----------------------------------------------------------------- */

int hal_pixel_reset(bool asserted)
{
    if (hal.reset_asserted && !asserted && hal.replay.frames) /* a new exposure: the next frame */
        hal.frame = (hal.frame + 1u) % hal.replay.frames;
    hal.reset_asserted = asserted;
    return WDR_OK;
}

int hal_row_select(uint16_t row)
{
    if (row >= hal.replay.height)
        return WDR_E_INVAL;
    hal.row = row;
    hal.converted = false;
    return WDR_OK;
}

void hal_row_deselect(void)
{
    hal.row = -1;
}

int hal_adc_convert(void)
{
    if (hal.row < 0)
        return WDR_E_INVAL;
    if (hal.ramp_playing)
        return WDR_E_BUSY;
    hal.converted = true;
    return WDR_OK;
}

int hal_adc_read_row(uint16_t *codes, size_t n)
{
    if (n != hal.replay.width || !hal.converted || hal.row < 0)
        return WDR_E_INVAL;
    size_t first = ((size_t)hal.frame * hal.replay.height + (size_t)hal.row) * n;
    memcpy(codes, (const uint8_t *)(replay() + 1) + first * 2u, n * 2u);
    return WDR_OK;
}

/* ---- Ramp: no DAC on this board; the ramp takes its integration time ------------------------- */

int hal_ramp_start(const wdr_lut_view *lut)
{
    if (!lut)
        return WDR_E_INVAL;
    if (hal.ramp_playing)
        return WDR_E_BUSY;
    if (lut->h.dac_bits != MPS2_DAC_BITS)
        return WDR_E_GEOMETRY;
    hal.ramp_deadline = hal_time_ns() + wdr_lut_ticks_ps(lut, lut->h.t_integration_ticks) / 1000u;
    hal.ramp_playing = true;
    return WDR_OK;
}

void hal_ramp_stop(void)
{
    hal.ramp_playing = false;
}

/* ---- Flash: PSRAM with NOR rules ---------------------------------------------------------------- */

static const psram_nor table_flash = {MPS2_FLASH_BASE, {MPS2_FLASH_BLOCK, MPS2_FLASH_BLOCKS, MPS2_FLASH_PROG}};

int hal_flash_geometry_get(hal_flash_geometry *g)
{
    *g = table_flash.geo;
    return WDR_OK;
}

int hal_flash_read(uint32_t addr, void *buf, uint32_t len)
{
    return psram_nor_read(&table_flash, addr, buf, len);
}

int hal_flash_erase(uint32_t block)
{
    return psram_nor_erase(&table_flash, block);
}

int hal_flash_prog(uint32_t addr, const void *buf, uint32_t len)
{
    return psram_nor_prog(&table_flash, addr, buf, len);
}

/* ---- The host link: UART0 in place of the bulk endpoints ------------------------------------------ */

size_t hal_usb_max_transfer(void)
{
    return WDR_PROTO_MAX_FRAME;
}

int hal_usb_read(uint8_t *buf, size_t cap)
{
    size_t n = 0;
    while (n < cap && (UART_STATE & UART_RX_FULL))
        buf[n++] = (uint8_t)UART_DATA;
    hal.rx_posted = false;
    return (int)n;
}

/* Blocking: the UART takes a byte at a time; the transfer is done when the last is in. */
int hal_usb_write(const uint8_t *buf, size_t len)
{
    if (len > hal_usb_max_transfer())
        return WDR_E_TOO_LARGE;
    for (size_t i = 0; i < len; i++) {
        while (UART_STATE & UART_TX_FULL) {
        }
        UART_DATA = buf[i];
    }
    evq_post(HAL_EV_USB_TX_DONE, 0);
    return WDR_OK;
}

int hal_set_illuminant(double amps)
{
    (void)amps;
    return WDR_E_UNSUPPORTED;
}

int hal_restore_scene(void) { return WDR_E_UNSUPPORTED; }
