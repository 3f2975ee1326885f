/* Array calibration: configuration, checks, per-pixel fits of every model, recovery. The pieces:
 * cal_pchip.c (monotone cubic), cal_nominal.c and cal_fit_nominal.c (nominal pixel), cal_bad.c (bad pixels),
 * cal_fit_paper.c, cal_fit_lsq.c, cal_fit_spline.c (per-model fits). Tables: cal_table.c. */
#include "cal_design.h"
#include "cal_fit_internal.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void wdr_cal_config_defaults(wdr_cal_config *c, int model)
{
    memset(c, 0, sizeof *c);
    c->model = model;
    /* SIMPLE3: Moebius is exact. SPLINE (the N-current model, any operator): the shared basis, as
     * a polynomial of <= 8 coefficients leaves 2-11 % on Drago and Tumblin-Rushmeier (their maps
     * bend within a few codes; tests/calibration/test_cal_sim.c). The others: polynomial. */
    c->form = model == WDR_MODEL_SIMPLE3 ? WDR_FORM_MOEBIUS : model == WDR_MODEL_SPLINE ? WDR_FORM_BASIS : WDR_FORM_POLY;
    c->n_coeffs = model == WDR_MODEL_SIMPLE3 ? 3 : model == WDR_MODEL_SPLINE ? 8 : 5;
    c->use_dark_ref = model == WDR_MODEL_SIMPLE3 || model == WDR_MODEL_COMPLEX4;
    c->raw_max = 4095;
    /* corrected codes in the raw codes' own range, as frames without a table: what the host tools
     * expect from a capture. A scale of 16 keeps 4 more bits (16-bit frames) */
    c->out_scale = 1.0f;
    c->out_max = 4095;
    c->stuck_frac = 0.01;
    c->dead_frac = 0.5;
    c->hot_frac = 0.25;
    c->max_residual = 0.5; /* LSQ/POLYMAP: caps the misfit a chip excuses (healthy: <= 0.21, cal_residual.c) */
    c->tie_codes = 0.5;
    c->tie_sigmas = 5;
    c->spacing_sigmas = 3;
}

static int levels_needed(const wdr_cal_config *cfg)
{
    int ref = cfg->use_dark_ref ? 1 : 0;
    switch (cfg->model) {
    case WDR_MODEL_SIMPLE3:
        return 3 + ref;
    case WDR_MODEL_COMPLEX4:
        return 4 + ref;
    case WDR_MODEL_LSQ:
        return WDR_LSQ_PARAMS + 2;
    case WDR_MODEL_SPLINE:
        return 4;
    default:
        return cfg->n_coeffs + 1;
    }
}

static int params_of(int model, int n_coeffs)
{
    switch (model) {
    case WDR_MODEL_SIMPLE3:
        return 4;
    case WDR_MODEL_COMPLEX4:
        return 5;
    case WDR_MODEL_LSQ:
        return WDR_LSQ_PARAMS;
    case WDR_MODEL_SPLINE:
        return WDR_CAL_MAX_LEVELS; /* its own responses at the calibration currents */
    default:
        return n_coeffs;
    }
}

static int check_levels(const wdr_cal_levels *lv, const wdr_cal_config *cfg, char *err, int errlen)
{
    int need = levels_needed(cfg);
    if (cfg->model <= WDR_MODEL_NONE || cfg->model >= WDR_MODEL_COUNT) {
        snprintf(err, (size_t)errlen, "unknown calibration model %d", cfg->model);
        return WDR_E_INVAL;
    }
    /* the paper models: their parameter count (+ the dark reference) is the exact fit, more
     * levels a least-squares fit that averages the levels' rounding */
    if (lv->n < need) {
        snprintf(err, (size_t)errlen, "model needs at least %d calibration levels, got %d", need, lv->n);
        return WDR_E_INVAL;
    }
    if (lv->n > WDR_PCHIP_MAX || cfg->n_coeffs < 2 || cfg->n_coeffs > (int)WDR_CAL_MAX_COEFFS) {
        snprintf(err, (size_t)errlen, "too many levels (%d) or bad coefficient count %d", lv->n, cfg->n_coeffs);
        return WDR_E_INVAL;
    }
    for (int k = 0; k < lv->n; k++)
        if (!isfinite(lv->amps[k]) || lv->amps[k] < 0 || (k > 0 && !(lv->amps[k] > lv->amps[k - 1]))) {
            snprintf(err, (size_t)errlen, "calibration current %d (%g A) is not above the one before", k,
                     lv->amps[k]);
            return WDR_E_INVAL;
        }
    return WDR_OK;
}

