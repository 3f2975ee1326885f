/* Issue 9, flag a pixel only on evidence, for the curve models LSQ and POLYMAP (the spline's
 * case is test_cal_defects.c). A simulated chip with the converters and temporal noise on,
 * calibrated as `wdrctl calibrate --model lsq|polymap` does by default (a two-frame probe, the
 * informative range, 19 currents, --frames auto, the designed response), at 128x96 so each case
 * takes a few seconds. Each model must
 *   - flag no healthy pixel of a clean chip (10 ppm of 12,288 is less than one), at the frames
 *     --frames auto chose and at 2 frames (the noisiest average there is);
 *   - find every planted defect (sim effect "defects": dead, stuck, hot, saturated at 1000 ppm
 *     each, plus one of each at the corners);
 *   - find responses that are wildly off, planted into a clean chip's levels: a jump of one mid
 *     level by a quarter of the swing, and a response that rises with the light. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "cal_design.h"
#include "cal_select.h"
#include "cal_test_support.h"

#define WIDTH 128
#define HEIGHT 96
#define GRID_LO 1e-14
#define GRID_PER_DECADE 6
#define PROBE_FRAMES 2
#define MIN_SLOPE_CODES 2.0
#define N_CURRENTS 19
#define FRAMES_TARGET_PCT 0.5 /* as wdrctl calibrate --frames auto */
#define FRAMES_MAX 64
#define DEFECT_PPM 1000
#define MAX_FALSE_PPM 10.0
#define N_WILD 16 /* wildly off responses planted: half jumps, half rising */
/* The jump, as a fraction of the swing: mid-range (~650 codes per unit of ln x) a quarter is an
 * e-fold error at that level. The residual is an rms over the levels, so one level's error counts
 * 1/sqrt(n): a tenth of the swing (0.4 in ln x at one level of 15) is not found at 64 frames. */
#define WILD_JUMP 0.25

typedef struct chip {
    wdr_board b;
    wdr_sim *sim;
    uint8_t *lut;
    wdr_cal_design design;
    uint8_t *truth; /* planted defect kind per pixel (0: healthy) */
} chip;

static void chip_open(chip *c, int with_defects)
{
    char err[512];
    wdr_board_defaults(&c->b);
    c->b.width = WIDTH, c->b.height = HEIGHT;
    if (wdr_cal_sim_setup(&c->b, "reinhard", 5, 1, WDR_CAL_MARGIN_V, &c->sim, &c->lut, err, sizeof err))
        fail_msg("%s", err);
    static const int temporal[] = {WDR_FX_SHOT, WDR_FX_KTC, WDR_FX_READ};
    for (int k = 0; k < 3; k++)
        wdr_sim_set_effect(c->sim, temporal[k], WDR_FX_ON);
    if (with_defects)
        assert_int_equal(plant_defects(c->sim, WIDTH, HEIGHT, DEFECT_PPM), WDR_OK);
    c->truth = malloc((size_t)WIDTH * HEIGHT);
    wdr_sim_defect_map(c->sim, c->truth);
    int middle_row = HEIGHT / 2; /* read at the middle row, as wdrctl's design */
    if (wdr_cal_design_init(&c->design, &c->b, "reinhard", wdr_sim_integration_time(c->sim),
                            middle_row * c->b.row_time_s, 1, err, sizeof err))
        fail_msg("design: %s", err);
}

static void chip_close(chip *c)
{
    wdr_sim_destroy(c->sim);
    free(c->lut);
    free(c->truth);
}

