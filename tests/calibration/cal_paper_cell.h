/* One cell of the paper models' matrix (issue 19): a simulated chip calibrated the way `wdrctl
 * calibrate --model simple3|complex4` does it (host/wdrctl/cal_common.c: a two-frame probe of the
 * 37-level grid with a dark frame, the informative range, 5 currents chosen by
 * wdr_cal_select_currents, --frames auto, the fit), and what came of it: refused (and why), or the
 * pixels flagged by reason. Shared by test_cal_paper_cells and tests/bench/bench_paper_cells. */
#ifndef CAL_PAPER_CELL_H
#define CAL_PAPER_CELL_H
#include "cal_design.h"
#include "cal_engine.h"
#include "cal_select.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PAPER_CELL_GRID_LO 1e-14
#define PAPER_CELL_GRID_LEVELS 37 /* 6 decades, 6 per decade: calibrate's probe grid */
#define PAPER_CELL_PROBE_FRAMES 2
#define PAPER_CELL_MIN_SLOPE 2.0
#define PAPER_CELL_FRAMES_PCT 0.5
#define PAPER_CELL_FRAMES_MAX 64

typedef struct paper_cell {
    const char *board; /* a board name or board.json; NULL: the defaults (sim-vga) */
    int width, height; /* 0: the board's */
    double mismatch;   /* every mismatch figure of the board times this (0: 1) */
    double margin_v;   /* the LUT's calibration margin (0: WDR_CAL_MARGIN_V, as calibrate) */
    const char *op;
    int model, adc, noise; /* adc: the ADC and DAC quantise (12 bits) or neither (analog) */
    uint64_t seed;
    int n_currents; /* 0: 5, calibrate's default for the paper models */
} paper_cell;

enum { PAPER_CELL_FITTED, PAPER_CELL_REFUSED_DESIGN, PAPER_CELL_REFUSED_PROBE, PAPER_CELL_ERROR };

typedef struct paper_cell_result {
    int outcome;   /* PAPER_CELL_* */
    char why[512]; /* the refusal or the error */
    long np, flagged, by_status[WDR_FIT_COUNT];
    int frames;
    wdr_cal_choice choice;
    double lo, hi;
} paper_cell_result;

static inline const char *paper_cell_outcome_name(int o)
{
    return o == PAPER_CELL_FITTED           ? "fitted"
           : o == PAPER_CELL_REFUSED_DESIGN ? "refused (design)"
           : o == PAPER_CELL_REFUSED_PROBE  ? "refused (probe)"
                                            : "error";
}

static inline int paper_cell_fail(paper_cell_result *r, int outcome, const char *what, const char *err)
{
    size_t cap = sizeof r->why - 1, a = strlen(what), b = strlen(err); /* a long reason is cut */
    a = a < cap ? a : cap;
    b = b < cap - a ? b : cap - a;
    memcpy(r->why, what, a);
    memcpy(r->why + a, err, b);
    r->why[a + b] = 0;
    return r->outcome = outcome;
}

static inline int paper_cell_open(const paper_cell *c, wdr_board *b, wdr_sim **sim, uint8_t **lut, wdr_cal_design *d,
                                  char *err, int errlen)
{
    wdr_board_defaults(b);
    if (c->board && wdr_board_load_named(c->board, b, err, errlen))
        return 1;
    if (c->width)
        b->width = (uint16_t)c->width, b->height = (uint16_t)c->height;
    double k = c->mismatch > 0 ? c->mismatch : 1;
    b->avt_mv_um *= k, b->abeta_pct_um *= k, b->c_pd_sigma_pct *= k, b->dark_sigma_ln *= k;
    if (wdr_cal_sim_setup(b, c->op, c->seed, c->adc, c->margin_v > 0 ? c->margin_v : WDR_CAL_MARGIN_V, sim, lut, err,
                          errlen))
        return 1;
    if (!c->adc)
        wdr_sim_set_effect(*sim, WDR_FX_DAC_QUANT, WDR_FX_OFF);
    static const int temporal[] = {WDR_FX_SHOT, WDR_FX_KTC, WDR_FX_READ};
    for (int j = 0; c->noise && j < 3; j++)
        wdr_sim_set_effect(*sim, temporal[j], WDR_FX_ON);
    return wdr_cal_design_init(d, b, c->op, wdr_sim_integration_time(*sim), b->height / 2 * b->row_time_s, 1, err,
                               errlen) != WDR_OK;
}

/* calibrate's configuration of a paper model for this chip (cal_set_output, cal_set_step). */
static inline void paper_cell_config(const paper_cell *c, const wdr_board *b, const wdr_cal_design *d,
                                     wdr_cal_config *cfg)
{
    wdr_cal_config_defaults(cfg, c->model);
    cfg->raw_max = (1u << b->adc_bits) - 1u;
    cfg->out_max = (uint16_t)cfg->raw_max;
    if (c->adc)
        cfg->step_codes = (b->dac_hi_v - b->dac_lo_v) / ((1u << b->dac_bits) - 1u) * b->adc_gain *
                          ((1u << b->adc_bits) - 1u) / (b->adc_hi_v - b->adc_lo_v);
    cfg->tie_codes = c->adc ? cfg->tie_codes : 1e-3;
    cfg->design = d;
}