static double geometric_centre(const wdr_cal_levels *lv)
{
    double s = 0;
    int m = 0;
    for (int k = 0; k < lv->n; k++)
        if (lv->amps[k] > 0)
            s += log(lv->amps[k]), m++;
    return m ? exp(s / m) : 1e-11;
}

static int alloc_result(wdr_cal_result *res, long np)
{
    res->params = calloc((size_t)np * (size_t)res->n_params, sizeof(double));
    res->flags = calloc((size_t)np, 1);
    res->status = calloc((size_t)np, 1);
    return res->params && res->flags && res->status ? WDR_OK : WDR_E_NOMEM;
}

/* Median response per level over the pixels not flagged so far. */
int wdr_cal_level_medians(const wdr_cal_levels *lv, const uint8_t *flags, double *med)
{
    long np = (long)lv->width * lv->height;
    float *good = malloc(sizeof(float) * 2 * (size_t)np);
    if (!good)
        return WDR_E_NOMEM;
    for (int k = 0; k < lv->n; k++) {
        long m = 0;
        for (long i = 0; i < np; i++)
            if (!flags || !flags[i])
                good[m++] = lv->frames[(long)k * np + i];
        med[k] = m ? wdr_cal_median_of(good, m, good + np) : 0;
    }
    free(good);
    return WDR_OK;
}

static void fit_all_pixels(const wdr_cal_levels *lv, wdr_cal_result *res, const double *med)
{
    long np = (long)lv->width * lv->height;
    double u[WDR_CAL_MAX_LEVELS], y[WDR_CAL_MAX_LEVELS], w[WDR_CAL_MAX_LEVELS];
    double tol[WDR_CAL_MAX_LEVELS], w_noise[WDR_CAL_MAX_LEVELS], w_code[WDR_CAL_MAX_LEVELS];
    wdr_cal_level_tolerances(lv, &res->cfg, tol, w_noise);
    wdr_cal_paper_weights(lv, w_code);
    for (int k = 0; k < lv->n; k++) {
        u[k] = lv->amps[k] / res->x_scale;
        w[k] = 1 / fmax(wdr_nominal_log_slope(&res->nominal, lv->amps[k]), 1e-9);
    }
    wdr_cal_residual_limit lim = {.limit = INFINITY}; /* LSQ, POLYMAP: the pixel's noise plus the model's misfit */
    if (res->model == WDR_MODEL_LSQ || res->model == WDR_MODEL_POLYMAP)
        wdr_cal_residual_limit_init(lv, res, med, w, &lim);
    for (long i = 0; i < np; i++) {
        double *par = res->params + i * res->n_params;
        if (res->flags[i])
            continue;
        for (int k = 0; k < lv->n; k++)
            y[k] = lv->frames[(long)k * np + i];
        int st;
        if (res->model == WDR_MODEL_LSQ)
            st = wdr_cal_fit_lsq_pixel(res, y, u, lv->n, med, &lim, par, NULL);
        else if (res->model == WDR_MODEL_POLYMAP)
            st = wdr_cal_fit_polymap_pixel(res, y, med, w, lv->n, &lim, par, NULL);
        else if (res->model == WDR_MODEL_SPLINE)
            st = wdr_cal_fit_spline_pixel(y, med, lv->n, tol, w_noise, par);
        else
            st = wdr_cal_fit_paper_pixel(res, u, y, lv->n, tol, w_code, par);
        if (st) {
            res->status[i] = (uint8_t)st;
            res->flags[i] |= WDR_PIX_UNFIT;
        }
    }
}

/* cfg.code_noise, or when 0: the temporal noise left in the levels' means (measured with the
 * levels, RMS over them), and one rounding of the ADC (1 code) and of the DAC (its step in ADC
 * codes from the design, else one code) if the levels are whole codes, as quantised frames
 * averaged without noise are (noise dithers the rounding away otherwise). */
