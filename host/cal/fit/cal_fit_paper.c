/* The paper's models per pixel (SIMPLE3, COMPLEX4) and the polynomial code map (POLYMAP). */
#include "cal_fit_internal.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The POLYMAP map's input variable: raw codes onto [-1, 1], the same as the table header's. */
double wdr_cal_poly_u(const wdr_cal_result *res, double y)
{
    return 2 * y / res->cfg.raw_max - 1;
}

double wdr_cal_poly_eval(const double *c, int n, double u)
{
    double v = c[n - 1];
    for (int k = n - 2; k >= 0; k--)
        v = v * u + c[k];
    return v;
}

/* Residual weights of a paper model's levels: one over each level's code sd, its temporal noise
 * left after averaging (measured with the levels) and one ADC rounding (1/12 code^2, which
 * averaging without noise does not remove). Equal when the noise was not measured. */
void wdr_cal_paper_weights(const wdr_cal_levels *lv, double *w)
{
    for (int k = 0; k < lv->n; k++) {
        double sd = wdr_cal_level_sd(lv, k);
        w[k] = 1 / sqrt(sd * sd + 1.0 / 12);
    }
}

/* The light levels' fit with the array's dark offset (m->d, the nominal pixel's) kept. */
static void simple3_light_fit(const double *u, const double *y, const double *w, int n, wdr_simple3 *m)
{
    double d = m->d;
    wdr_simple3_fit_lsq(u, y, w, n, m);
    m->d = d;
}

static void complex4_light_fit(const double *u, const double *y, const double *w, int n, wdr_complex4 *m)
{
    double d = m->d;
    wdr_complex4_fit_lsq(u, y, w, n, m);
    m->d = d;
}

/* A pixel's own dark shift fails (its dark reading at or below its dimmest level, or further above
 * it than the model allows) but the reading agrees, within the tolerance of the dark-first pair,
 * with what the array's dark offset predicts from its light levels (one frame's noise): at 1e-14 A the reading is only
 * ~3 codes above the dimmest level, so noise (two probe frames: 2-8 % of a healthy chip; 64 frames:
 * 1 %) decides the failure, not the pixel. Such a pixel takes the array's offset. */
static int dark_within_noise(const wdr_cal_result *res, const double *u, const double *y, const double *w, int n,
                             double y0, const double *tol)
{
    if (!tol || res->nominal.model != res->model)
        return 0; /* no tolerance, or the nominal pixel itself is being fitted */
    double y_exp, d;
    int st;
    if (res->model == WDR_MODEL_SIMPLE3) {
        wdr_simple3 m = {.x_scale = res->x_scale};
        d = res->nominal.s3.d;
        st = wdr_simple3_fit_lsq(u, y, w, n, &m);
        y_exp = wdr_simple3_eval(&m, d);
    } else {
        wdr_complex4 m = {.x_scale = res->x_scale};
        d = res->nominal.c4.d;
        st = wdr_complex4_fit_lsq(u, y, w, n, &m);
        y_exp = wdr_complex4_eval(&m, d);
    }
    /* one frame's tolerance (the pair's, times sqrt M): the same on the two-frame probe that
     * chose the levels as on the calibration's averaged frames */
    double tc = res->cfg.tie_codes, one_frame = tc + (tol[1] - tc) * sqrt(res->m_avg > 1 ? res->m_avg : 1);
    return !st && d > -u[0] && fabs(y0 - y_exp) <= one_frame;
}

/* Fit one pixel with a paper model; u[], y[] (and w[], may be NULL) hold its n levels, ordered,
 * the dark reference first when cfg.use_dark_ref. With the paper's count (3 or 4 light levels)
 * the exact fit; with more, least squares on the code residuals. tol (may be NULL): per pair of
 * levels the rise that counts as a reversal (wdr_cal_level_tolerances); a least-squares fit
 * averages smaller ones, an exact fit refuses any. */
