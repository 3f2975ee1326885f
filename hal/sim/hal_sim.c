/* Simulated board, core: virtual time, the event queue, the sensor control lines, ramp
 * playback and the column ADC, all on top of the pixel-array simulator (sim/wdr_sim.h).
 * The CPU is infinitely fast: only waits move the clock, and a wait with nothing scheduled
 * blocks on the USB socket in real time instead of spinning. */
#include "hal_sim_internal.h"
#include "wdr_sim.h"
#include "hal_event_ring.h"
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define IDLE_POLL_MS 100 /* real-time slice of an idle wait; bounds the reaction to a stop */
#define NEVER UINT64_MAX

static struct {
    int ready;
    wdr_board board;
    wdr_sim *sensor;
    uint64_t frame_seed;
    uint64_t now_ns;
    uint64_t frames;

    hal_event_ring events;

    uint64_t timer_at;     /* NEVER when disarmed */
    uint64_t ramp_done_at; /* NEVER when no ramp plays */
    uint64_t integration_end_ns;
    int exposed;           /* hold nodes carry a frame */
    int reset_asserted;

    int row_selected;      /* -1: none */
    int converted;         /* adc_row holds a conversion */
    uint16_t *adc_row;

    /* The scene behind a uniform illuminant, kept so that hal_restore_scene can put it back. */
    int scene_saved;
    float *scene_amps;     /* NULL: the scene itself was uniform, at scene_uniform */
    double scene_uniform;
} B;

static atomic_int stop_flag;
int hal_sim_exit_on_disconnect;
int hal_sim_eof_fd = -1;

/* ---- Events and virtual time ------------------------------------------------------------ */

void hal_sim_post(uint8_t type, uint32_t arg)
{
    hal_event_ring_post(&B.events, type, arg);
}

