/* Torture: the calibration maths pushed to its edges on synthetic pixel responses (the shape of
 * the paper's pixel, with mismatch). Every case must give finite tables and flagged pixels,
 * never NaN or Inf, both in double (host recovery) and in the firmware's float32 kernel, and
 * asserts its expected outcome: the refusal and its error code, flag counts within bounds, and
 * the healthy pixels' recovered currents within a stated error (tests/torture/README.md). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "cal_select.h"
#include "cal_test_support.h"

#define W 32
#define H 16
#define NP (W * H)

/* A deterministic generator: the tests must not depend on the platform's rand(). */
static uint64_t rng_state = 88172645463325252ull;
static double uniform01(void)
{
    rng_state ^= rng_state << 13, rng_state ^= rng_state >> 7, rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) / 9007199254740992.0;
}
static double gauss(void) { return sqrt(-2 * log(uniform01() + 1e-300)) * cos(6.283185307179586 * uniform01()); }

typedef struct pixel_truth {
    double a, b, c, d;
} pixel_truth;

static pixel_truth truth[NP];

static void draw_pixels(void)
{
    for (int i = 0; i < NP; i++)
        truth[i] = (pixel_truth){3100 + 20 * gauss(), 2600 * (1 + 0.01 * gauss()), 1 + 0.01 * gauss(),
                                 3e-16 * exp(0.3 * gauss())};
}

static double response(int i, double x)
{
    double t = (x + truth[i].d) / 1e-11;
    return truth[i].a - truth[i].b * t / (1 + truth[i].c * t);
}

/* Levels at amps (plus a dark frame); noise in codes (rms) is added to every sample, and told to
 * the noise-aware statistics as one frame's measured noise (m_avg 1). */
static void make_levels(wdr_cal_levels *lv, const double *amps, int n, double noise)
{
    memset(lv, 0, sizeof *lv);
    lv->width = W, lv->height = H, lv->n = n;
    lv->m_avg = noise > 0 ? 1 : 0;
    lv->dark_noise = noise;
    for (int k = 0; k < n; k++)
        lv->noise[k] = noise;
    lv->frames = malloc(sizeof(float) * NP * (size_t)n);
    lv->dark = malloc(sizeof(float) * NP);
    for (int k = 0; k < n; k++) {
        lv->amps[k] = amps[k];
        for (int i = 0; i < NP; i++)
            lv->frames[k * NP + i] = (float)(response(i, amps[k]) + noise * gauss());
    }
    for (int i = 0; i < NP; i++)
        lv->dark[i] = (float)(response(i, 0) + noise * gauss());
}

/* Levels with the dark frame as level 0 for the paper models' dark reference. */
static void with_dark_first(const wdr_cal_levels *src, const int *idx, int n, wdr_cal_levels *out)
{
    assert_int_equal(wdr_cal_levels_subset(src, idx, n, out), WDR_OK);
    out->dark = src->dark;
}

/* Double recovery and map over every code: finite for every pixel, flagged or not. */
static long host_sweep_bad(const wdr_cal_result *res)
{
    long bad = 0;
    for (int i = 0; i < NP; i++)
        for (double y = -10; y <= res->cfg.raw_max + 10; y += 13.7) {
            int st;
            bad += !isfinite(wdr_cal_recover(res, i, y, &st)) || !isfinite(wdr_cal_map(res, i, y));
        }
    return bad;
}

/* Worst |x_hat / x - 1| of the unflagged pixels at currents between the calibration levels
 * (geometric midpoints within 1e-13..1e-9 A), noiseless responses. */
static double worst_healthy_error(const wdr_cal_result *res, const wdr_cal_levels *lv)
{
    double worst = 0;
    for (int k = 1; k < lv->n; k++) {
        if (!(lv->amps[k - 1] > 0))
            continue;
        double x = sqrt(lv->amps[k - 1] * lv->amps[k]);
        if (x < 1e-13 || x > 1e-9)
            continue; /* where the response carries contrast: the ends are flat to a code */
        for (int i = 0; i < NP; i++) {
            int st;
            if (!res->flags[i])
                worst = fmax(worst, fabs(wdr_cal_recover(res, i, response(i, x), &st) / x - 1));
        }
    }
    return worst;
}

static double last_healthy_error; /* of the last run_model that fitted */
static int last_rc;               /* and its return code */

