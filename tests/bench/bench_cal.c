/* Accuracy vs time for calibration: per model, the fit time per megapixel and the residual
 * contrast error it leaves (worst over 31 currents, 1e-14..1e-8 A, 100 sd of ln(x_hat/x) by
 * host/cal/metrics/cal_metrics.h as wdrctl fpn report, on the simulator with default mismatch, static
 * effects on, temporal noise off), analog (no DAC/ADC quantisation) and with the 12-bit converters
 * beside the model's floor; and for the N-current spline, how the number of calibration currents
 * trades frames for accuracy, through the study engine (host/study, `wdrctl study`) with the
 * converters and noise on. Prints tables; asserts nothing about speed. --quick uses a small chip. */
#include "bench_util.h"
#include "cal_design.h"
#include "cal_select.h"
#include "study.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct setup {
    wdr_sim *sim;
    uint8_t *lut;
    wdr_cal_simsrc ss;
    wdr_cal_source src;
    wdr_cal_levels grid;
    wdr_cal_design design;
    int quantised;
} setup;

static int open_chip_q(setup *s, int w, int h, const char *op, int quantised)
{
    wdr_board b;
    char err[512];
    wdr_board_defaults(&b);
    b.width = (uint16_t)w, b.height = (uint16_t)h;
    s->quantised = quantised;
    if (wdr_cal_sim_setup(&b, op, 3, quantised, 0.06, &s->sim, &s->lut, err, sizeof err) ||
        wdr_cal_design_init(&s->design, &b, op, wdr_sim_integration_time(s->sim), h / 2 * b.row_time_s, 1, err,
                            sizeof err)) {
        fprintf(stderr, "bench_cal: %s\n", err);
        return 1;
    }
    if (!quantised)
        wdr_sim_set_effect(s->sim, WDR_FX_DAC_QUANT, WDR_FX_OFF);
    s->ss = (wdr_cal_simsrc){s->sim, quantised, 77};
    s->src = (wdr_cal_source){w, h, wdr_cal_sim_capture, &s->ss};
    double amps[37];
    for (int k = 0; k < 37; k++)
        amps[k] = 1e-14 * pow(10, k / 6.0);
    if (wdr_cal_acquire(&s->src, amps, 37, 1, 1, NULL, NULL, &s->grid, err, sizeof err)) {
        fprintf(stderr, "bench_cal: %s\n", err);
        return 1;
    }
    return 0;
}

static int open_chip(setup *s, int w, int h, const char *op) { return open_chip_q(s, w, h, op, 0); }

static void close_chip(setup *s)
{
    wdr_cal_levels_free(&s->grid);
    wdr_sim_destroy(s->sim);
    free(s->lut);
}

typedef struct result {
    double fit_s_per_mp, table_s_per_mp, worst_model, worst_table;
    double table_pct[31], floor_pct[31]; /* per judging current */
    double worst_poly; /* a BASIS run: the poly-5 table from the same fit */
    long bad;
} result;

/* Worst table-path error of a table of another form built from the same fit. */
static double other_form_worst(const wdr_cal_result *res, const wdr_cal_source *src, const double *x, int form,
                               int n_coeffs)
{
    char err[512];
    uint8_t *tb;
    size_t tl;
    wdr_cal_view tab;
    wdr_fpn_stats t[31];
    wdr_cal_result alt = *res; /* the builder only reads the fit */
    alt.cfg.form = form, alt.cfg.n_coeffs = n_coeffs;
    if (wdr_cal_build_table(&alt, 1, 1, &tb, &tl, err, sizeof err) || wdr_cal_parse(tb, tl, &tab))
        return NAN;
    double worst = 0;
    if (!wdr_cal_evaluate(res, &tab, src, x, 31, NULL, NULL, t))
        for (int k = 0; k < 31; k++)
            worst = fmax(worst, t[k].sd_pct);
    free(tb);
    return worst;
}

/* Model and table contrast error at the judging currents, by wdr_eval_point_measure (one frame:
 * temporal noise is off), with the quantisation floor when the chip is quantised. */
static void worst_of(const wdr_cal_result *res, const wdr_cal_view *tab, setup *acc, const double *x, double *table_pct,
                     double *floor_pct, double *worst_model, double *worst_table)
{
    wdr_eval_opts eo = {.frames = 1, .quantised = acc->quantised, .design = &acc->design};
    *worst_model = *worst_table = 0;
    for (int k = 0; k < 31; k++) {
        wdr_eval_point p;
        eo.first_frame_no = 1000 + k;
        if (wdr_eval_point_measure(res, tab, &acc->src, x[k], &eo, &p)) {
            *worst_model = *worst_table = NAN;
            return;
        }
        table_pct[k] = p.table.sd_pct, floor_pct[k] = p.floor_pct;
        *worst_model = fmax(*worst_model, p.model.sd_pct);
        *worst_table = fmax(*worst_table, p.table.sd_pct);
    }
}

