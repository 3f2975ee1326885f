/* Samples of a pixel's exact map nominal(model^-1(y)) over the table's range: what the polynomial
 * form (cal_table.c) and the shared basis (cal_basis.c) fit. Apart from cal_table.c, which calls
 * the basis, so that the basis need not call back into it. */
#include "cal_basis.h"
#include <math.h>

/* LSQ models the inverse only: find the code whose recovered current is x by bisection
 * (recovery falls monotonically with the code over the pixel's span, which the fit checked). */
static double code_for_current(const wdr_cal_result *res, long i, double x)
{
    double lo = 0, hi = res->cfg.raw_max;
    int st;
    for (int it = 0; it < 40; it++) {
        double mid = 0.5 * (lo + hi);
        if (wdr_cal_recover(res, i, mid, &st) > x)
            lo = mid;
        else
            hi = mid;
    }
    return 0.5 * (lo + hi);
}

/* Pixel response at current x from its fitted model (the table's input side). */
static double pixel_response(const wdr_cal_result *res, long i, double x)
{
    const double *p = res->params + i * res->n_params;
    if (res->model == WDR_MODEL_LSQ)
        return code_for_current(res, i, x);
    if (res->model == WDR_MODEL_SPLINE) {
        wdr_pchip c;
        return wdr_pchip_init_ends(&c, res->nominal.curve.lx, p, res->nominal.curve.n, res->nominal.end_ratio)
                   ? 0
                   : wdr_pchip_eval(&c, log(x));
    }
    if (res->model == WDR_MODEL_SIMPLE3) {
        wdr_simple3 m = {p[0], p[1], p[2], p[3], res->x_scale};
        return wdr_simple3_eval(&m, x / res->x_scale);
    }
    wdr_complex4 m = {p[0], p[1], p[2], p[3], p[4], res->x_scale, 0};
    return wdr_complex4_eval(&m, x / res->x_scale);
}

/* Sample codes for the map: exact pixel responses for the paper models; for LSQ (which models
 * the inverse only) the two ends by bisection and the nominal curve's spacing in between. */
static void sample_codes(const wdr_cal_result *res, long i, const double *xs, double *ys, int m)
{
    if (res->model == WDR_MODEL_SPLINE) { /* one curve for all samples */
        wdr_pchip c;
        const double *p = res->params + i * res->n_params;
        int bad = wdr_pchip_init_ends(&c, res->nominal.curve.lx, p, res->nominal.curve.n, res->nominal.end_ratio);
        for (int k = 0; k < m; k++)
            ys[k] = bad ? 0 : wdr_pchip_eval(&c, log(xs[k]));
        return;
    }
    if (res->model != WDR_MODEL_LSQ) {
        for (int k = 0; k < m; k++)
            ys[k] = pixel_response(res, i, xs[k]);
        return;
    }
    const wdr_nominal *n = &res->nominal;
    double y0 = code_for_current(res, i, xs[0]), y1 = code_for_current(res, i, xs[m - 1]);
    double n0 = wdr_nominal_eval(n, xs[0]), n1 = wdr_nominal_eval(n, xs[m - 1]);
    for (int k = 0; k < m; k++)
        ys[k] = y1 + (wdr_nominal_eval(n, xs[k]) - n1) * (y0 - y1) / (n0 - n1);
}

/* Weight of a map sample at current x: one over its expected error in codes. A contrast error c
 * costs c times the slope in codes; the level codes the map passes through are themselves
 * uncertain by res->code_noise. Without that term (exact levels) the fit minimises the contrast
 * error; with it, at the ends of a quantised range where one code is 10-20 % of contrast, the fit
 * no longer chases the levels' rounding there at the expense of 0.7 % everywhere else. */
#define MAP_CONTRAST_TOL 1e-3

static double map_weight(const wdr_cal_result *res, double x)
{
    double slope = wdr_nominal_log_slope(&res->nominal, fmax(x, res->nominal.x_lo));
    return 1 / fmax(hypot(slope * MAP_CONTRAST_TOL, res->code_noise), 1e-12);
}

/* Sample k of m of the map: the current it stands for (the paper models and the spline invert
 * their own response exactly; LSQ recovers it from the code), its target and contrast weight. */
static void map_target(const wdr_cal_result *res, long i, double xk, double yk, double *t, double *w)
{
    int st;
    double x = res->model == WDR_MODEL_LSQ ? wdr_cal_recover(res, i, yk, &st) : xk;
    *t = wdr_nominal_eval(&res->nominal, x);
    *w = map_weight(res, x);
}

void wdr_cal_map_log_spaced(const wdr_cal_result *res, double *xs, int m)
{
    double lx0 = log(res->nominal.x_lo), lx1 = log(res->nominal.x_hi);
    for (int k = 0; k < m; k++)
        xs[k] = exp(lx0 + (lx1 - lx0) * k / (m - 1));
}

void wdr_cal_map_samples_at(const wdr_cal_result *res, long i, const double *xs, int m, double *y, double *t, double *w)
{
    sample_codes(res, i, xs, y, m);
    for (int k = 0; k < m; k++)
        map_target(res, i, xs[k], y[k], &t[k], &w[k]);
}

void wdr_cal_map_samples(const wdr_cal_result *res, long i, wdr_map_samples *s)
{
    double xs[WDR_BASIS_SAMPLES];
    wdr_cal_map_log_spaced(res, xs, WDR_BASIS_SAMPLES);
    wdr_cal_map_samples_at(res, i, xs, WDR_BASIS_SAMPLES, s->y, s->t, s->w);
}
