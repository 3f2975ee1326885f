/* Defect detection that can be measured: a simulated VGA chip (board defaults, 640x480) with
 * every static effect and the board's temporal noise on, calibrated the way `wdrctl calibrate`
 * does by default (host/wdrctl/cal_common.c: a two-frame probe of the grid, the informative
 * range, 19 spline currents, --frames auto for half the eye's 1 % threshold). Planted defects
 * (sim effect "defects": dead, stuck, hot, saturated at 100 ppm each plus one of each at the
 * corners) must all be flagged; a clean chip (the same seed, nothing planted) may have at most
 * 10 ppm of its pixels flagged. CTest runs it at QVGA (320x240, ~1/4 of the time): 10 ppm is then
 * less than one pixel, so no healthy pixel may be flagged at all (stricter). `test_cal_defects vga`
 * runs the full 640x480 chip (about 2.5 minutes on one core pair). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "cal_select.h"
#include "cal_test_support.h"

#define GRID_LO 1e-14
#define GRID_PER_DECADE 6
#define PROBE_FRAMES 2
#define MIN_SLOPE_CODES 2.0
#define N_CURRENTS 19
#define FRAMES_TARGET_PCT 0.5
#define FRAMES_MAX 64
#define DEFECT_PPM 100
#define MAX_FALSE_PPM 10.0

typedef struct run {
    long np, flagged, healthy_flagged, planted, planted_found, per_kind[WDR_DEFECT_KINDS];
    int frames;
} run;

static int vga; /* argument "vga": the full board size */

static void calibrate_default(wdr_sim *sim, const wdr_board *b, wdr_cal_result *res, int *frames)
{
    wdr_cal_simsrc ss = {sim, 1, 1000};
    wdr_cal_source src = {b->width, b->height, wdr_cal_sim_capture, &ss};
    double amps[WDR_CAL_MAX_LEVELS], lo, hi, med[WDR_CAL_MAX_LEVELS];
    char err[512];
    int n = 6 * GRID_PER_DECADE + 1;
    for (int k = 0; k < n; k++)
        amps[k] = GRID_LO * pow(10, (double)k / GRID_PER_DECADE);
    wdr_cal_levels grid, lv;
    assert_int_equal(wdr_cal_acquire(&src, amps, n, PROBE_FRAMES, 1, NULL, NULL, &grid, err, sizeof err), WDR_OK);
    assert_int_equal(wdr_cal_informative_range(&grid, MIN_SLOPE_CODES, &lo, &hi), WDR_OK);
    wdr_cal_config cfg;
    wdr_cal_config_defaults(&cfg, WDR_MODEL_SPLINE);
    cfg.range_lo = lo, cfg.range_hi = hi;
    cfg.step_codes = (b->dac_hi_v - b->dac_lo_v) / ((1u << b->dac_bits) - 1u) * b->adc_gain *
                     ((1u << b->adc_bits) - 1u) / (b->adc_hi_v - b->adc_lo_v);
    wdr_cal_choice ch;
    if (wdr_cal_select_currents(&grid, &cfg, N_CURRENTS, lo, hi, 256, &ch, err, sizeof err))
        fail_msg("selection: %s", err);
    wdr_cal_frames_choice fc;
    assert_int_equal(wdr_cal_level_medians(&grid, NULL, med), WDR_OK);
    assert_int_equal(wdr_cal_frames_for(&grid, med, lo, hi, 1.0, FRAMES_TARGET_PCT, FRAMES_MAX, &fc), WDR_OK);
    wdr_cal_levels_free(&grid);
    *frames = fc.frames;
    printf("# range %.3g..%.3g A, %d currents, frames auto: %d (noise %.3g codes at %.3g A, slope %.3g)\n", lo, hi,
           ch.n, fc.frames, fc.sigma_codes, fc.at_amps, fc.slope);
    assert_int_equal(wdr_cal_acquire(&src, ch.amps, ch.n, fc.frames, 1, NULL, NULL, &lv, err, sizeof err), WDR_OK);
    if (wdr_cal_fit_array(&lv, &cfg, res, err, sizeof err))
        fail_msg("fit: %s", err);
    wdr_cal_levels_free(&lv);
}

static run run_chip(int with_defects)
{
    wdr_board b;
    wdr_sim *sim;
    uint8_t *lut;
    char err[512];
    wdr_board_defaults(&b); /* 640 x 480 */
    if (!vga)
        b.width = 320, b.height = 240;
    if (wdr_cal_sim_setup(&b, "reinhard", 5, 1, WDR_CAL_MARGIN_V, &sim, &lut, err, sizeof err))
        fail_msg("%s", err);
    static const int temporal[] = {WDR_FX_SHOT, WDR_FX_KTC, WDR_FX_READ}; /* as the simulated board serves */
    for (int k = 0; k < 3; k++)
        wdr_sim_set_effect(sim, temporal[k], WDR_FX_ON);
    if (with_defects)
        assert_int_equal(plant_defects(sim, b.width, b.height, DEFECT_PPM), WDR_OK);
    run r = {.np = (long)b.width * b.height};
    uint8_t *truth = malloc((size_t)r.np);
    wdr_sim_defect_map(sim, truth);
    wdr_cal_result res;
    calibrate_default(sim, &b, &res, &r.frames);
    for (long i = 0; i < r.np; i++) {
        r.flagged += res.flags[i] != 0;
        if (truth[i]) {
            r.planted++;
            r.planted_found += res.flags[i] != 0;
            r.per_kind[truth[i]] += res.flags[i] != 0;
        } else if (res.flags[i]) {
            r.healthy_flagged++;
            if (r.healthy_flagged <= 5)
                printf("# healthy pixel %ld flagged 0x%x (%s)\n", i, res.flags[i], wdr_fit_status_name(res.status[i]));
        }
    }
    wdr_cal_result_free(&res);
    free(truth);
    wdr_sim_destroy(sim);
    free(lut);
    return r;
}

static void clean_chip_flags_at_most_10ppm(void **state)
{
    (void)state;
    run r = run_chip(0);
    double ppm = 1e6 * (double)r.flagged / (double)r.np;
    printf("# clean chip: %ld of %ld pixels flagged (%.2f ppm), %d frames per level\n", r.flagged, r.np, ppm, r.frames);
    assert_true(ppm <= MAX_FALSE_PPM);
}

static void planted_defects_all_found(void **state)
{
    (void)state;
    run r = run_chip(1);
    printf("# planted %ld: found %ld (dead %ld, stuck %ld, hot %ld, saturated %ld); healthy flagged %ld (%.2f ppm)\n",
           r.planted, r.planted_found, r.per_kind[WDR_DEFECT_DEAD], r.per_kind[WDR_DEFECT_STUCK],
           r.per_kind[WDR_DEFECT_HOT], r.per_kind[WDR_DEFECT_SATURATED], r.healthy_flagged,
           1e6 * (double)r.healthy_flagged / (double)(r.np - r.planted));
    assert_int_equal(r.planted, 4 * lround(DEFECT_PPM * r.np / 1e6) + 4);
    assert_int_equal(r.planted_found, r.planted);
    assert_true(1e6 * (double)r.healthy_flagged / (double)(r.np - r.planted) <= MAX_FALSE_PPM);
}

int main(int argc, char **argv)
{
    vga = argc > 1 && !strcmp(argv[1], "vga");
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(clean_chip_flags_at_most_10ppm),
        cmocka_unit_test(planted_defects_all_found),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