/* Fit on the timing chip, judge contrast on the accuracy chip (same currents). */
static int run(setup *timing, setup *acc, wdr_cal_config *cfg, const wdr_cal_choice *ch, result *r)
{
    char err[512];
    wdr_cal_levels lv;
    wdr_cal_result res;
    uint8_t *tb;
    size_t tl;
    wdr_cal_view tab;
    long np = (long)timing->src.width * timing->src.height;
    if (wdr_cal_levels_from_choice(&timing->grid, ch, &lv))
        return 1;
    double t0 = now_s();
    int rc = wdr_cal_fit_array(&lv, cfg, &res, err, sizeof err);
    double t1 = now_s();
    rc = rc ? rc : wdr_cal_build_table(&res, 1, 1, &tb, &tl, err, sizeof err);
    double t2 = now_s();
    lv.dark = NULL;
    wdr_cal_levels_free(&lv);
    if (rc) {
        fprintf(stderr, "bench_cal: %s\n", err);
        return 1;
    }
    r->fit_s_per_mp = (t1 - t0) * 1e6 / np;
    r->table_s_per_mp = (t2 - t1) * 1e6 / np;
    free(tb);
    wdr_cal_result_free(&res);
    /* accuracy on the small chip */
    if (wdr_cal_levels_from_choice(&acc->grid, ch, &lv) || wdr_cal_fit_array(&lv, cfg, &res, err, sizeof err) ||
        wdr_cal_build_table(&res, 1, 1, &tb, &tl, err, sizeof err) || wdr_cal_parse(tb, tl, &tab))
        return 1;
    double x[31];
    for (int k = 0; k < 31; k++)
        x[k] = cfg->range_lo * pow(cfg->range_hi / cfg->range_lo, (k + 0.37) / 31);
    worst_of(&res, &tab, acc, x, r->table_pct, r->floor_pct, &r->worst_model, &r->worst_table);
    r->bad = res.n_bad;
    r->worst_poly = cfg->form == WDR_FORM_BASIS ? other_form_worst(&res, &acc->src, x, WDR_FORM_POLY, 5) : NAN;
    lv.dark = NULL;
    wdr_cal_levels_free(&lv);
    wdr_cal_result_free(&res);
    free(tb);
    return 0;
}

/* How the number of calibration currents trades frames for accuracy is a knob of the study
 * (`wdrctl study --levels`): this section is a thin wrapper over it, so it is judged as the
 * study judges, with the 12-bit converters and temporal noise on and 16 frames per level. */
static int levels_through_study(int quick)
{
    study_knobs k = {.model = "spline", .form = "poly", .levels = quick ? "5,19" : "5,7,10,13,19,25", .frames = "16"};
    study s = {.board = "sim-vga", .range_lo = 1e-14, .range_hi = 1e-8, .fps = 30, .seed = 1, .jobs = 2};
    int skipped;
    double wall;
    if (study_expand(&k, &s, &skipped) || study_run(&s, 0, &wall))
        return 1;
    printf("\nNumber of calibration currents (spline, poly-5 table; wdrctl study --levels: 12-bit converters,\n"
           "noise on, 16 frames per level, 64x48): frames to capture vs residual error\n");
    printf("%8s %8s %12s %12s %12s %12s %12s\n", "currents", "frames", "board cal s", "fit s/MP", "FPN err%",
           "total err%", "floor%");
    for (int i = 0; i < s.n; i++) {
        const study_result *r = &s.res[i];
        if (!r->ok)
            return fprintf(stderr, "bench_cal: study point %d: %s\n", i, r->why), 1;
        printf("%8d %8d %12.3f %12.3f %12.4f %12.4f %12.4f\n", s.pts[i].n_levels, (s.pts[i].n_levels + 1) * 16,
               r->cal_s, r->fit_s_per_mp, r->worst_fpn_pct, r->worst_total_pct, r->floor_pct);
    }
    free(s.pts), free(s.res);
    return 0;
}

typedef struct model_row {
    const char *name;
    int model, form, n_coeffs, n_currents;
} model_row;

static const model_row rows[] = {
    {"3-parameter (eq. 19-20), Moebius table", WDR_MODEL_SIMPLE3, WDR_FORM_MOEBIUS, 3, 3},
    {"4-parameter (eq. 23-25), poly-5 table", WDR_MODEL_COMPLEX4, WDR_FORM_POLY, 5, 4},
    {"LSQ physical basis, 19 currents, poly-5", WDR_MODEL_LSQ, WDR_FORM_POLY, 5, 19},
    {"poly map, 19 currents, poly-5", WDR_MODEL_POLYMAP, WDR_FORM_POLY, 5, 19},
    {"spline, 19 currents, poly-5 table", WDR_MODEL_SPLINE, WDR_FORM_POLY, 5, 19},
    {"spline, 19 currents, basis-8 table", WDR_MODEL_SPLINE, WDR_FORM_BASIS, 8, 19},
};