/* Fit with one model, build its table, and check everything that must hold whatever the data. */
static long run_model(const wdr_cal_levels *lv, int model, int form)
{
    wdr_cal_config cfg;
    wdr_cal_result res;
    char err[256] = "";
    uint8_t *tb;
    size_t tl;
    wdr_cal_view v;
    wdr_cal_config_defaults(&cfg, model);
    cfg.form = form;
    cfg.range_lo = lv->amps[0] > 0 ? lv->amps[0] : lv->amps[1];
    cfg.range_hi = lv->amps[lv->n - 1];
    int rc = wdr_cal_fit_array(lv, &cfg, &res, err, sizeof err);
    last_rc = rc;
    if (rc) {
        /* refusing is allowed, silently is not */
        assert_true(rc < 0 && err[0]);
        printf("    model %d refused: %s\n", model, err);
        wdr_cal_result_free(&res);
        return -1;
    }
    assert_int_equal(host_sweep_bad(&res), 0);
    last_healthy_error = worst_healthy_error(&res, lv);
    if (wdr_cal_build_table(&res, 1, 1, &tb, &tl, err, sizeof err))
        fail_msg("table: %s", err);
    assert_int_equal(wdr_cal_parse(tb, tl, &v), WDR_OK);
    assert_true(table_all_finite(&v));
    assert_int_equal(kernel_sweep_bad(&v), 0);
    long flagged = v.h.bad_pixels;
    if (getenv("TORTURE_VERBOSE"))
        printf("    model %d: fit flagged %ld (unfit %ld: ill-cond %ld, pole %ld, reversed %ld, residual %ld), "
               "table flagged %ld\n", model, res.n_bad, res.n_flag[4], res.n_status[WDR_FIT_ILL_COND],
               res.n_status[WDR_FIT_POLE], res.n_status[WDR_FIT_REVERSED], res.n_status[WDR_FIT_RESIDUAL], flagged);
    free(tb);
    wdr_cal_result_free(&res);
    return flagged;
}

/* Flagged pixels per model: simple3, complex4, lsq, polymap, spline (poly), spline (basis);
 * -1 where the model refused. */
static long flags_of[6];

static void run_all_models(const wdr_cal_levels *all, const char *what)
{
    int n = all->n, k3[4] = {-1, 0, n / 2, n - 1}, k4[5] = {-1, 0, n / 3, 2 * n / 3, n - 1};
    wdr_cal_levels l3, l4;
    with_dark_first(all, k3, 4, &l3);
    with_dark_first(all, k4, 5, &l4);
    long *f = flags_of;
    f[0] = run_model(&l3, WDR_MODEL_SIMPLE3, WDR_FORM_MOEBIUS);
    f[1] = run_model(&l4, WDR_MODEL_COMPLEX4, WDR_FORM_POLY);
    wdr_cal_levels plain = *all;
    plain.dark = all->dark;
    f[2] = run_model(&plain, WDR_MODEL_LSQ, WDR_FORM_POLY);
    f[3] = run_model(&plain, WDR_MODEL_POLYMAP, WDR_FORM_POLY);
    f[4] = run_model(&plain, WDR_MODEL_SPLINE, WDR_FORM_POLY);
    double spline_err = last_healthy_error;
    f[5] = run_model(&plain, WDR_MODEL_SPLINE, WDR_FORM_BASIS);
    last_healthy_error = spline_err; /* the spline model's own recovery (the table form does not change it) */
    printf("  %s: flagged pixels (of %d) simple3 %ld, complex4 %ld, lsq %ld, polymap %ld, spline %ld, "
           "spline with the basis table %ld\n", what, NP, f[0], f[1], f[2], f[3], f[4], f[5]);
    l3.dark = l4.dark = NULL;
    wdr_cal_levels_free(&l3);
    wdr_cal_levels_free(&l4);
}

static int synthetic_capture(void *ctx, double amps, int frame_no, float *frame)
{
    (void)ctx, (void)frame_no;
    for (int i = 0; i < NP; i++)
        frame[i] = (float)response(i, amps);
    return WDR_OK;
}

static void log_levels(double lo, double hi, int n, double *amps)
{
    for (int k = 0; k < n; k++)
        amps[k] = lo * pow(hi / lo, (double)k / (n - 1));
}