/* The calibration with the probe's choice: acquire, the dark frame as level 0, fit, count. */
static inline int paper_cell_fit(const paper_cell *c, const wdr_cal_source *src, const wdr_cal_config *cfg,
                                 paper_cell_result *r)
{
    char err[512];
    wdr_cal_levels lv, with_dark;
    int idx[WDR_CAL_MAX_LEVELS], n = r->choice.n - 1;
    (void)c;
    if (wdr_cal_acquire(src, r->choice.amps + 1, n, r->frames, 1, NULL, NULL, &lv, err, sizeof err))
        return paper_cell_fail(r, PAPER_CELL_ERROR, "acquire: ", err);
    idx[0] = -1;
    for (int k = 0; k < n; k++)
        idx[k + 1] = k;
    if (wdr_cal_levels_subset(&lv, idx, n + 1, &with_dark))
        return paper_cell_fail(r, PAPER_CELL_ERROR, "out of memory", "");
    with_dark.dark = lv.dark;
    wdr_cal_result res;
    int rc = wdr_cal_fit_array(&with_dark, cfg, &res, err, sizeof err);
    with_dark.dark = NULL;
    wdr_cal_levels_free(&with_dark);
    wdr_cal_levels_free(&lv);
    if (rc)
        return paper_cell_fail(r, PAPER_CELL_ERROR, "fit: ", err);
    r->flagged = res.n_bad;
    for (int s = 0; s < WDR_FIT_COUNT; s++)
        r->by_status[s] = res.n_status[s];
    wdr_cal_result_free(&res);
    return r->outcome = PAPER_CELL_FITTED;
}

static inline int paper_cell_run(const paper_cell *c, paper_cell_result *r)
{
    wdr_board b;
    wdr_sim *sim = NULL;
    uint8_t *lut = NULL;
    wdr_cal_design d;
    char err[512];
    memset(r, 0, sizeof *r);
    if (paper_cell_open(c, &b, &sim, &lut, &d, err, sizeof err)) {
        wdr_sim_destroy(sim);
        free(lut);
        return paper_cell_fail(r, PAPER_CELL_ERROR, "chip: ", err);
    }
    r->np = (long)b.width * b.height;
    wdr_cal_config cfg;
    paper_cell_config(c, &b, &d, &cfg);
    int n_cur = c->n_currents ? c->n_currents : 5;
    wdr_cal_simsrc ss = {sim, c->adc, 1000};
    wdr_cal_source src = {b.width, b.height, wdr_cal_sim_capture, &ss};
    double amps[PAPER_CELL_GRID_LEVELS], med[WDR_CAL_MAX_LEVELS];
    if (wdr_cal_design_check(&d, &cfg, n_cur, NULL, 0, PAPER_CELL_MIN_SLOPE, err, sizeof err)) {
        wdr_sim_destroy(sim);
        free(lut);
        return paper_cell_fail(r, PAPER_CELL_REFUSED_DESIGN, "", err);
    }
    for (int k = 0; k < PAPER_CELL_GRID_LEVELS; k++)
        amps[k] = PAPER_CELL_GRID_LO * pow(10, k / 6.0);
    wdr_cal_levels grid;
    if (wdr_cal_acquire(&src, amps, PAPER_CELL_GRID_LEVELS, PAPER_CELL_PROBE_FRAMES, 1, NULL, NULL, &grid, err,
                        sizeof err))
        paper_cell_fail(r, PAPER_CELL_ERROR, "probe: ", err);
    else if (wdr_cal_informative_range(&grid, PAPER_CELL_MIN_SLOPE, &r->lo, &r->hi))
        paper_cell_fail(r, PAPER_CELL_ERROR, "flat everywhere", "");
    else {
        cfg.range_lo = r->lo, cfg.range_hi = r->hi;
        wdr_cal_frames_choice fc;
        if (wdr_cal_select_currents(&grid, &cfg, n_cur, r->lo, r->hi, 256, &r->choice, err, sizeof err))
            paper_cell_fail(r, PAPER_CELL_REFUSED_PROBE, "", err);
        else if (wdr_cal_level_medians(&grid, NULL, med) ||
                 wdr_cal_frames_for(&grid, med, r->lo, r->hi, c->adc ? 1.0 : 0.0, PAPER_CELL_FRAMES_PCT,
                                    PAPER_CELL_FRAMES_MAX, &fc))
            paper_cell_fail(r, PAPER_CELL_ERROR, "frames auto failed", "");
        else {
            r->frames = fc.frames;
            paper_cell_fit(c, &src, &cfg, r);
        }
        wdr_cal_levels_free(&grid);
    }
    wdr_sim_destroy(sim);
    free(lut);
    return r->outcome;
}

#endif