int main(int argc, char **argv)
{
    int quick = argc > 1 && !strcmp(argv[1], "--quick");
    int tw = quick ? 64 : 320, th = quick ? 48 : 240;
    setup timing, acc, acc12;
    char err[512];
    if (open_chip(&acc, 64, 48, "reinhard") || open_chip(&timing, tw, th, "reinhard") ||
        open_chip_q(&acc12, 64, 48, "reinhard", 1))
        return 1;
    printf("Calibration accuracy vs time (Reinhard, simulator, temporal noise off)\n");
    printf("fit timed on %dx%d (analog), contrast judged on 64x48 at 31 currents 1e-14..1e-8 A: analog (ADC and DAC\n"
           "quantisation off) and with the 12-bit ADC and DAC; 'x floor' is the 12-bit worst over the model's floor,\n"
           "sqrt(analog^2 + quantisation floor^2) at each current\n\n", tw, th);
    printf("%-42s %6s %10s %10s %11s %11s %11s %8s %5s\n", "model", "frames", "fit s/MP", "table s/MP", "model err%",
           "table err%", "12-bit err%", "x floor", "bad");
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        wdr_cal_config cfg, cfg12;
        wdr_cal_choice ch, ch12;
        result r, r12;
        wdr_cal_config_defaults(&cfg, rows[i].model);
        cfg.form = rows[i].form, cfg.n_coeffs = rows[i].n_coeffs;
        cfg.range_lo = 1e-14, cfg.range_hi = 1e-8;
        cfg12 = cfg;
        cfg.tie_codes = 1e-3, cfg.design = &acc.design, cfg12.design = &acc12.design;
        /* --quick (CI) skips the slow global fits at 12 bits: their selection refits LSQ per candidate */
        int skip12 = quick && (rows[i].model == WDR_MODEL_LSQ || rows[i].model == WDR_MODEL_POLYMAP);
        if (wdr_cal_select_currents(&acc.grid, &cfg, rows[i].n_currents, 1e-14, 1e-8, 256, &ch, err, sizeof err) ||
            run(&timing, &acc, &cfg, &ch, &r) ||
            (!skip12 && (wdr_cal_select_currents(&acc12.grid, &cfg12, rows[i].n_currents, 1e-14, 1e-8, 256, &ch12,
                                                 err, sizeof err) ||
                         run(&acc12, &acc12, &cfg12, &ch12, &r12)))) {
            fprintf(stderr, "bench_cal: %s: %s\n", rows[i].name, err);
            return 1;
        }
        double ratio = NAN;
        if (skip12)
            r12.worst_table = NAN;
        for (int k = 0; !skip12 && k < 31; k++)
            ratio = fmax(k ? ratio : 0, r12.table_pct[k] / hypot(r.table_pct[k], r12.floor_pct[k]));
        printf("%-42s %6d %10.3f %10.3f %11.4f %11.4f %11.3f %8.2f %5ld\n", rows[i].name, ch.n, r.fit_s_per_mp,
               r.table_s_per_mp, r.worst_model, r.worst_table, r12.worst_table, ratio, r.bad);
    }
    close_chip(&acc12);
    if (levels_through_study(quick))
        return 1;
    printf("\nEvery operator (spline, 19 currents over the operator's informative range, 64x48, analog):\n"
           "the default basis-8 table and a poly-5 table from the same fit\n");
    printf("%-18s %22s %12s %12s %12s %6s\n", "operator", "range (A)", "model err%", "basis-8 err%", "poly-5 err%",
           "bad");
    static const char *ops[] = {"reinhard", "reinhard_white", "schlick", "tumblin_rushmeier", "drago", "exponential",
                                "logarithmic"};
    for (size_t i = 0; i < sizeof ops / sizeof ops[0]; i++) {
        setup s;
        wdr_cal_config cfg;
        wdr_cal_choice ch;
        result r;
        double lo, hi;
        if (open_chip(&s, 64, 48, ops[i]) || wdr_cal_informative_range(&s.grid, 2.0, &lo, &hi))
            return 1;
        wdr_cal_config_defaults(&cfg, WDR_MODEL_SPLINE);
        cfg.range_lo = lo, cfg.range_hi = hi, cfg.tie_codes = 1e-3;
        if (wdr_cal_select_currents(&s.grid, &cfg, 19, lo, hi, 64, &ch, err, sizeof err) || run(&s, &s, &cfg, &ch, &r))
            return 1;
        printf("%-18s %10.3g..%-10.3g %12.4f %12.4f %12.4f %6ld\n", ops[i], lo, hi, r.worst_model, r.worst_table,
               r.worst_poly, r.bad);
        close_chip(&s);
    }
    close_chip(&acc);
    close_chip(&timing);
    return 0;
}
