/* The test board: every hal.h function over plain memory (see fake_hal.h). */
#include "fake_hal.h"
#include "hal.h"
#include "hal_event_ring.h"
#include "nor_emul.h"
#include "wdr_boot.h"
#include "wdr_fw_config.h"
#include "wdr_proto.h"
#include <assert.h>
#include <string.h>

#define FIFO_SIZE (1u << 21)

typedef struct fifo {
    uint8_t buf[FIFO_SIZE];
    size_t head, tail; /* linear: reset when drained */
} fifo;

static struct {
    uint8_t flash[FB_BLOCK_SIZE * FB_BLOCK_COUNT];
    uint8_t programmed[FB_BLOCK_SIZE * FB_BLOCK_COUNT / FB_PROG_SIZE];
    nor_emul nor;     /* the one NOR emulator (hal/sim/nor_emul.h) */
    uint64_t ops_at_boot; /* nor.ops at the last power-on: the test API counts from there */
    hal_event_ring events;
    uint64_t now, timer_at, ramp_end;
    int timer_armed, ramp_playing, tx_busy, row, fail_row;
    uint64_t ramp_ticks;
    double amps;
    fifo to_board, to_host;
    uint8_t img[FB_IMG_BLOCK_SIZE * FB_IMG_BLOCK_COUNT];
    uint8_t img_programmed[FB_IMG_BLOCK_SIZE * FB_IMG_BLOCK_COUNT / FB_IMG_PROG_SIZE];
    nor_emul img_nor;
    int img_absent, has_record, resets, last_cause;
    long feeds, tx_total, tx_at_reset;
    uint32_t boots;
    wdr_boot_record record;
} fb;

/* ---- Test API ------------------------------------------------------------------------------- */

void fb_power_cycle(void)
{
    fb.ops_at_boot = fb.nor.ops;
    nor_emul_derive_programmed(&fb.nor); /* tests write fb_flash() directly between boots */
    nor_emul_cut_power_at(&fb.nor, 0, NOR_TEAR_NONE);
    nor_emul_fail_at(&fb.nor, 0);
    nor_emul_reboot(&fb.nor);
    nor_emul_derive_programmed(&fb.img_nor);
    nor_emul_reboot(&fb.img_nor);
    fb.has_record = 0;
    hal_event_ring_reset(&fb.events);
    fb.now = fb.timer_at = fb.ramp_end = 0;
    fb.timer_armed = fb.ramp_playing = fb.tx_busy = 0;
    fb.row = fb.fail_row = -1;
    fb.to_board.head = fb.to_board.tail = fb.to_host.head = fb.to_host.tail = 0;
}

void fb_init(void)
{
    const hal_flash_geometry g = {FB_BLOCK_SIZE, FB_BLOCK_COUNT, FB_PROG_SIZE};
    const hal_flash_geometry ig = {FB_IMG_BLOCK_SIZE, FB_IMG_BLOCK_COUNT, FB_IMG_PROG_SIZE};
    nor_emul_init(&fb.nor, &g, fb.flash, fb.programmed);
    nor_emul_init(&fb.img_nor, &ig, fb.img, fb.img_programmed);
    fb.amps = 0;
    fb.img_absent = fb.resets = 0;
    fb.last_cause = -1;
    fb.feeds = 0;
    fb.boots = 0;
    fb_power_cycle();
}

/* op counts from this power-on, 0-based; the emulator's numbers are absolute and 1-based. */
void fb_cut_power_at(long op, int torn)
{
    fb_cut_power_tear(op, torn ? NOR_TEAR_FIRST_HALF : NOR_TEAR_NONE);
}

void fb_cut_power_tear(long op, int tear)
{
    nor_emul_cut_power_at(&fb.nor, op < 0 ? 0 : fb.ops_at_boot + (uint64_t)op + 1, tear);
}

void fb_fail_flash_at(long op) { nor_emul_fail_at(&fb.nor, op < 0 ? 0 : fb.ops_at_boot + (uint64_t)op + 1); }

long fb_flash_ops(void) { return (long)(fb.nor.ops - fb.ops_at_boot); }
int fb_power_lost(void) { return fb.nor.power_lost; }
uint8_t *fb_flash(void) { return fb.flash; }
double fb_illuminant(void) { return fb.amps; }
uint64_t fb_ramp_ticks(void) { return fb.ramp_ticks; }
void fb_fail_adc_row(int row) { fb.fail_row = row; }
int fb_scheduled(void) { return fb.timer_armed || fb.ramp_playing; }

uint16_t fb_pattern(int row, int col) { return (uint16_t)((row * 83 + col * 29 + 5) & 0xfff); }

static void fifo_put(fifo *f, const void *p, size_t n)
{
    assert(f->tail + n <= FIFO_SIZE);
    memcpy(f->buf + f->tail, p, n);
    f->tail += n;
}

