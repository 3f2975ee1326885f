/* The nominal pixel: what a corrected pixel reports for a current, the curve or model fitted to
 * the array median, and its fast inverse table (LSQ). */
#include "cal_design.h"
#include "cal_fit_internal.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

double wdr_nominal_eval(const wdr_nominal *n, double x)
{
    switch (n->model) {
    case WDR_MODEL_SIMPLE3:
        return wdr_simple3_eval(&n->s3, x / n->s3.x_scale);
    case WDR_MODEL_COMPLEX4:
        return wdr_complex4_eval(&n->c4, x / n->c4.x_scale);
    default:
        return wdr_pchip_eval(&n->curve, log(fmax(x, 1e-30)));
    }
}

/* Currents far outside any sensor's range are clamped: exp() stays finite. */
static double invert_pchip(const wdr_pchip *p, double y)
{
    double lx = wdr_pchip_invert(p, y);
    if (!(lx > log(1e-22)))
        return 0;
    return exp(fmin(lx, log(1e-2)));
}

double wdr_nominal_invert(const wdr_nominal *n, double y)
{
    double u, cap;
    int clamped;
    switch (n->model) {
    case WDR_MODEL_SIMPLE3:
        cap = 10 * n->x_hi / n->s3.x_scale;
        wdr_simple3_invert(&n->s3, y, cap, &u);
        return u * n->s3.x_scale;
    case WDR_MODEL_COMPLEX4:
        cap = 10 * n->x_hi / n->c4.x_scale;
        if (wdr_complex4_invert(&n->c4, y, cap, &u, &clamped) == WDR_FIT_FLAT)
            u = cap;
        return u * n->c4.x_scale;
    default:
        return invert_pchip(&n->curve, y);
    }
}

static double complex4_slope_u(const wdr_complex4 *m, double u)
{
    double t = u + m->d, num = m->p + m->q * t - m->r * t * t, den = 1 + m->s * t;
    return ((m->q - 2 * m->r * t) * den - num * m->s) / (den * den);
}

double wdr_nominal_log_slope(const wdr_nominal *n, double x)
{
    x = fmax(x, n->x_lo * 1e-3);
    switch (n->model) {
    case WDR_MODEL_SIMPLE3:
        return fabs(wdr_simple3_slope(&n->s3, x / n->s3.x_scale) * x / n->s3.x_scale);
    case WDR_MODEL_COMPLEX4:
        return fabs(complex4_slope_u(&n->c4, x / n->c4.x_scale) * x / n->c4.x_scale);
    default:
        return fabs(wdr_pchip_slope(&n->curve, log(x)));
    }
}

/* Fast inverse of the nominal curve: table guess, then one Newton step (the curve is smooth
 * and the guess is within a fraction of a code). Outside the table: the full inverse. */
double wdr_nominal_invert_lx(const wdr_nominal *n, double z)
{
    double f = n->inv_lx ? (z - n->inv_z0) / n->inv_dz : -1;
    if (!(f >= 0 && f < n->inv_n - 1))
        return wdr_pchip_invert(&n->curve, z);
    int k = (int)f;
    double lx = n->inv_lx[k] + (f - k) * (n->inv_lx[k + 1] - n->inv_lx[k]);
    double slope = wdr_pchip_slope(&n->curve, lx);
    if (slope != 0) {
        double next = lx - (wdr_pchip_eval(&n->curve, lx) - z) / slope;
        if (fabs(next - lx) < 0.1)
            lx = next;
    }
    return lx;
}

#define INV_STEP_CODES 0.25

int wdr_nominal_build_inverse_table(wdr_nominal *n)
{
    double z_hi = n->curve.y[0], z_lo = n->curve.y[n->curve.n - 1];
    if (!(z_hi > z_lo))
        return WDR_OK; /* no table: the full inverse is used */
    n->inv_n = (int)ceil((z_hi - z_lo) / INV_STEP_CODES) + 1;
    n->inv_z0 = z_lo;
    n->inv_dz = (z_hi - z_lo) / (n->inv_n - 1);
    n->inv_lx = malloc(sizeof(double) * (size_t)n->inv_n);
    if (!n->inv_lx)
        return WDR_E_NOMEM;
    for (int k = 0; k < n->inv_n; k++)
        n->inv_lx[k] = wdr_pchip_invert(&n->curve, n->inv_z0 + k * n->inv_dz);
    return WDR_OK;
}