static void currents_over_eight_decades(void **state)
{
    (void)state;
    double amps[17];
    wdr_cal_levels lv;
    draw_pixels();
    log_levels(1e-15, 1e-7, 17, amps);
    make_levels(&lv, amps, 17, 0.0);
    run_all_models(&lv, "1e-15..1e-7 A, noiseless");
    /* no pixel here is defective: the spline flags none, and recovers every one between its
     * levels (half a decade apart) within 1 % over 1e-13..1e-9 A (measured 0.56 %) */
    assert_int_equal(flags_of[4], 0);
    assert_int_equal(flags_of[5], 0);
    printf("  spline healthy recovery: worst %.3g %%\n", 100 * last_healthy_error);
    assert_true(last_healthy_error < 0.01);
    wdr_cal_levels_free(&lv);
    make_levels(&lv, amps, 17, 0.3);
    run_all_models(&lv, "1e-15..1e-7 A, 0.3 code noise");
    /* noise within its measured sigma is pooled, never flagged: at most 1 % of the healthy pixels */
    assert_true(flags_of[4] >= 0 && flags_of[4] <= NP / 100);
    assert_true(flags_of[5] >= 0 && flags_of[5] <= NP / 100);
    wdr_cal_levels_free(&lv);
}

static void two_currents_within_a_thousandth(void **state)
{
    (void)state;
    double amps[9];
    wdr_cal_levels lv;
    draw_pixels();
    log_levels(1e-14, 1e-8, 9, amps);
    /* every model's middle currents land on the near pair */
    amps[3] = 1e-11, amps[4] = 1.001e-11;
    amps[5] = 1.002e-11;
    make_levels(&lv, amps, 9, 0.2);
    run_all_models(&lv, "currents 0.1 % apart, noisy");
    /* the paper models on exactly the near pair */
    int k3[4] = {-1, 0, 3, 4}, k4[5] = {-1, 0, 3, 4, 8};
    wdr_cal_levels l3, l4;
    with_dark_first(&lv, k3, 4, &l3);
    with_dark_first(&lv, k4, 5, &l4);
    printf("  near pair in the fit: simple3 flagged %ld, complex4 flagged %ld\n",
           run_model(&l3, WDR_MODEL_SIMPLE3, WDR_FORM_MOEBIUS), run_model(&l4, WDR_MODEL_COMPLEX4, WDR_FORM_POLY));
    l3.dark = l4.dark = NULL;
    wdr_cal_levels_free(&l3);
    wdr_cal_levels_free(&l4);
    /* acquisition refuses such currents up front, naming them */
    char err[256] = "";
    wdr_cal_levels out;
    wdr_cal_source src = {W, H, NULL, NULL}; /* no capture function: refused as a bad request */
    assert_int_equal(wdr_cal_acquire(&src, amps, 9, 1, 0, NULL, NULL, &out, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "bad acquisition request"));
    wdr_cal_source ok_src = {W, H, synthetic_capture, NULL}; /* a working source: refused for the currents */
    assert_int_equal(wdr_cal_acquire(&ok_src, amps, 9, 1, 0, NULL, NULL, &out, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "1e-11"));
    assert_non_null(strstr(err, "differ by"));
    printf("  acquisition: %s\n", err);
    wdr_cal_levels_free(&lv);
}

/* Noise pushes codes beyond the fitted curve's reach: eq. 26's discriminant goes negative and
 * must be clamped and reported, with a finite current. */
static void negative_discriminant(void **state)
{
    (void)state;
    int clamped = 0, any = 0;
    for (int sign = -1; sign <= 1; sign += 2) {
        /* R < 0 (a fit whose white-point term came out negative) drives the discriminant below
         * zero at bright codes, R > 0 far above the dark level */
        wdr_complex4 m = {3100, 3100 * 0.8 - 2000, sign * 2000 * 2e-3, 0.8, 0, 1e-11, 0};
        for (double y = -500; y < 5000; y += 0.5) {
            double u;
            int st = wdr_complex4_invert(&m, y, 1e6, &u, &clamped);
            assert_true(isfinite(u));
            assert_true(st == WDR_FIT_OK || st == WDR_FIT_POLE || st == WDR_FIT_FLAT);
            any |= clamped;
        }
    }
    assert_true(any);
    double amps[9];
    wdr_cal_levels lv;
    draw_pixels();
    log_levels(1e-14, 1e-8, 9, amps);
    make_levels(&lv, amps, 9, 3.0); /* heavy noise against a flat bright end */
    run_all_models(&lv, "3 codes of noise");
    wdr_cal_levels_free(&lv);
}