/* The levels and configuration wdrctl calibrate would use; frames 0: --frames auto. */
static void acquire_default(chip *c, int model, int frames, wdr_cal_levels *lv, wdr_cal_config *cfg)
{
    wdr_cal_simsrc ss = {c->sim, 1, 1000};
    wdr_cal_source src = {WIDTH, HEIGHT, wdr_cal_sim_capture, &ss};
    double amps[WDR_CAL_MAX_LEVELS], lo, hi, med[WDR_CAL_MAX_LEVELS];
    char err[512];
    int n = 6 * GRID_PER_DECADE + 1;
    for (int k = 0; k < n; k++)
        amps[k] = GRID_LO * pow(10, (double)k / GRID_PER_DECADE);
    wdr_cal_levels grid;
    assert_int_equal(wdr_cal_acquire(&src, amps, n, PROBE_FRAMES, 1, NULL, NULL, &grid, err, sizeof err), WDR_OK);
    assert_int_equal(wdr_cal_informative_range(&grid, MIN_SLOPE_CODES, &lo, &hi), WDR_OK);
    wdr_cal_config_defaults(cfg, model);
    cfg->range_lo = lo, cfg->range_hi = hi;
    cfg->design = &c->design;
    const wdr_board *b = &c->b;
    cfg->step_codes = (b->dac_hi_v - b->dac_lo_v) / ((1u << b->dac_bits) - 1u) * b->adc_gain *
                      ((1u << b->adc_bits) - 1u) / (b->adc_hi_v - b->adc_lo_v);
    wdr_cal_choice ch;
    if (wdr_cal_select_currents(&grid, cfg, N_CURRENTS, lo, hi, 256, &ch, err, sizeof err))
        fail_msg("selection: %s", err);
    if (!frames) {
        wdr_cal_frames_choice fc;
        assert_int_equal(wdr_cal_level_medians(&grid, NULL, med), WDR_OK);
        assert_int_equal(wdr_cal_frames_for(&grid, med, lo, hi, 1.0, FRAMES_TARGET_PCT, FRAMES_MAX, &fc), WDR_OK);
        frames = fc.frames;
    }
    wdr_cal_levels_free(&grid);
    assert_int_equal(wdr_cal_acquire(&src, ch.amps, ch.n, frames, 1, NULL, NULL, lv, err, sizeof err), WDR_OK);
    printf("# %s: range %.3g..%.3g A, %d currents, %d frames per level\n", model == WDR_MODEL_LSQ ? "lsq" : "polymap",
           lo, hi, ch.n, frames);
}

static void fit(const wdr_cal_levels *lv, const wdr_cal_config *cfg, wdr_cal_result *res)
{
    char err[512];
    if (wdr_cal_fit_array(lv, cfg, res, err, sizeof err))
        fail_msg("fit: %s", err);
}

/* Healthy pixels (truth 0, not in skip) flagged, the first few printed. */
static long healthy_flagged(const wdr_cal_result *res, const uint8_t *truth, const uint8_t *skip)
{
    long n = 0;
    for (long i = 0; i < (long)res->width * res->height; i++)
        if (!truth[i] && !(skip && skip[i]) && res->flags[i] && ++n <= 5)
            printf("# healthy pixel %ld flagged 0x%x (%s)\n", i, res->flags[i], wdr_fit_status_name(res->status[i]));
    return n;
}

static void clean_chip(int model, int frames)
{
    chip c;
    wdr_cal_levels lv;
    wdr_cal_config cfg;
    wdr_cal_result res;
    chip_open(&c, 0);
    acquire_default(&c, model, frames, &lv, &cfg);
    fit(&lv, &cfg, &res);
    long np = (long)WIDTH * HEIGHT, bad = healthy_flagged(&res, c.truth, NULL);
    printf("# clean chip: %ld of %ld healthy pixels flagged (%.1f ppm)\n", bad, np, 1e6 * (double)bad / (double)np);
    assert_true(1e6 * (double)bad / (double)np <= MAX_FALSE_PPM);
    wdr_cal_result_free(&res);
    wdr_cal_levels_free(&lv);
    chip_close(&c);
}

/* Responses no healthy pixel has, planted into copies of healthy pixels' levels. */
static void plant_wild(wdr_cal_levels *lv, uint8_t *planted)
{
    long np = (long)lv->width * lv->height;
    int mid = lv->n / 2;
    double swing = 0;
    for (int k = 0; k < lv->n; k++) /* the array's swing over the levels, from one pixel's */
        swing = fmax(swing, fabs(lv->frames[(long)k * np + np / 2] - lv->frames[(long)(lv->n - 1) * np + np / 2]));
    for (int j = 0; j < N_WILD; j++) {
        long i = 37 + j * (np / N_WILD);
        planted[i] = 1;
        if (j % 2 == 0) { /* one level jumps: a telegraph step, or a mis-set light for one pixel */
            lv->frames[(long)mid * np + i] += (float)(WILD_JUMP * swing);
        } else { /* the response rises with the light: the pixel's codes in reverse order */
            for (int k = 0; k < lv->n / 2; k++) {
                float *a = &lv->frames[(long)k * np + i], *b = &lv->frames[(long)(lv->n - 1 - k) * np + i], t = *a;
                *a = *b, *b = t;
            }
        }
    }
}

