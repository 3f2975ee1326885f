/* Defect detection that can be measured (issue 9; kinds and weak hot pixels, issue 19 item 5).
 * Simulated chips with every static effect and the board's temporal noise on, calibrated the way
 * `wdrctl calibrate` does by default (host/wdrctl/cal_common.c: a two-frame probe of the grid, the
 * informative range, 19 spline currents, --frames auto for half the eye's 1 % threshold).
 *
 * 1. clean chip: a 320x240 chip (seed 5, nothing planted) may have at most 10 ppm of its pixels
 *    flagged, i.e. none (10 ppm is less than a pixel); `test_cal_defects vga` runs 640x480.
 * 2. planted defects (sim effect "defects": dead, stuck, hot, saturated at 100 ppm each, plus one of
 *    each at the corners) are all found, each named by its kind, position by position against the
 *    simulator's defect map (the test reads it; calibration never does), and the counts by kind
 *    (what `wdrctl calibrate --json` and `fpn report` print) are the planted ones.
 * 3. the same over a matrix of chips: sizes, seeds, 1x and 2x mismatch (every mismatch figure of
 *    the board doubled, the margin with it), Reinhard and Drago; no healthy pixel flagged.
 * 4. weak hot pixels (extra dark current 1e-13 A, 1e-14 A): not flagged, and corrected: at the dark
 *    end their recovered current is within 1 % (analog) or within sqrt(1 %^2 + floor^2) (12 bits,
 *    the quantisation floor) of the truth, as healthy pixels are; the same through the forms
 *    --form auto gives at 12 bits (Reinhard compact, Drago shifted) where they hold (weak_hot_held).
 * 5. hot pixels at the simulator's 1e-11 A on Schlick, which the frames cannot always tell from a
 *    reset offset: those left unflagged are corrected within the 12-bit limit at the dark end.
 * `test_cal_defects plant` evaluates the weak hot pixels with 10x the extra dark current they were
 * calibrated with (a dark current the table does not correct): tests 4 and 5 must fail. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "cal_design.h"
#include "cal_form_measure.h"
#include "cal_select.h"
#include "operators.h"
#include "cal_test_support.h"

#define GRID_LO 1e-14
#define GRID_PER_DECADE 6
#define PROBE_FRAMES 2
#define MIN_SLOPE_CODES 2.0
#define N_CURRENTS 19
#define FRAMES_TARGET_PCT 0.5
#define FRAMES_MAX 64
#define DEFECT_PPM 100
#define MATRIX_PPM 500 /* 9-10 of each kind on 160x120, 1 (+ the corner) on 64x48 */
#define WEAK_HOT_PPM 1000
#define MAX_FALSE_PPM 10.0
#define ANALOG_LIMIT_PCT 1.0
#define N_DARK_END 7
/* A current whose 12-bit floor is 100 % or more is not resolved by the converters (one code step
 * spans a factor 2 of current or more): a pixel may read 0 A there where the truth is 1e-14 A, an
 * infinite log error that says nothing of its correction. Such currents are printed, not judged. */
#define UNRESOLVED_FLOOR_PCT 100.0
#define SIM_HOT_AMPS 1e-11 /* a hot pixel's dark current when the "defects" effect plants it (sim/wdr_sim.h) */

static const double dark_end[N_DARK_END] = {1e-14, 2e-14, 5e-14, 1e-13, 2e-13, 5e-13, 1e-12};

typedef struct chip_case {
    int w, h;
    uint64_t seed;
    double mismatch; /* every mismatch figure of the board times this */
    const char *op;
    int converters; /* ADC and DAC quantisation */
    int noise;      /* the board's temporal noise */
    int form_auto;  /* 1: the table form the board gets (wdrctl calibrate --form auto); 0: basis-8 */
} chip_case;

typedef struct chip {
    wdr_board b;
    wdr_sim *sim;
    uint8_t *lut;
    wdr_cal_simsrc ss;
    wdr_cal_source src;
    long np;
    const char *op;
    int form_auto, noise;
} chip;

static int vga;    /* argument "vga": the full board size */
static int plant;  /* argument "plant": the weak hot pixels' dark current rises after calibration */
static int matrix; /* argument "matrix": every cell */
/* argument "memory" (the sanitizers' run, tests/calibration/CMakeLists.txt): seed 1 only in each
 * sweep, so every code path runs under ASan and UBSan once; the Release run holds the figures. */