/* Saturated, dead, stuck and hot pixels, and zero or reversed slopes: each flagged with its own
 * reason, and the kernel replaces them from their row neighbours. */
static void bad_pixels_flagged(void **state)
{
    (void)state;
    double amps[9];
    wdr_cal_levels lv;
    draw_pixels();
    log_levels(1e-14, 1e-8, 9, amps);
    make_levels(&lv, amps, 9, 0.0);
    enum { SAT = 3, DEAD = 40, STUCK = 77, HOT = 100, FLAT = 130, REV = 161, NANPIX = 200 };
    for (int k = 0; k < 9; k++) {
        float *f = lv.frames + k * NP;
        f[SAT] = k >= 6 ? 0.0f : f[SAT];              /* clipped at the ADC's bottom rail */
        f[DEAD] = (float)(truth[DEAD].a - 0.1 * (truth[DEAD].a - f[DEAD])); /* a tenth of the swing */
        f[STUCK] = 4095.0f;                           /* stuck at the top rail */
        if (k == 5)
            f[FLAT] = lv.frames[4 * NP + FLAT];       /* zero slope between two levels */
        if (k == 6)
            f[REV] = lv.frames[5 * NP + REV] + 5;     /* reversed slope */
        f[NANPIX] = k == 2 ? NAN : f[NANPIX];
    }
    lv.dark[HOT] -= 200; /* a dark current far above the array's */
    wdr_cal_config cfg;
    wdr_cal_result res;
    char err[256];
    wdr_cal_config_defaults(&cfg, WDR_MODEL_SPLINE);
    assert_int_equal(wdr_cal_fit_array(&lv, &cfg, &res, err, sizeof err), WDR_OK);
    /* one kind each (host/cal/cal_bad.c): a pixel at a rail is saturated, whatever else it does */
    assert_int_equal(res.flags[SAT], WDR_PIX_SATURATED);
    assert_int_equal(res.flags[DEAD], WDR_PIX_DEAD);
    assert_int_equal(res.flags[STUCK], WDR_PIX_SATURATED);
    assert_int_equal(res.flags[HOT], WDR_PIX_HOT);
    assert_true(res.flags[FLAT] & WDR_PIX_UNFIT);
    assert_true(res.flags[REV] & WDR_PIX_UNFIT);
    assert_int_equal(res.status[FLAT], WDR_FIT_FLAT);     /* each for its own reason */
    assert_int_equal(res.status[REV], WDR_FIT_REVERSED);
    assert_true(res.flags[NANPIX] != 0);
    assert_int_equal(res.n_bad, 7); /* the seven planted, no healthy pixel */
    assert_int_equal(host_sweep_bad(&res), 0);
    uint8_t *tb;
    size_t tl;
    wdr_cal_view v;
    assert_int_equal(wdr_cal_build_table(&res, 1, 1, &tb, &tl, err, sizeof err), WDR_OK);
    assert_int_equal(wdr_cal_parse(tb, tl, &v), WDR_OK);
    assert_int_equal(kernel_sweep_bad(&v), 0);
    /* the kernel patches the stuck pixel from its row neighbours on a uniform frame */
    uint16_t raw[W], out[W];
    int row = STUCK / W, col = STUCK % W;
    for (int c = 0; c < W; c++)
        raw[c] = (uint16_t)lround(lv.frames[4 * NP + row * W + c]);
    assert_int_equal(wdr_correct_row(&v, row, raw, out), WDR_OK);
    assert_true(abs((int)out[col] - (int)out[col - 1]) < 64 && abs((int)out[col] - (int)out[col + 1]) < 64);
    char kinds[160];
    printf("  bad pixels: %ld flagged (%s)\n", res.n_bad, wdr_cal_flag_counts_text(res.n_flag, kinds, sizeof kinds));
    free(tb);
    wdr_cal_result_free(&res);
    run_all_models(&lv, "bad pixels");
    wdr_cal_levels_free(&lv);
}

/* The shared basis is learnt from the good pixels: with fewer than two per basis function it
 * would be degenerate, and the table is refused with a message instead of being built. */