static size_t fifo_get(fifo *f, uint8_t *p, size_t cap)
{
    size_t n = f->tail - f->head < cap ? f->tail - f->head : cap;
    memcpy(p, f->buf + f->head, n);
    f->head += n;
    if (f->head == f->tail)
        f->head = f->tail = 0;
    return n;
}

void fb_host_write(const void *bytes, size_t n) { fifo_put(&fb.to_board, bytes, n); }
size_t fb_host_read(uint8_t *buf, size_t cap) { return fifo_get(&fb.to_host, buf, cap); }

/* ---- Events and time ------------------------------------------------------------------------- */

static void post(uint8_t type)
{
    int posted = hal_event_ring_post(&fb.events, type, 0);
    assert(posted); /* the tests never let events pile up: a full ring is a test bug */
    (void)posted;
}

/* Post what is due at the current time. */
static void fire_due(void)
{
    if (fb.ramp_playing && fb.now >= fb.ramp_end) {
        fb.ramp_playing = 0;
        post(HAL_EV_RAMP_DONE);
    }
    if (fb.timer_armed && fb.now >= fb.timer_at) {
        fb.timer_armed = 0;
        post(HAL_EV_TIMER);
    }
}

int hal_init(void) { return WDR_OK; }

int hal_event_poll(hal_event *ev)
{
    fire_due();
    if (!hal_event_ring_take(&fb.events, ev))
        return 0;
    if (ev->type == HAL_EV_USB_TX_DONE)
        fb.tx_busy = 0;
    return 1;
}

/* Jump virtual time to the next scheduled happening. */
void hal_wait_for_event(void)
{
    uint64_t next = UINT64_MAX;
    if (fb.ramp_playing)
        next = fb.ramp_end;
    if (fb.timer_armed && fb.timer_at < next)
        next = fb.timer_at;
    if (next != UINT64_MAX && next > fb.now)
        fb.now = next;
    fire_due();
}

uint64_t hal_time_ns(void) { return fb.now; }
void hal_delay_ns(uint32_t ns) { fb.now += ns; }

void hal_timer_arm(uint64_t deadline_ns)
{
    fb.timer_at = deadline_ns;
    fb.timer_armed = 1;
}

/* ---- Board and sensor ------------------------------------------------------------------------- */

int hal_board_info_get(hal_board_info *out)
{
    memset(out, 0, sizeof *out);
    out->sensor_id = FB_SENSOR_ID;
    out->width = FB_WIDTH;
    out->height = FB_HEIGHT;
    out->adc_bits = FB_ADC_BITS;
    out->dac_bits = FB_DAC_BITS;
    out->row_time_ns = FB_ROW_TIME_NS;
    out->caps = HAL_CAP_ILLUMINANT;
    strcpy(out->name, FB_BOARD_NAME);
    return WDR_OK;
}

int hal_pixel_reset(bool asserted)
{
    (void)asserted;
    return WDR_OK;
}

int hal_row_select(uint16_t row)
{
    if (row >= FB_HEIGHT)
        return WDR_E_INVAL;
    fb.row = row;
    return WDR_OK;
}

void hal_row_deselect(void) { fb.row = -1; }

int hal_adc_convert(void)
{
    if (fb.row < 0)
        return WDR_E_INVAL;
    return fb.ramp_playing ? WDR_E_BUSY : WDR_OK;
}

int hal_adc_read_row(uint16_t *codes, size_t n)
{
    if (n != FB_WIDTH || fb.row < 0)
        return WDR_E_INVAL;
    if (fb.row == fb.fail_row)
        return WDR_E_IO;
    for (size_t c = 0; c < n; c++)
        codes[c] = fb_pattern(fb.row, (int)c);
    return WDR_OK;
}

int hal_ramp_start(const wdr_lut_view *lut)
{
    if (fb.ramp_playing)
        return WDR_E_BUSY;
    if (lut->h.dac_bits != FB_DAC_BITS)
        return WDR_E_GEOMETRY;
    fb.ramp_ticks = lut->h.t_integration_ticks;
    fb.ramp_end = fb.now + wdr_lut_ticks_ps(lut, lut->h.t_integration_ticks) / 1000u;
    fb.ramp_playing = 1;
    return WDR_OK;
}

void hal_ramp_stop(void) { fb.ramp_playing = 0; }

int hal_set_illuminant(double amps)
{
    if (!(amps >= 0.0) || amps > 1.0)
        return WDR_E_INVAL;
    fb.amps = amps;
    return WDR_OK;
}

/* The fake board has no scene: back to its start (0 A, as fb_illuminant reports). */
int hal_restore_scene(void)
{
    fb.amps = 0;
    return WDR_OK;
}

/* ---- Flash: the NOR emulator of hal/sim, with its power-cut counter ----------------------------------------------- */

int hal_flash_geometry_get(hal_flash_geometry *g)
{
    g->block_size = FB_BLOCK_SIZE;
    g->block_count = FB_BLOCK_COUNT;
    g->prog_size = FB_PROG_SIZE;
    return WDR_OK;
}