/* Nominal dark level: the response is linear in x below the lowest currents, so the secant of
 * the two lowest levels continued to zero current. (The dark frame is no substitute: dark current
 * moves it, and under slow ramps it holds the ramp's last code.) */
static double nominal_dark_top(const wdr_cal_levels *lv, const double *med)
{
    double b = (med[0] - med[1]) / (lv->amps[1] - lv->amps[0]);
    return med[0] + b * lv->amps[0];
}
/* End slopes of the curves from the designed response's shape at the first and last two knots. */
static void design_end_ratios(const wdr_cal_levels *lv, const wdr_cal_design *d, double *ratio)
{
    ratio[0] = ratio[1] = 0;
    if (!d || lv->n < 3 || !(lv->amps[0] > 0))
        return;
    ratio[0] = wdr_cal_design_end_ratio(d, lv->amps[0], lv->amps[1]);
    ratio[1] = wdr_cal_design_end_ratio(d, lv->amps[lv->n - 1], lv->amps[lv->n - 2]);
}

int wdr_cal_fit_nominal(const wdr_cal_levels *lv, wdr_cal_result *res, const double *med, char *err, int errlen)
{
    wdr_nominal *n = &res->nominal;
    double u[WDR_CAL_MAX_LEVELS], lx[WDR_CAL_MAX_LEVELS], par[8] = {0};
    n->model = res->model;
    n->x_lo = res->cfg.range_lo > 0 ? res->cfg.range_lo : lv->amps[0] > 0 ? lv->amps[0] : lv->amps[1];
    n->x_hi = res->cfg.range_hi > n->x_lo ? res->cfg.range_hi : lv->amps[lv->n - 1];
    for (int k = 0; k < lv->n; k++) {
        u[k] = lv->amps[k] / res->x_scale;
        lx[k] = log(fmax(lv->amps[k], 1e-30));
    }
    int st = WDR_FIT_OK;
    if (wdr_cal_is_curve_model(res->model)) {
        double falling[WDR_CAL_MAX_LEVELS] = {0};
        double tol[WDR_CAL_MAX_LEVELS], w[WDR_CAL_MAX_LEVELS];
        wdr_cal_level_tolerances(lv, &res->cfg, tol, w);
        st = wdr_cal_falling_fit(med, lv->n, tol, w, falling); /* strictly falling: invertible */
        if (!st && !(falling[0] - falling[lv->n - 1] > lv->n * WDR_CAL_TIE_STEP))
            st = WDR_FIT_FLAT;
        design_end_ratios(lv, res->cfg.design, n->end_ratio);
        if (!st)
            st = wdr_pchip_init_ends(&n->curve, lx, falling, lv->n, n->end_ratio) ? WDR_FIT_REVERSED : WDR_FIT_OK;
        n->y_top = !st ? nominal_dark_top(lv, falling) : 0;
        if (!st && res->model == WDR_MODEL_LSQ && wdr_nominal_build_inverse_table(n))
            return WDR_E_NOMEM;
    } else {
        st = wdr_cal_fit_paper_pixel(res, u, med, lv->n, NULL, NULL, par);
        if (st && res->cfg.use_dark_ref) {
            /* the median's dark reading does not fit the model: its current scale keeps d = 0 */
            wdr_cal_result plain = *res;
            plain.cfg.use_dark_ref = 0;
            memset(par, 0, sizeof par);
            st = wdr_cal_fit_paper_pixel(&plain, u + 1, med + 1, lv->n - 1, NULL, NULL, par);
        }
    }
    n->s3 = (wdr_simple3){par[0], par[1], par[2], par[3], res->x_scale};
    n->c4 = (wdr_complex4){par[0], par[1], par[2], par[3], par[4], res->x_scale, 0};
    if (st)
        snprintf(err, (size_t)errlen, "the array's median response cannot be fitted: %s", wdr_fit_status_name(st));
    return st ? WDR_E_NUMERIC : WDR_OK;
}
