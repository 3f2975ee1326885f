/* The nominal pixel fitted to the array median: the curve models' strictly falling monotone cubic
 * (end slopes from the designed response), or the paper model through the medians. Apart from
 * cal_nominal.c, which evaluates the nominal pixel, because the fits of cal_fit_paper.c,
 * cal_fit_lsq.c and cal_residual.c evaluate it: with the fit in the same file they called each
 * other in a circle. */
#include "cal_design.h"
#include "cal_fit_internal.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <string.h>

int wdr_cal_is_curve_model(int model)
{
    return model == WDR_MODEL_LSQ || model == WDR_MODEL_POLYMAP || model == WDR_MODEL_SPLINE;
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