int hal_flash_read(uint32_t addr, void *buf, uint32_t len) { return nor_emul_read(&fb.nor, addr, buf, len); }
int hal_flash_erase(uint32_t block) { return nor_emul_erase(&fb.nor, block); }
int hal_flash_prog(uint32_t addr, const void *buf, uint32_t len) { return nor_emul_prog(&fb.nor, addr, buf, len); }

/* ---- USB ----------------------------------------------------------------------------------------- */

size_t hal_usb_max_transfer(void) { return WDR_PROTO_MAX_FRAME; }

int hal_usb_read(uint8_t *buf, size_t cap) { return (int)fifo_get(&fb.to_board, buf, cap); }

int hal_usb_write(const uint8_t *buf, size_t len)
{
    if (fb.tx_busy)
        return WDR_E_BUSY;
    if (len > WDR_PROTO_MAX_FRAME)
        return WDR_E_TOO_LARGE;
    fifo_put(&fb.to_host, buf, len);
    fb.tx_total += (long)len;
    fb.tx_busy = 1;
    post(HAL_EV_USB_TX_DONE);
    return WDR_OK;
}

/* ---- Image flash, boot record, reset, watchdog ------------------------------------------------------ */

uint8_t *fb_image_flash(void) { return fb.img; }
void fb_set_image_flash(int present) { fb.img_absent = !present; }
int fb_resets(void) { return fb.resets; }
int fb_last_reset_cause(void) { return fb.last_cause; }
long fb_watchdog_feeds(void) { return fb.feeds; }
long fb_tx_bytes(void) { return fb.tx_total; }
long fb_tx_bytes_at_reset(void) { return fb.tx_at_reset; }

void fb_set_boot_record(const wdr_boot_record *r)
{
    fb.has_record = r != NULL;
    if (r)
        fb.record = *r;
}

static int img_read(void *ctx, uint32_t addr, void *buf, uint32_t len)
{
    return nor_emul_read(ctx, addr, buf, len);
}
static int img_erase(void *ctx, uint32_t block) { return nor_emul_erase(ctx, block); }
static int img_prog(void *ctx, uint32_t addr, const void *buf, uint32_t len)
{
    return nor_emul_prog(ctx, addr, buf, len);
}

int fb_boot(uint8_t cause)
{
    wdr_boot_flash f = {fb.img_nor.g, &fb.img_nor, img_read, img_erase, img_prog};
    wdr_boot_layout l;
    wdr_boot_decision d;
    wdr_boot_policy pol = {FB_BOARD_NAME, wdr_boot_key(), WDR_FW_IMAGE_LOAD_LO, WDR_FW_IMAGE_LOAD_HI, true};
    fb.has_record = 0;
    if (wdr_boot_layout_init(&l, &f.geo) || wdr_boot_decide(&f, &l, &pol, &d) || d.slot < 0)
        return -1;
    wdr_boot_record r;
    memset(&r, 0, sizeof r);
    r.magic = WDR_BOOT_RECORD_MAGIC_RAM;
    r.slot = (uint8_t)d.slot;
    r.testing = d.testing;
    r.attempts = d.slots[d.slot].attempts;
    r.reset_cause = cause;
    r.boots = ++fb.boots;
    r.floor = d.floor;
    r.hdr = d.slots[d.slot].hdr;
    wdr_boot_record_seal(&r);
    fb_set_boot_record(&r);
    return d.slot;
}

int hal_image_flash_geometry_get(hal_flash_geometry *g)
{
    if (fb.img_absent)
        return WDR_E_UNSUPPORTED;
    *g = fb.img_nor.g;
    return WDR_OK;
}

int hal_image_flash_read(uint32_t addr, void *buf, uint32_t len)
{
    return fb.img_absent ? WDR_E_UNSUPPORTED : nor_emul_read(&fb.img_nor, addr, buf, len);
}

int hal_image_flash_erase(uint32_t block)
{
    return fb.img_absent ? WDR_E_UNSUPPORTED : nor_emul_erase(&fb.img_nor, block);
}

int hal_image_flash_prog(uint32_t addr, const void *buf, uint32_t len)
{
    return fb.img_absent ? WDR_E_UNSUPPORTED : nor_emul_prog(&fb.img_nor, addr, buf, len);
}

int hal_boot_record_get(struct wdr_boot_record *out)
{
    if (!fb.has_record || !wdr_boot_record_ok(&fb.record))
        return WDR_E_UNSUPPORTED;
    *out = fb.record;
    return WDR_OK;
}

/* A test reboots the board itself (fb_power_cycle, fb_boot, th_boot): count and remember. */
void hal_reset(uint8_t cause)
{
    fb.resets++;
    fb.last_cause = cause;
    fb.tx_at_reset = fb.tx_total;
}

void hal_watchdog_feed(void) { fb.feeds++; }
