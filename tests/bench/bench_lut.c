/* Accuracy vs time for DAC ramp tables: build time of a LUT against the worst error of the
 * ideal pixel it drives, for uniform clocks of 256..65536 entries, equal-voltage steps at 8..16
 * DAC bits, and DAC timer resolutions. Prints a table; asserts nothing about speed. */
#include "bench_util.h"
#include "board.h"
#include "operators.h"
#include "ramp.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* The fastest update the DAC must sustain: the hardware cost of a table. */
static double min_step_ns(const wdr_lut_view *v)
{
    uint32_t prev = 0, t, best = UINT32_MAX;
    uint16_t code;
    for (uint32_t k = 1; k < v->h.entry_count; k++) {
        wdr_lut_entry(v, k, &t, &code);
        if (k > 1 && t - prev < best)
            best = t - prev;
        prev = t;
    }
    return best == UINT32_MAX ? 0 : best * (v->h.tick_ps * 1e-3);
}

typedef struct row {
    const char *mode;
    int dac_bits;
    double timer_hz;
    uint32_t entries_asked;
} row;

static int run_row(const wdr_board *base, const wdr_operator *op, const row *r)
{
    wdr_board b = *base;
    wdr_ideal_pixel px;
    wdr_ramp ramp;
    wdr_lut_view v;
    uint8_t *bytes = NULL;
    size_t len;
    char err[512];
    int timing = strcmp(r->mode, "uniform") ? WDR_TIMING_STAMPED : WDR_TIMING_UNIFORM;
    b.dac_bits = r->dac_bits;
    b.dac_timer_hz = r->timer_hz;
    double t0 = now_s();
    wdr_ideal_pixel_init(&b, &px);
    int rc = wdr_ramp_build(&px, op, b.i_min_a, b.i_max_a, 8192, WDR_RAMP_FAIL, &ramp, err, sizeof err);
    if (!rc)
        rc = wdr_ramp_quantise(&ramp, &b, op, timing, r->entries_asked, &bytes, &len, err, sizeof err);
    double t1 = now_s();
    if (!rc)
        rc = wdr_lut_parse(bytes, len, &v);
    if (rc) {
        printf("%-8s %4d %9.0e %8u  error: %s\n", r->mode, r->dac_bits, r->timer_hz, r->entries_asked, err);
        return 1;
    }
    double lsb_mv = (b.dac_hi_v - b.dac_lo_v) / ((1 << b.dac_bits) - 1) * 1e3;
    double worst = wdr_ramp_lut_worst_error_lsb(&px, op, &v, b.i_min_a, b.i_max_a, 2001, NULL);
    printf("%-8s %4d %9.0e %8u %9.2f %10.3f %10.3f %10.3f %11.1f\n", r->mode, r->dac_bits, r->timer_hz,
           v.h.entry_count, (t1 - t0) * 1e3, worst, worst * lsb_mv,
           v.h.t_integration_ticks * (v.h.tick_ps * 1e-12) * 1e3, min_step_ns(&v));
    wdr_ramp_free(&ramp);
    free(bytes);
    return 0;
}

int main(int argc, char **argv)
{
    int quick = argc > 1 && !strcmp(argv[1], "--quick");
    const char *op_name = argc > 2 ? argv[2] : argc > 1 && !quick ? argv[1] : "reinhard";
    char path[1024], err[512];
    wdr_board b;
    static wdr_operator op;
    wdr_lum_stats st;
    wdr_board_defaults(&b);
    wdr_board_path("sim-vga", path, sizeof path);
    if (wdr_board_load(path, &b, err, sizeof err) ||
        (wdr_lum_stats_default(b.i_min_a, b.i_center_a, b.i_max_a, b.lum_per_amp, 0.18, &st),
         wdr_operator_init(&op, op_name, &st, err, sizeof err))) {
        fprintf(stderr, "bench_lut: %s\n", err);
        return 1;
    }
    static const row full[] = {
        {"uniform", 12, 1e9, 256},   {"uniform", 12, 1e9, 1024},   {"uniform", 12, 1e9, 4096},
        {"uniform", 12, 1e9, 16384}, {"uniform", 12, 1e9, 65536},  {"stamped", 8, 1e9, 0},
        {"stamped", 10, 1e9, 0},     {"stamped", 12, 1e9, 0},      {"stamped", 14, 1e9, 0},
        {"stamped", 16, 1e9, 0},     {"stamped", 12, 1e8, 0},      {"stamped", 12, 1e7, 0},
        {"stamped", 12, 1e6, 0},
    };
    static const row fast[] = {{"uniform", 12, 1e9, 256}, {"stamped", 10, 1e9, 0}};
    const row *rows = quick ? fast : full;
    int n = quick ? 2 : (int)(sizeof full / sizeof full[0]), failures = 0;
    printf("LUT build: operator %s, board %s, photocurrent %.0e..%.0e A\n", op_name, b.name, b.i_min_a, b.i_max_a);
    printf("%-8s %4s %9s %8s %9s %10s %10s %10s %11s\n", "timing", "bits", "timer_Hz", "entries", "build_ms",
           "worst_LSB", "worst_mV", "t_int_ms", "min_step_ns");
    for (int i = 0; i < n; i++)
        failures += run_row(&b, &op, &rows[i]);
    return failures ? 1 : 0;
}