static void basis_from_too_few_good_pixels_refused(void **state)
{
    (void)state;
    double amps[9];
    wdr_cal_levels lv;
    wdr_cal_config cfg;
    wdr_cal_result res;
    char err[256] = "";
    uint8_t *tb = NULL;
    size_t tl;
    draw_pixels();
    log_levels(1e-14, 1e-8, 9, amps);
    make_levels(&lv, amps, 9, 0.0);
    wdr_cal_config_defaults(&cfg, WDR_MODEL_SPLINE);
    assert_int_equal(cfg.form, WDR_FORM_BASIS);
    assert_int_equal(wdr_cal_fit_array(&lv, &cfg, &res, err, sizeof err), WDR_OK);
    for (int i = 5; i < NP; i++) /* all but five pixels dead: 5 < 2 * 8 */
        res.flags[i] |= WDR_PIX_DEAD;
    assert_int_equal(wdr_cal_build_table(&res, 1, 1, &tb, &tl, err, sizeof err), WDR_E_NUMERIC);
    assert_null(tb);
    assert_non_null(strstr(err, "good pixels"));
    printf("  basis from 5 good pixels: %s\n", err);
    wdr_cal_result_free(&res);
    wdr_cal_levels_free(&lv);
}

/* A whole array whose response does not fall with light: no nominal curve, refused clearly. */
static void reversed_array_refused(void **state)
{
    (void)state;
    double amps[9];
    wdr_cal_levels lv;
    draw_pixels();
    log_levels(1e-14, 1e-8, 9, amps);
    make_levels(&lv, amps, 9, 0.0);
    for (int k = 0; k < 9; k++)
        for (int i = 0; i < NP; i++)
            lv.frames[k * NP + i] = (float)(500 + 10 * k);
    run_all_models(&lv, "rising response (every pixel reversed)");
    /* the curve models have no nominal curve to fit: refused with WDR_E_NUMERIC; the paper
     * models may fit, but then every pixel must be flagged */
    for (int m = 0; m < 6; m++)
        assert_true(flags_of[m] == -1 || flags_of[m] == NP);
    assert_int_equal(flags_of[4], -1);
    assert_int_equal(flags_of[5], -1);
    wdr_cal_levels plain = lv;
    wdr_cal_config cfg;
    wdr_cal_result res;
    char err[256] = "";
    wdr_cal_config_defaults(&cfg, WDR_MODEL_SPLINE);
    assert_int_equal(wdr_cal_fit_array(&plain, &cfg, &res, err, sizeof err), WDR_E_NUMERIC);
    assert_non_null(strstr(err, "median response"));
    wdr_cal_result_free(&res);
    wdr_cal_levels_free(&lv);
}

/* The bright end flattens: levels there differ by less than a DAC step. Selection must never
 * put two chosen levels closer than one DAC step plus 3 sigma of their difference. */
static void close_levels_never_selected(void **state)
{
    (void)state;
    double amps[25];
    wdr_cal_levels lv;
    draw_pixels();
    log_levels(1e-14, 1e-7, 25, amps);
    make_levels(&lv, amps, 25, 0.2);
    wdr_cal_config cfg;
    wdr_cal_config_defaults(&cfg, WDR_MODEL_SPLINE);
    cfg.step_codes = 1.65; /* one 12-bit DAC step of the default board, in codes */
    cfg.range_lo = amps[0], cfg.range_hi = amps[24];
    wdr_cal_choice ch;
    char err[256] = "";
    assert_int_equal(wdr_cal_select_currents(&lv, &cfg, 19, amps[0], amps[24], NP, &ch, err, sizeof err), WDR_OK);
    double med[25];
    assert_int_equal(wdr_cal_level_medians(&lv, NULL, med), WDR_OK);
    double closest = INFINITY, need = cfg.step_codes + cfg.spacing_sigmas * 0.2 * sqrt(2.0);
    for (int j = 1; j < ch.n; j++)
        closest = fmin(closest, fabs(med[ch.idx[j - 1]] - med[ch.idx[j]]));
    printf("  selection: %d of 19 levels kept, closest pair %.3g codes apart (need > %.3g)\n", ch.n, closest, need);
    assert_true(closest > need);
    assert_true(ch.n >= 4);
    wdr_cal_levels_free(&lv);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(currents_over_eight_decades), cmocka_unit_test(two_currents_within_a_thousandth),
        cmocka_unit_test(negative_discriminant),       cmocka_unit_test(bad_pixels_flagged),
        cmocka_unit_test(reversed_array_refused),      cmocka_unit_test(basis_from_too_few_good_pixels_refused),
        cmocka_unit_test(close_levels_never_selected),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