static int memory;
static int forms; /* argument "forms": weak hot pixels through the forms --form auto gives (measured only) */

/* A seed the "memory" run leaves out (each sweep keeps seed 1). */
static int memory_skips(uint64_t seed)
{
    return memory && seed > 1;
}

static void chip_open(chip *c, const chip_case *cc)
{
    char err[512];
    wdr_board_defaults(&c->b);
    c->b.width = (uint16_t)cc->w, c->b.height = (uint16_t)cc->h;
    c->b.avt_mv_um *= cc->mismatch, c->b.abeta_pct_um *= cc->mismatch;
    c->b.c_pd_sigma_pct *= cc->mismatch, c->b.dark_sigma_ln *= cc->mismatch;
    /* the margin grows with the thresholds' spread (issue 19 item 3 sizes it from the chip) */
    if (wdr_cal_sim_setup(&c->b, cc->op, cc->seed, cc->converters, WDR_CAL_MARGIN_V * cc->mismatch, &c->sim, &c->lut,
                          err, sizeof err))
        fail_msg("%s", err);
    if (!cc->converters)
        wdr_sim_set_effect(c->sim, WDR_FX_DAC_QUANT, WDR_FX_OFF);
    static const int temporal[] = {WDR_FX_SHOT, WDR_FX_KTC, WDR_FX_READ}; /* as the simulated board serves */
    for (int k = 0; cc->noise && k < 3; k++)
        wdr_sim_set_effect(c->sim, temporal[k], WDR_FX_ON);
    c->ss = (wdr_cal_simsrc){c->sim, cc->converters, 1000};
    c->src = (wdr_cal_source){c->b.width, c->b.height, wdr_cal_sim_capture, &c->ss};
    c->np = (long)cc->w * cc->h;
    c->op = cc->op;
    c->form_auto = cc->form_auto, c->noise = cc->noise;
}

static void chip_close(chip *c)
{
    wdr_sim_destroy(c->sim);
    free(c->lut);
}

/* --form auto as calibrate runs it (cal_form_choice.c): on fresh frames of this chip, the
 * smallest form that meets the target goes into res->cfg; the nearest when none does. */
static void choose_form(chip *c, wdr_cal_result *res, double lo, double hi, int frames)
{
    char err[512];
    wdr_form_trial tr[WDR_FORM_CANDIDATES];
    int nt;
    wdr_form_judging j = {WDR_FORM_JUDGING_CURRENTS, frames < 4 ? frames : 4, c->noise, 6000000};
    int k = wdr_form_choose_on_source(res, &c->src, lo, hi, &j, WDR_FORM_TARGET_DEFAULT, 1, 1, tr, &nt, NULL, err,
                                      sizeof err);
    if (k == -2)
        fail_msg("form auto: %s", err);
    if (k < 0)
        k = wdr_form_nearest(tr, nt);
    res->cfg.form = tr[k].form, res->cfg.n_coeffs = tr[k].n_coeffs;
}

/* Calibrate as `wdrctl calibrate` does; lv keeps the levels (the kinds are judged on them). */
static void calibrate_default(chip *c, wdr_cal_result *res, wdr_cal_levels *lv, int *frames)
{
    double amps[WDR_CAL_MAX_LEVELS], lo, hi, med[WDR_CAL_MAX_LEVELS];
    char err[512];
    int n = 6 * GRID_PER_DECADE + 1;
    for (int k = 0; k < n; k++)
        amps[k] = GRID_LO * pow(10, (double)k / GRID_PER_DECADE);
    wdr_cal_levels grid;
    assert_int_equal(wdr_cal_acquire(&c->src, amps, n, PROBE_FRAMES, 1, NULL, NULL, &grid, err, sizeof err), WDR_OK);
    assert_int_equal(wdr_cal_informative_range(&grid, MIN_SLOPE_CODES, &lo, &hi), WDR_OK);
    wdr_cal_config cfg;
    wdr_cal_config_defaults(&cfg, WDR_MODEL_SPLINE);
    cfg.range_lo = lo, cfg.range_hi = hi;
    const wdr_board *b = &c->b;
    cfg.step_codes = (b->dac_hi_v - b->dac_lo_v) / ((1u << b->dac_bits) - 1u) * b->adc_gain *
                     ((1u << b->adc_bits) - 1u) / (b->adc_hi_v - b->adc_lo_v);
    cfg.tie_codes = c->ss.quantised ? cfg.tie_codes : 1e-3;
    wdr_cal_choice ch;
    if (wdr_cal_select_currents(&grid, &cfg, N_CURRENTS, lo, hi, 256, &ch, err, sizeof err))
        fail_msg("selection: %s", err);
    wdr_cal_frames_choice fc;
    assert_int_equal(wdr_cal_level_medians(&grid, NULL, med), WDR_OK);
    assert_int_equal(wdr_cal_frames_for(&grid, med, lo, hi, 1.0, FRAMES_TARGET_PCT, FRAMES_MAX, &fc), WDR_OK);
    wdr_cal_levels_free(&grid);
    *frames = fc.frames;
    assert_int_equal(wdr_cal_acquire(&c->src, ch.amps, ch.n, fc.frames, 1, NULL, NULL, lv, err, sizeof err), WDR_OK);
    if (wdr_cal_fit_array(lv, &cfg, res, err, sizeof err))
        fail_msg("fit: %s", err);
    if (c->form_auto) /* the table form the board gets (wdrctl calibrate --form auto), on this chip's frames */
        choose_form(c, res, lo, hi, fc.frames);
}

