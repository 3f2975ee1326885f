/* bench_target's accuracy half: the worst contrast error each table form leaves on every one of
 * the seven operators, analog case (no DAC steps, no ADC codes, temporal noise off), through the
 * kernel's own arithmetic (wdr_correct_row_f32: for COMPACT the controller's fixed-point sums).
 * The setup of tests/calibration/test_cal_sim.c: 64x48 chip, seed 11, 19 currents over the range
 * where the operator carries contrast, judged on 31 fresh currents between them. */
#ifndef BENCH_TARGET_STUDY_H
#define BENCH_TARGET_STUDY_H
#include "cal_select.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#define STUDY_W 64 /* the default chip; study_open_chip takes any */
#define STUDY_H 48
#define STUDY_SEED 11
#define STUDY_TEST 31
#define STUDY_OPS 7

static const char *const study_ops[STUDY_OPS] = {"reinhard", "reinhard_white", "schlick",    "tumblin_rushmeier",
                                                 "drago",    "exponential",    "logarithmic"};

typedef struct study_chip {
    int w, h;
    wdr_sim *sim;
    uint8_t *lut;
    wdr_cal_simsrc ss;
    wdr_cal_source src;
    wdr_cal_levels grid;
    double lo, hi, x[STUDY_TEST];
} study_chip;

/* A w x h chip of the given seed under operator op, every mismatch figure of the board times
 * mismatch (1: the board's). */
static inline int study_open_chip_mismatch(study_chip *c, const char *op, int w, int h, uint32_t seed, double mismatch)
{
    wdr_board b;
    char err[512];
    wdr_board_defaults(&b);
    b.width = w, b.height = h;
    b.avt_mv_um *= mismatch, b.abeta_pct_um *= mismatch, b.c_pd_sigma_pct *= mismatch, b.dark_sigma_ln *= mismatch;
    c->w = w, c->h = h;
    if (wdr_cal_sim_setup(&b, op, seed, 0, 0.06 * mismatch, &c->sim, &c->lut, err,
                          sizeof err)) /* margin grows with the spread */
        return fprintf(stderr, "bench_target: %s: %s\n", op, err), 1;
    wdr_sim_set_effect(c->sim, WDR_FX_DAC_QUANT, WDR_FX_OFF);
    c->ss = (wdr_cal_simsrc){c->sim, 0, 500};
    c->src = (wdr_cal_source){w, h, wdr_cal_sim_capture, &c->ss};
    double amps[37];
    for (int k = 0; k < 37; k++)
        amps[k] = 1e-14 * pow(10, k / 6.0);
    if (wdr_cal_acquire(&c->src, amps, 37, 1, 1, NULL, NULL, &c->grid, err, sizeof err) ||
        wdr_cal_informative_range(&c->grid, 2.0, &c->lo, &c->hi))
        return fprintf(stderr, "bench_target: %s: acquisition failed\n", op), 1;
    for (int k = 0; k < STUDY_TEST; k++)
        c->x[k] = c->lo * pow(c->hi / c->lo, (k + 0.37) / STUDY_TEST);
    return 0;
}

static inline int study_open_chip(study_chip *c, const char *op, int w, int h, uint32_t seed)
{
    return study_open_chip_mismatch(c, op, w, h, seed, 1);
}
static inline int study_open(study_chip *c, const char *op)
{
    return study_open_chip(c, op, STUDY_W, STUDY_H, STUDY_SEED);
}

static inline void study_close(study_chip *c)
{
    wdr_cal_levels_free(&c->grid);
    wdr_sim_destroy(c->sim);
    free(c->lut);
}

/* Fit with model over n_cur currents of the chip's range. */
static inline int study_fit(study_chip *c, int model, int n_cur, wdr_cal_result *res)
{
    char err[512];
    wdr_cal_config cfg;
    wdr_cal_choice ch;
    wdr_cal_levels lv;
    wdr_cal_config_defaults(&cfg, model);
    cfg.range_lo = c->lo, cfg.range_hi = c->hi, cfg.tie_codes = 1e-3; /* unquantised: only a clip ties */
    if (wdr_cal_select_currents(&c->grid, &cfg, n_cur, c->lo, c->hi, 64, &ch, err, sizeof err) ||
        wdr_cal_levels_from_choice(&c->grid, &ch, &lv))
        return fprintf(stderr, "bench_target: select: %s\n", err), 1;
    int rc = wdr_cal_fit_array(&lv, &cfg, res, err, sizeof err);
    lv.dark = NULL;
    wdr_cal_levels_free(&lv);
    return rc ? (fprintf(stderr, "bench_target: fit: %s\n", err), 1) : 0;
}

/* Worst contrast error (%) of a table of form/n from the fit, on the chip's test currents. */
static inline double study_worst(study_chip *c, const wdr_cal_result *res, int form, int n)
{
    char err[512];
    uint8_t *tb;
    size_t tl;
    wdr_cal_view tab;
    wdr_fpn_stats t[STUDY_TEST];
    wdr_cal_result alt = *res; /* the builder only reads the fit */
    alt.cfg.form = form, alt.cfg.n_coeffs = n;
    if (wdr_cal_build_table(&alt, 1, 1, &tb, &tl, err, sizeof err))
        return NAN;
    double worst = NAN;
    if (!wdr_cal_parse(tb, tl, &tab) && !wdr_cal_evaluate(res, &tab, &c->src, c->x, STUDY_TEST, NULL, NULL, t)) {
        worst = 0;
        for (int k = 0; k < STUDY_TEST; k++)
            worst = fmax(worst, t[k].sd_pct);
    }
    free(tb);
    return worst;
}

#endif