int wdr_cal_fit_paper_pixel(const wdr_cal_result *res, const double *u, const double *y, int n, const double *tol,
                            const double *w, double *par)
{
    int st, ref = res->cfg.use_dark_ref ? 1 : 0;
    const double *ul = u + ref, *yl = y + ref, *wl = w ? w + ref : NULL;
    for (int k = ref + 1; tol && k < n; k++)
        if (y[k] > y[k - 1] + tol[k])
            return WDR_FIT_REVERSED;
    if (res->model == WDR_MODEL_SIMPLE3) {
        wdr_simple3 m = {.x_scale = res->x_scale};
        st = ref ? wdr_simple3_fit_lsq_dark(ul, yl, wl, n - 1, u[0], y[0], &m) : wdr_simple3_fit_lsq(ul, yl, wl, n, &m);
        if (ref && (st == WDR_FIT_REVERSED || st == WDR_FIT_DARK) &&
            dark_within_noise(res, ul, yl, wl, n - 1, y[0], tol))
            st = WDR_FIT_OK, m = res->nominal.s3, simple3_light_fit(ul, yl, wl, n - 1, &m);
        par[0] = m.a, par[1] = m.b, par[2] = m.c, par[3] = m.d;
    } else {
        wdr_complex4 m = {.x_scale = res->x_scale};
        st = ref ? wdr_complex4_fit_lsq_dark(ul, yl, wl, n - 1, u[0], y[0], &m)
                 : wdr_complex4_fit_lsq(ul, yl, wl, n, &m);
        if (ref && (st == WDR_FIT_REVERSED || st == WDR_FIT_DARK) &&
            dark_within_noise(res, ul, yl, wl, n - 1, y[0], tol))
            st = WDR_FIT_OK, m = res->nominal.c4, complex4_light_fit(ul, yl, wl, n - 1, &m);
        par[0] = m.p, par[1] = m.q, par[2] = m.r, par[3] = m.s, par[4] = m.d;
    }
    return st;
}

/* POLYMAP: the polynomial map from this pixel's codes to the nominal codes at the same currents,
 * weighted so each residual is in units of ln x (i.e. relative current, the contrast error).
 * Judged against the pixel's noise and the model's misfit (lim, cal_residual.c), not a fixed
 * residual: a healthy pixel is unfit only on evidence. */
int wdr_cal_fit_polymap_pixel(const wdr_cal_result *res, const double *y, const double *target, const double *w, int n,
                              const wdr_cal_residual_limit *lim, double *par, double *resid)
{
    int nc = res->n_params;
    double a[WDR_CAL_MAX_LEVELS * WDR_CAL_MAX_COEFFS], t[WDR_CAL_MAX_LEVELS], rcond;
    for (int k = 0; k < n; k++) {
        double u = wdr_cal_poly_u(res, y[k]), p = 1;
        for (int j = 0; j < nc; j++, p *= u)
            a[k * nc + j] = p;
        t[k] = target[k];
    }
    int st = wdr_lsq_solve(a, t, w, n, nc, par, &rcond);
    if (resid)
        *resid = INFINITY;
    if (st)
        return st;
    double ss = 0;
    for (int k = 0; k < n; k++) {
        double r = (wdr_cal_poly_eval(par, nc, wdr_cal_poly_u(res, y[k])) - target[k]) * w[k];
        ss += r * r;
    }
    double rms = sqrt(ss / n);
    if (resid)
        *resid = rms;
    if (!(rms <= lim->limit))
        return WDR_FIT_RESIDUAL;
    /* the map must keep the pixel's order of brightness across its calibrated span: a fall of the
     * mapped code, in ln x at the nominal slope there, beyond the limit is a reversal; a smaller one
     * is the noise the polynomial followed */
    double v_max = -INFINITY;
    for (int s = 0; s <= 16; s++) {
        double v = wdr_cal_poly_eval(par, nc, wdr_cal_poly_u(res, y[n - 1] + (y[0] - y[n - 1]) * s / 16.0));
        if (v > v_max) {
            v_max = v;
            continue;
        }
        double slope = wdr_nominal_log_slope(&res->nominal, wdr_nominal_invert(&res->nominal, v_max));
        if (!((v_max - v) / fmax(slope, 1e-9) <= lim->limit))
            return WDR_FIT_REVERSED;
    }
    return WDR_FIT_OK;
}