static double level_code_noise(const wdr_cal_levels *lv, const wdr_cal_config *cfg)
{
    if (cfg->code_noise > 0)
        return cfg->code_noise;
    double var = 0;
    for (int k = 0; k < lv->n; k++)
        var += wdr_cal_level_sd(lv, k) * wdr_cal_level_sd(lv, k) / lv->n;
    long np = (long)lv->width * lv->height, probe = np * lv->n < 4096 ? np * lv->n : 4096;
    for (long i = 0; i < probe; i++)
        if (lv->frames[i] != floorf(lv->frames[i]))
            return sqrt(var);
    double step = cfg->design ? wdr_cal_design_dac_step_codes(cfg->design, sqrt(lv->amps[0] * lv->amps[lv->n - 1]))
                              : 1.0;
    return sqrt(var + (1 + step * step) / 12);
}

static void count_flags(wdr_cal_result *res)
{
    long np = (long)res->width * res->height;
    memset(res->n_flag, 0, sizeof res->n_flag);
    memset(res->n_status, 0, sizeof res->n_status);
    res->n_bad = 0;
    for (long i = 0; i < np; i++) {
        for (int b = 0; b < 8; b++)
            res->n_flag[b] += (res->flags[i] >> b) & 1;
        res->n_status[res->status[i]]++;
        res->n_bad += res->flags[i] != 0;
    }
}

int wdr_cal_fit_array(const wdr_cal_levels *lv, const wdr_cal_config *cfg, wdr_cal_result *res, char *err,
                      int errlen)
{
    memset(res, 0, sizeof *res);
    int rc = check_levels(lv, cfg, err, errlen);
    if (rc)
        return rc;
    long np = (long)lv->width * lv->height;
    res->width = lv->width;
    res->height = lv->height;
    res->model = cfg->model;
    res->cfg = *cfg;
    res->x_scale = geometric_centre(lv);
    res->n_params = params_of(cfg->model, cfg->n_coeffs);
    if ((rc = alloc_result(res, np))) {
        snprintf(err, (size_t)errlen, "out of memory for %ld pixels", np);
        return rc;
    }
    wdr_cal_detect_bad(lv, cfg, res->flags, &res->saturated_levels);
    double med[WDR_CAL_MAX_LEVELS];
    if ((rc = wdr_cal_level_medians(lv, res->flags, med)) || (rc = wdr_cal_fit_nominal(lv, res, med, err, errlen)))
        return rc;
    res->m_avg = lv->m_avg;
    fit_all_pixels(lv, res, med);
    count_flags(res);
    res->code_noise = level_code_noise(lv, cfg);
    return WDR_OK;
}

void wdr_cal_result_free(wdr_cal_result *res)
{
    free(res->nominal.inv_lx);
    res->nominal.inv_lx = NULL;
    free(res->params);
    free(res->flags);
    free(res->status);
    res->params = NULL;
    res->flags = res->status = NULL;
}

/* ---- recovery ---- */

double wdr_cal_recover(const wdr_cal_result *res, long i, double y, int *status)
{
    const double *p = res->params + i * res->n_params;
    double cap = 10 * res->nominal.x_hi / res->x_scale, u = 0;
    int clamped = 0;
    *status = WDR_FIT_OK;
    if (!isfinite(y)) {
        *status = WDR_FIT_NONFINITE;
        return 0;
    }
    if (res->model == WDR_MODEL_SIMPLE3) {
        wdr_simple3 m = {p[0], p[1], p[2], p[3], res->x_scale};
        *status = wdr_simple3_invert(&m, y, cap, &u);
    } else if (res->model == WDR_MODEL_COMPLEX4) {
        wdr_complex4 m = {p[0], p[1], p[2], p[3], p[4], res->x_scale, 0};
        *status = wdr_complex4_invert(&m, y, cap, &u, &clamped);
    } else if (res->model == WDR_MODEL_LSQ) {
        u = wdr_cal_lsq_recover_u(res, p, y);
        return isfinite(u) ? u * res->x_scale : 0;
    } else if (res->model == WDR_MODEL_SPLINE) {
        return wdr_cal_spline_recover(res, p, y);
    } else {
        return wdr_nominal_invert(&res->nominal, wdr_cal_poly_eval(p, res->n_params, wdr_cal_poly_u(res, y)));
    }
    if (clamped && !*status)
        *status = WDR_FIT_ILL_COND;
    return u * res->x_scale;
}

double wdr_cal_map(const wdr_cal_result *res, long i, double y)
{
    int st;
    if (res->model == WDR_MODEL_POLYMAP)
        return wdr_cal_poly_eval(res->params + i * res->n_params, res->n_params, wdr_cal_poly_u(res, y));
    return wdr_nominal_eval(&res->nominal, wdr_cal_recover(res, i, y, &st));
}