static uint64_t splitmix64(uint64_t x)
{
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

/* The ramp reached t_integration: every pixel has crossed and holds its value. */
static void finish_integration(void)
{
    B.integration_end_ns = B.ramp_done_at;
    B.ramp_done_at = NEVER;
    B.exposed = wdr_sim_expose(B.sensor, splitmix64(B.frame_seed ^ splitmix64(B.frames))) == WDR_OK;
    B.frames++;
    hal_sim_post(HAL_EV_RAMP_DONE, 0);
}

/* Post everything scheduled at or before now, in time order. */
static void fire_due(void)
{
    int ramp_first = B.ramp_done_at <= B.timer_at;
    if (ramp_first && B.ramp_done_at <= B.now_ns)
        finish_integration();
    if (B.timer_at <= B.now_ns) {
        B.timer_at = NEVER;
        hal_sim_post(HAL_EV_TIMER, 0);
    }
    if (B.ramp_done_at <= B.now_ns)
        finish_integration();
}

static uint64_t next_scheduled(void) { return B.ramp_done_at < B.timer_at ? B.ramp_done_at : B.timer_at; }

static int queue_empty(void) { return hal_event_ring_empty(&B.events); }

int hal_event_poll(hal_event *ev)
{
    fire_due();
    if (queue_empty())
        hal_sim_usb_pump(0);
    if (queue_empty())
        return 0;
    return hal_event_ring_take(&B.events, ev);
}

/* Host I/O first (it happens "now"), then jump the clock to the next scheduled happening;
 * with nothing scheduled, block on the socket a slice at a time until something arrives. */
void hal_wait_for_event(void)
{
    while (!atomic_load(&stop_flag)) {
        fire_due();
        hal_sim_usb_pump(0);
        if (!queue_empty())
            return;
        if (!hal_sim_usb_tx_pending() && next_scheduled() != NEVER) {
            B.now_ns = next_scheduled();
            continue;
        }
        hal_sim_usb_pump(IDLE_POLL_MS);
        if (!queue_empty())
            return;
    }
}

uint64_t hal_time_ns(void) { return B.now_ns; }

void hal_delay_ns(uint32_t ns) { B.now_ns += ns; }

void hal_timer_arm(uint64_t deadline_ns) { B.timer_at = deadline_ns; }

/* ---- Identity ---------------------------------------------------------------------------- */

int hal_init(void)
{
    if (!B.ready)
        return WDR_E_IO; /* hal_sim_setup was not called: no board to bring up */
    hal_sim_reboot();
    hal_sim_boot_run(); /* the bootloader runs before the application's first instruction */
    return WDR_OK;
}

int hal_board_info_get(hal_board_info *out)
{
    memset(out, 0, sizeof *out);
    if (!B.ready)
        return WDR_E_IO;
    out->sensor_id = B.board.sensor_id;
    out->width = B.board.width;
    out->height = B.board.height;
    out->adc_bits = (uint8_t)B.board.adc_bits;
    out->dac_bits = (uint8_t)B.board.dac_bits;
    out->row_time_ns = (uint32_t)llround(B.board.row_time_s * 1e9);
    out->caps = hal_sim_hand_light_on() ? 0u : HAL_CAP_ILLUMINANT; /* by hand: a real board's light */
    /* Board names longer than the HAL's field are cut, as the board file allows 63 bytes. */
    memcpy(out->name, B.board.name, sizeof out->name - 1);
    out->name[sizeof out->name - 1] = 0;
    return WDR_OK;
}

/* ---- Sensor control lines and ADC --------------------------------------------------------- */

int hal_pixel_reset(bool asserted)
{
    B.reset_asserted = asserted;
    if (asserted)
        B.exposed = 0; /* reset discharges every hold path: the old frame is gone */
    return WDR_OK;
}

int hal_row_select(uint16_t row)
{
    if (row >= B.board.height)
        return WDR_E_INVAL;
    B.row_selected = row;
    return WDR_OK;
}

void hal_row_deselect(void) { B.row_selected = -1; }

/* Samples the selected row now, as many microseconds after integration as have passed, and
 * takes the board's row time to convert: that is what spreads leakage over the rows.
 * Also WDR_E_INVAL when no frame has been integrated since the last reset. */
int hal_adc_convert(void)
{
    if (B.ramp_done_at != NEVER)
        return WDR_E_BUSY;
    if (B.row_selected < 0 || !B.exposed)
        return WDR_E_INVAL;
    double t_after = (double)(B.now_ns - B.integration_end_ns) * 1e-9;
    if (wdr_sim_read_row(B.sensor, B.row_selected, t_after, B.adc_row) != WDR_OK)
        return WDR_E_IO;
    B.converted = 1;
    B.now_ns += (uint64_t)llround(B.board.row_time_s * 1e9);
    return WDR_OK;
}

int hal_adc_read_row(uint16_t *codes, size_t n)
{
    if (n != B.board.width || !B.converted)
        return WDR_E_INVAL;
    memcpy(codes, B.adc_row, n * sizeof *codes);
    return WDR_OK;
}

/* ---- Ramp DAC ------------------------------------------------------------------------------ */

int hal_ramp_start(const wdr_lut_view *lut)
{
    if (!lut || !lut->entries || lut->h.entry_count == 0)
        return WDR_E_INVAL;
    if (B.ramp_done_at != NEVER)
        return WDR_E_BUSY;
    if (lut->h.dac_bits != B.board.dac_bits)
        return WDR_E_GEOMETRY;
    if (wdr_sim_set_lut(B.sensor, lut) != WDR_OK)
        return WDR_E_INVAL;
    hal_sim_hand_light_apply(); /* what a person set before this frame */
    uint64_t t_int_ns = wdr_lut_ticks_ps(lut, lut->h.t_integration_ticks) / 1000u;
    B.exposed = 0;
    B.converted = 0;
    B.ramp_done_at = B.now_ns + t_int_ns;
    return WDR_OK;
}

void hal_ramp_stop(void) { B.ramp_done_at = NEVER; }

/* ---- Light --------------------------------------------------------------------------------- */

/* Copy what the pixels see before the first uniform light replaces it. */
static int save_scene(void)
{
    if (B.scene_saved)
        return WDR_OK;
    const float *amps = wdr_sim_photocurrent(B.sensor, &B.scene_uniform);
    if (amps) {
        size_t n = (size_t)B.board.width * B.board.height;
        if (!(B.scene_amps = malloc(n * sizeof *amps)))
            return WDR_E_NOMEM;
        memcpy(B.scene_amps, amps, n * sizeof *amps);
    }
    B.scene_saved = 1;
    return WDR_OK;
}

static void forget_scene(void)
{
    free(B.scene_amps);
    B.scene_amps = NULL;
    B.scene_saved = 0;
}

int hal_sim_light_uniform(double amps)
{
    if (!isfinite(amps) || amps < 0)
        return WDR_E_INVAL;
    int rc = save_scene();
    return rc ? rc : wdr_sim_set_uniform(B.sensor, amps);
}

int hal_set_illuminant(double amps)
{
    return hal_sim_hand_light_on() ? WDR_E_UNSUPPORTED : hal_sim_light_uniform(amps);
}

int hal_restore_scene(void)
{
    if (!B.scene_saved)
        return WDR_OK; /* no uniform light on: the scene is in place */
    int rc = B.scene_amps ? wdr_sim_set_photocurrent(B.sensor, B.scene_amps)
                          : wdr_sim_set_uniform(B.sensor, B.scene_uniform);
    if (rc == WDR_OK)
        forget_scene();
    return rc;
}

int hal_sim_set_illuminant(double amps) { return hal_sim_light_uniform(amps); }

int hal_sim_set_scene(const float *amps)
{
    if (!amps)
        return WDR_E_INVAL;
    forget_scene(); /* a new scene: nothing older to go back to */
    return wdr_sim_set_photocurrent(B.sensor, amps);
}

/* ---- Emulator control ---------------------------------------------------------------------- */

static int setup_sensor(const hal_sim_config *cfg, char *err, int errlen)
{
    B.board = *cfg->board;
    B.frame_seed = cfg->frame_seed;
    B.sensor = wdr_sim_create(&B.board, cfg->seed);
    B.adc_row = calloc(B.board.width ? B.board.width : 1, sizeof *B.adc_row);
    if (!B.sensor || !B.adc_row) {
        snprintf(err, (size_t)errlen, "no memory for a %ux%u sensor", B.board.width, B.board.height);
        return WDR_E_NOMEM;
    }
    return WDR_OK;
}

int hal_sim_setup(const hal_sim_config *cfg, char *err, int errlen)
{
    if (B.ready || !cfg || !cfg->board) {
        snprintf(err, (size_t)errlen, "hal_sim_setup: %s", B.ready ? "already set up" : "no board");
        return WDR_E_INVAL;
    }
    memset(&B, 0, sizeof B);
    int rc = setup_sensor(cfg, err, errlen);
    if (rc == WDR_OK)
        rc = hal_sim_flash_setup(cfg, err, errlen);
    if (rc == WDR_OK)
        rc = hal_sim_image_setup(cfg, err, errlen);
    hal_sim_hand_light_setup(cfg->hand_light_path);
    if (rc == WDR_OK && cfg->socket_path)
        rc = hal_sim_usb_setup(cfg->socket_path, err, errlen);
    B.ready = 1;
    if (rc != WDR_OK) {
        hal_sim_teardown();
        return rc;
    }
    atomic_store(&stop_flag, 0);
    hal_sim_reboot();
    return WDR_OK;
}

void hal_sim_teardown(void)
{
    hal_sim_usb_teardown();
    hal_sim_flash_teardown();
    hal_sim_image_teardown();
    hal_sim_boot_teardown();
    wdr_sim_destroy(B.sensor);
    free(B.adc_row);
    free(B.scene_amps);
    memset(&B, 0, sizeof B);
    hal_sim_hand_light_setup(NULL);
    hal_sim_exit_on_disconnect = 0;
    hal_sim_eof_fd = -1;
}

wdr_sim *hal_sim_sensor(void) { return B.sensor; }

void hal_sim_reboot(void)
{
    hal_event_ring_reset(&B.events);
    B.now_ns = 0;
    B.timer_at = B.ramp_done_at = NEVER;
    B.integration_end_ns = 0;
    B.exposed = B.converted = B.reset_asserted = 0;
    B.row_selected = -1;
    hal_sim_flash_reboot();
    hal_sim_image_reboot();
    hal_sim_usb_reboot();
}

uint64_t hal_sim_time_ns(void) { return B.now_ns; }

void hal_sim_advance_ns(uint64_t ns)
{
    B.now_ns += ns;
    fire_due();
}

uint64_t hal_sim_frames_exposed(void) { return B.frames; }

void hal_sim_request_stop(void)
{
    atomic_store(&stop_flag, 1);
}

int hal_sim_stop_requested(void) { return atomic_load(&stop_flag); }

void hal_sim_set_exit_on_disconnect(int on) { hal_sim_exit_on_disconnect = on; }

void hal_sim_watch_eof(int fd) { hal_sim_eof_fd = fd; }