/* ---- kinds, position by position ---- */

typedef struct kind_run {
    long np, planted[WDR_DEFECT_KINDS], right[WDR_DEFECT_KINDS], wrong, stuck_in_dark_band, healthy_flagged;
    long counts_wrong; /* kinds whose count (res.n_flag) differs from the expected */
    int frames;
} kind_run;

static uint8_t flag_of_kind(int kind)
{
    static const uint8_t flag[WDR_DEFECT_KINDS] = {0, WDR_PIX_DEAD, WDR_PIX_STUCK, WDR_PIX_HOT, WDR_PIX_SATURATED};
    return flag[kind];
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Where healthy pixels' dark outputs lie, from the truth: median and 1.4826 MAD over them. */
static void healthy_dark_band(const wdr_cal_levels *lv, const uint8_t *truth, long np, double *med, double *sigma)
{
    double *v = malloc(sizeof(double) * (size_t)np);
    long m = 0;
    for (long i = 0; i < np; i++)
        if (!truth[i])
            v[m++] = lv->dark[i];
    qsort(v, (size_t)m, sizeof *v, cmp_double);
    *med = v[m / 2];
    for (long i = 0; i < m; i++)
        v[i] = fabs(v[i] - *med);
    qsort(v, (size_t)m, sizeof *v, cmp_double);
    *sigma = 1.4826 * v[m / 2];
    free(v);
}

/* The kind a planted pixel must be given. A stuck node held where dark pixels read (within 6
 * robust sigma of the healthy dark outputs) gives a dead pixel's frames: it must be called dead. */
static uint8_t expected_flag(const wdr_cal_levels *lv, long np, long i, int kind, double dark_med, double dark_sigma)
{
    if (kind != WDR_DEFECT_STUCK)
        return flag_of_kind(kind);
    double mean = 0;
    for (int k = 0; k < lv->n; k++)
        mean += lv->frames[(long)k * np + i] / lv->n;
    return fabs(mean - dark_med) <= 6 * dark_sigma ? WDR_PIX_DEAD : WDR_PIX_STUCK;
}

static void judge_kinds(const wdr_cal_result *res, const wdr_cal_levels *lv, const uint8_t *truth, kind_run *r)
{
    double dark_med, dark_sigma;
    long expect_count[8] = {0};
    healthy_dark_band(lv, truth, r->np, &dark_med, &dark_sigma);
    for (long i = 0; i < r->np; i++) {
        int t = truth[i];
        if (!t) {
            r->healthy_flagged += res->flags[i] != 0;
            if (res->flags[i] && r->healthy_flagged <= 5)
                printf("# healthy pixel %ld flagged 0x%x (%s)\n", i, res->flags[i],
                       wdr_fit_status_name(res->status[i]));
            continue;
        }
        uint8_t want = expected_flag(lv, r->np, i, t, dark_med, dark_sigma);
        r->planted[t]++;
        r->stuck_in_dark_band += t == WDR_DEFECT_STUCK && want == WDR_PIX_DEAD;
        if (res->flags[i] == want)
            r->right[t]++;
        else if (r->wrong++ < 5)
            printf("# planted %s at %ld labelled 0x%x, want 0x%x\n", wdr_defect_name(t), i, res->flags[i], want);
        for (int b = 0; b < 8; b++)
            expect_count[b] += (want >> b) & 1;
    }
    for (long i = 0; i < r->np; i++) /* healthy flags (unfit) count as they are */
        for (int b = 0; !truth[i] && b < 8; b++)
            expect_count[b] += (res->flags[i] >> b) & 1;
    for (int b = 0; b < 8; b++)
        r->counts_wrong += res->n_flag[b] != expect_count[b];
}

static kind_run run_kinds(const chip_case *cc, double ppm)
{
    chip c;
    chip_open(&c, cc);
    assert_int_equal(plant_defects(c.sim, cc->w, cc->h, ppm), WDR_OK);
    kind_run r = {.np = c.np};
    uint8_t *truth = malloc((size_t)r.np);
    wdr_sim_defect_map(c.sim, truth);
    wdr_cal_result res;
    wdr_cal_levels lv;
    calibrate_default(&c, &res, &lv, &r.frames);
    judge_kinds(&res, &lv, truth, &r);
    char kinds[160];
    printf("# %dx%d seed %llu mismatch %gx %s: planted dead %ld, stuck %ld, hot %ld, saturated %ld; named right %ld, "
           "%ld, %ld, %ld (%ld stuck held in the dark band, named dead); wrong %ld; counts (%s)%s; healthy flagged %ld "
           "(%.2f ppm); %d frames\n",
           cc->w, cc->h, (unsigned long long)cc->seed, cc->mismatch, cc->op, r.planted[1], r.planted[2], r.planted[3],
           r.planted[4], r.right[1], r.right[2], r.right[3], r.right[4], r.stuck_in_dark_band, r.wrong,
           wdr_cal_flag_counts_text(res.n_flag, kinds, sizeof kinds), r.counts_wrong ? " WRONG" : "", r.healthy_flagged,
           1e6 * (double)r.healthy_flagged / (double)r.np, r.frames);
    wdr_cal_levels_free(&lv);
    wdr_cal_result_free(&res);
    free(truth);
    chip_close(&c);
    return r;
}

static void assert_kinds(const kind_run *r, double ppm, int w, int h)
{
    long per_kind = lround(ppm * (double)w * h / 1e6) + 1;
    for (int k = 1; k < WDR_DEFECT_KINDS; k++)
        assert_int_equal(r->planted[k], per_kind);
    assert_int_equal(r->wrong, 0);
    assert_int_equal(r->counts_wrong, 0);
    assert_true(1e6 * (double)r->healthy_flagged / (double)r->np <= MAX_FALSE_PPM);
}

static void clean_chip_flags_at_most_10ppm(void **state)
{
    (void)state;
    chip_case cc = {vga ? 640 : 320, vga ? 480 : 240, 5, 1, "reinhard", 1, 1, 0};
    chip c;
    chip_open(&c, &cc);
    wdr_cal_result res;
    wdr_cal_levels lv;
    int frames;
    calibrate_default(&c, &res, &lv, &frames);
    double ppm = 1e6 * (double)res.n_bad / (double)c.np;
    printf("# clean chip: %ld of %ld pixels flagged (%.2f ppm), %d frames per level\n", res.n_bad, c.np, ppm, frames);
    wdr_cal_levels_free(&lv);
    wdr_cal_result_free(&res);
    chip_close(&c);
    assert_true(ppm <= MAX_FALSE_PPM);
}

static void planted_defects_found_by_kind(void **state)
{
    (void)state;
    chip_case cc = {vga ? 640 : 320, vga ? 480 : 240, 5, 1, "reinhard", 1, 1, 0};
    kind_run r = run_kinds(&cc, DEFECT_PPM);
    assert_kinds(&r, DEFECT_PPM, cc.w, cc.h);
}

/* sim-qvga's size and a small chip, 3 seeds, 1x and 2x mismatch, Reinhard and Drago: every cell
 * with argument "matrix"; CTest runs the 64x48 cells and, at 160x120, Reinhard at 1x and Drago at
 * 2x (each seed). */
static void kinds_over_chips(void **state)
{
    (void)state;
    static const int sizes[][2] = {{160, 120}, {64, 48}};
    static const char *const ops[] = {"reinhard", "drago"};
    long worst_healthy = 0, stuck_dead = 0, planted = 0, cells = 0;
    for (int s = 0; s < 2; s++)
        for (uint64_t seed = 1; seed <= 3; seed++)
            for (int m = 1; m <= 2; m++)
                for (int o = 0; o < 2; o++) {
                    if ((!matrix && s == 0 && o != m - 1) || (memory && s == 0) || memory_skips(seed))
                        continue;
                    chip_case cc = {sizes[s][0], sizes[s][1], seed, m, ops[o], 1, 1, 0};
                    kind_run r = run_kinds(&cc, MATRIX_PPM);
                    assert_kinds(&r, MATRIX_PPM, cc.w, cc.h);
                    worst_healthy = r.healthy_flagged > worst_healthy ? r.healthy_flagged : worst_healthy;
                    stuck_dead += r.stuck_in_dark_band;
                    for (int k = 1; k < WDR_DEFECT_KINDS; k++)
                        planted += r.planted[k];
                    cells++;
                }
    printf("# %ld chips: %ld planted, every one named right (%ld stuck held in the dark band, named dead); worst "
           "healthy flagged %ld\n",
           cells, planted, stuck_dead, worst_healthy);
}

/* ---- weak hot pixels: corrected at the dark end ---- */

typedef struct weak_run {
    long planted, flagged, healthy_flagged;
    double hot_rms_pct[N_DARK_END], healthy_sd_pct[N_DARK_END], floor_pct[N_DARK_END], limit_pct[N_DARK_END];
    double worst_ratio; /* worst hot rms over its limit */
} weak_run;

static void plant_weak_hot(chip *c, double amps)
{
    wdr_sim_defects d = {.ppm = {0, 0, 0, WEAK_HOT_PPM, 0}, .seed = 77, .hot_amps = amps};
    assert_int_equal(wdr_sim_set_defects(c->sim, &d), WDR_OK);
}

/* A frame averaged over m frames at current x (numbers from first). */
static void averaged_frame(chip *c, double x, int m, int first, float *out, float *tmp)
{
    memset(out, 0, sizeof(float) * (size_t)c->np);
    for (int f = 0; f < m; f++) {
        assert_int_equal(c->src.capture(c->src.ctx, x, first + f, tmp), 0);
        for (long i = 0; i < c->np; i++)
            out[i] += tmp[i] / (float)m;
    }
}

/* rms over the weak hot pixels of ln(x_hat / x) less the healthy pixels' mean (their common
 * bias), and the healthy pixels' sd, in %. */
static void dark_end_errors(const double *x_hat, const uint8_t *truth, long np, double x, double *hot_rms,
                            double *healthy_sd)
{
    double s = 0, ss = 0, hs = 0;
    long n = 0, nh = 0;
    for (long i = 0; i < np; i++) {
        if (truth[i] || !isfinite(x_hat[i]))
            continue;
        double e = log(x_hat[i] / x);
        s += e, ss += e * e, n++;
    }
    double mean = s / (double)n;
    *healthy_sd = 100 * sqrt(fmax(ss / (double)n - mean * mean, 0));
    for (long i = 0; i < np; i++)
        if (truth[i] && isfinite(x_hat[i])) {
            double e = log(x_hat[i] / x) - mean;
            hs += e * e, nh++;
        }
    *hot_rms = nh ? 100 * sqrt(hs / (double)nh) : 0;
}

static weak_run run_weak_hot(const chip_case *cc, double amps)
{
    chip c;
    char err[512];
    chip_open(&c, cc);
    plant_weak_hot(&c, amps);
    weak_run r = {0};
    uint8_t *truth = malloc((size_t)c.np);
    wdr_sim_defect_map(c.sim, truth);
    wdr_cal_result res;
    wdr_cal_levels lv;
    int frames;
    calibrate_default(&c, &res, &lv, &frames);
    wdr_cal_levels_free(&lv);
    for (long i = 0; i < c.np; i++) {
        r.planted += truth[i] != 0;
        r.flagged += truth[i] && res.flags[i];
        r.healthy_flagged += !truth[i] && res.flags[i];
    }
    uint8_t *tb = NULL;
    size_t tl = 0;
    wdr_cal_view tab;
    wdr_cal_design design;
    if (wdr_cal_build_table(&res, 1, 1, &tb, &tl, err, sizeof err))
        fail_msg("table: %s", err);
    assert_int_equal(wdr_cal_parse(tb, tl, &tab), WDR_OK);
    const int middle_row = cc->h / 2; /* the row whose hold time the design assumes */
    assert_int_equal(wdr_cal_design_init(&design, &c.b, cc->op, wdr_sim_integration_time(c.sim),
                                         middle_row * c.b.row_time_s, 1, err, sizeof err),
                     WDR_OK);
    if (plant) /* the plant: a dark current 10x the one calibrated, which the table does not correct */
        plant_weak_hot(&c, 10 * amps);
    float *frame = malloc(sizeof(float) * (size_t)c.np), *tmp = malloc(sizeof(float) * (size_t)c.np);
    double *x_hat = malloc(sizeof(double) * (size_t)c.np);
    for (int k = 0; k < N_DARK_END; k++) {
        averaged_frame(&c, dark_end[k], frames, 50000 + 100 * k, frame, tmp);
        assert_int_equal(wdr_fpn_recover(&res, &tab, WDR_PATH_TABLE, frame, res.flags, x_hat), WDR_OK);
        dark_end_errors(x_hat, truth, c.np, dark_end[k], &r.hot_rms_pct[k], &r.healthy_sd_pct[k]);
        r.floor_pct[k] = cc->converters ? wdr_quant_floor_pct(wdr_cal_design_log_slope(&design, dark_end[k]),
                                                              wdr_cal_design_dac_step_codes(&design, dark_end[k]))
                                        : 0;
        r.limit_pct[k] = hypot(ANALOG_LIMIT_PCT, r.floor_pct[k]);
        if (r.floor_pct[k] < UNRESOLVED_FLOOR_PCT) /* see UNRESOLVED_FLOOR_PCT */
            r.worst_ratio = fmax(r.worst_ratio, r.hot_rms_pct[k] / r.limit_pct[k]);
    }
    printf("# %dx%d seed %llu %s %s, form %d/%d coefficients, extra dark current %.0e A: %ld weak hot pixels, %ld "
           "flagged; healthy flagged %ld; %d frames\n#   x (A), weak hot rms %%, healthy sd %%, floor %%, limit %%:",
           cc->w, cc->h, (unsigned long long)cc->seed, cc->op, cc->converters ? "12-bit" : "analog", res.cfg.form,
           res.cfg.n_coeffs, amps, r.planted, r.flagged, r.healthy_flagged, frames);
    for (int k = 0; k < N_DARK_END; k++)
        printf(" | %.0e %.3f %.3f %.3f %.3f", dark_end[k], r.hot_rms_pct[k], r.healthy_sd_pct[k], r.floor_pct[k],
               r.limit_pct[k]);
    printf("\n#   worst weak hot rms over its limit: %.3f\n", r.worst_ratio);
    free(frame), free(tmp), free(x_hat), free(tb), free(truth);
    wdr_cal_result_free(&res);
    chip_close(&c);
    return r;
}

/* Where a weak hot pixel's correction is held: every cell but Drago at 1e-13 A (the basis-8 table
 * leaves +2..4.5 % there, 1.1x the 12-bit limit, where the spline model itself is exact; the
 * shifted table Drago gets from --form auto 1.9-2.2x). Through the forms --form auto gives, only
 * at 12 bits, the board's converters: analog, Drago's shifted table is 1.4x at both currents. */
static int weak_hot_held(double amps, const char *op, int converters, int form_auto)
{
    int drago = !strcmp(op, "drago");
    return !(amps > 5e-14 && drago) && !(form_auto && drago && !converters);
}

/* One weak hot cell; folds its ratio into *worst (held) or *worst_open (printed only). */
static void weak_hot_cell(const chip_case *cc, double amps, double *worst, double *worst_open)
{
    weak_run r = run_weak_hot(cc, amps);
    assert_int_equal(r.healthy_flagged, 0);
    if (weak_hot_held(amps, cc->op, cc->converters, cc->form_auto))
        *worst = fmax(*worst, r.worst_ratio);
    else
        *worst_open = fmax(*worst_open, r.worst_ratio), printf("#   (open: not asserted)\n");
}

/* 1e-13 and 1e-14 A of extra dark current, 3 seeds, Reinhard and Drago, 12 bits (and analog on
 * seed 1; every cell with "matrix"), temporal noise off (the floor is the figure), basis-8 table,
 * or with "forms" the forms --form auto gives. Held where weak_hot_held says. */
static void weak_hot_corrected_at_dark_end(void **state)
{
    (void)state;
    static const double extra[] = {1e-13, 1e-14};
    static const char *const ops[] = {"reinhard", "drago"};
    double worst = 0, worst_open = 0;
    for (int e = 0; e < 2; e++)
        for (uint64_t seed = 1; seed <= 3; seed++)
            for (int o = 0; o < 2; o++)
                for (int q = 0; q <= 1; q++) {
                    if ((!matrix && !q && seed != 1) || (memory && !q) || memory_skips(seed))
                        continue;
                    chip_case cc = {160, 120, seed, 1, ops[o], q, 0, forms};
                    weak_hot_cell(&cc, extra[e], &worst, &worst_open);
                }
    printf("# weak hot pixels: worst rms over the limit %.3f where asserted (must be <= 1); %.3f where open\n", worst,
           worst_open);
    assert_true(worst <= 1.0);
}

/* The same through the tables the board gets (--form auto at 12 bits): Reinhard's compact at
 * 1e-13 A and Drago's shifted at 1e-14 A, seed 1 (the whole sweep: argument "forms"; measured
 * 0.42-0.52x and 0.68-0.74x on seeds 1-3). */
static void weak_hot_through_board_forms(void **state)
{
    (void)state;
    double worst = 0, worst_open = 0;
    const chip_case reinhard = {160, 120, 1, 1, "reinhard", 1, 0, 1}, drago = {160, 120, 1, 1, "drago", 1, 0, 1};
    if (forms || memory)
        skip(); /* "forms" runs them all above; under the sanitizers the basis-8 sweep covers the code */
    weak_hot_cell(&reinhard, 1e-13, &worst, &worst_open);
    weak_hot_cell(&drago, 1e-14, &worst, &worst_open);
    printf("# weak hot pixels through the board's forms: worst rms over the limit %.3f (must be <= 1)\n", worst);
    assert_true(worst <= 1.0);
}

/* Hot pixels at the simulator's own hot current (1e-11 A, what the "defects" effect plants) on
 * Schlick, whose dark end is nearly linear: there a dark current moves the whole response by a
 * near-constant code, as a reset offset does, so the frames cannot always tell it (on sim-qvga
 * one of three planted at 1x sits 7.9 robust sigma from the dark median, under the 8 sigma limit;
 * at 2x the sigma doubles). Those left unflagged must be corrected as healthy pixels are: within
 * the limit at the dark end. 160x120, seeds 1-3, 1x and 2x mismatch, 12 bits, noise off. */
static void hot_pixels_left_unflagged_are_corrected(void **state)
{
    (void)state;
    double worst = 0;
    long planted = 0, flagged = 0;
    for (uint64_t seed = 1; seed <= 3 && !memory_skips(seed); seed++)
        for (int m = 1; m <= 2; m++) {
            chip_case cc = {160, 120, seed, m, "schlick", 1, 0, 0};
            weak_run r = run_weak_hot(&cc, SIM_HOT_AMPS);
            assert_int_equal(r.healthy_flagged, 0);
            worst = fmax(worst, r.worst_ratio);
            planted += r.planted, flagged += r.flagged;
        }
    printf("# Schlick, hot pixels at %.0e A: %ld of %ld flagged; those left: worst rms over the limit %.3f (must be "
           "<= 1)\n",
           SIM_HOT_AMPS, flagged, planted, worst);
    assert_true(worst <= 1.0);
}

int main(int argc, char **argv)
{
    for (int a = 1; a < argc; a++) {
        vga |= !strcmp(argv[a], "vga");
        plant |= !strcmp(argv[a], "plant");
        matrix |= !strcmp(argv[a], "matrix");
        memory |= !strcmp(argv[a], "memory");
        forms |= !strcmp(argv[a], "forms");
        if (!strncmp(argv[a], "only=", 5)) /* one test by name (cmocka's filter) */
            cmocka_set_test_filter(argv[a] + 5);
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(clean_chip_flags_at_most_10ppm),
        cmocka_unit_test(planted_defects_found_by_kind),
        cmocka_unit_test(kinds_over_chips),
        cmocka_unit_test(weak_hot_corrected_at_dark_end),
        cmocka_unit_test(weak_hot_through_board_forms),
        cmocka_unit_test(hot_pixels_left_unflagged_are_corrected),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