static void wild_responses(int model)
{
    chip c;
    wdr_cal_levels lv;
    wdr_cal_config cfg;
    wdr_cal_result res;
    chip_open(&c, 0);
    acquire_default(&c, model, 0, &lv, &cfg);
    uint8_t *planted = calloc((size_t)WIDTH * HEIGHT, 1);
    plant_wild(&lv, planted);
    fit(&lv, &cfg, &res);
    long found = 0, bad = healthy_flagged(&res, c.truth, planted);
    for (long i = 0; i < (long)WIDTH * HEIGHT; i++)
        if (planted[i]) {
            found += res.flags[i] != 0;
            if (!res.flags[i])
                printf("# planted response at pixel %ld not flagged\n", i);
        }
    printf("# wildly off responses: %ld of %d flagged; healthy flagged %ld\n", found, N_WILD, bad);
    assert_int_equal(found, N_WILD);
    assert_int_equal(bad, 0);
    free(planted);
    wdr_cal_result_free(&res);
    wdr_cal_levels_free(&lv);
    chip_close(&c);
}

static void planted_defects(int model)
{
    chip c;
    wdr_cal_levels lv;
    wdr_cal_config cfg;
    wdr_cal_result res;
    chip_open(&c, 1);
    acquire_default(&c, model, 0, &lv, &cfg);
    fit(&lv, &cfg, &res);
    long np = (long)WIDTH * HEIGHT, planted = 0, found = 0;
    for (long i = 0; i < np; i++)
        if (c.truth[i]) {
            planted++, found += res.flags[i] != 0;
            if (!res.flags[i])
                printf("# planted defect %d at pixel %ld not flagged\n", c.truth[i], i);
        }
    long bad = healthy_flagged(&res, c.truth, NULL);
    printf("# planted %ld: found %ld; healthy flagged %ld\n", planted, found, bad);
    assert_int_equal(planted, 4 * lround(DEFECT_PPM * np / 1e6) + 4);
    assert_int_equal(found, planted);
    assert_true(1e6 * (double)bad / (double)(np - planted) <= MAX_FALSE_PPM);
    wdr_cal_result_free(&res);
    wdr_cal_levels_free(&lv);
    chip_close(&c);
}

static void lsq_clean_auto(void **s)
{
    (void)s, clean_chip(WDR_MODEL_LSQ, 0);
}
static void lsq_clean_2_frames(void **s)
{
    (void)s, clean_chip(WDR_MODEL_LSQ, 2);
}
static void lsq_defects(void **s)
{
    (void)s, planted_defects(WDR_MODEL_LSQ);
}
static void lsq_wild(void **s)
{
    (void)s, wild_responses(WDR_MODEL_LSQ);
}
static void polymap_clean_auto(void **s)
{
    (void)s, clean_chip(WDR_MODEL_POLYMAP, 0);
}
static void polymap_clean_2_frames(void **s)
{
    (void)s, clean_chip(WDR_MODEL_POLYMAP, 2);
}
static void polymap_defects(void **s)
{
    (void)s, planted_defects(WDR_MODEL_POLYMAP);
}
static void polymap_wild(void **s)
{
    (void)s, wild_responses(WDR_MODEL_POLYMAP);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(lsq_clean_auto),     cmocka_unit_test(lsq_clean_2_frames),
        cmocka_unit_test(lsq_defects),        cmocka_unit_test(lsq_wild),
        cmocka_unit_test(polymap_clean_auto), cmocka_unit_test(polymap_clean_2_frames),
        cmocka_unit_test(polymap_defects),    cmocka_unit_test(polymap_wild),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
