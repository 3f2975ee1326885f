/* SPLINE: the pixel's own monotone responses as its model, and the falling fit every curve
 * model's responses go through (the pixel's and the array median's). */
#include "cal_fit_internal.h"
#include "wdr_err.h"
#include <math.h>

/* A falling curve through noisy, quantised codes. Where the response is flat, neighbouring
 * levels tie or even rise a little: a rise within the level pair's tolerance (quantisation
 * plus k sigma of the measured temporal noise) is pooled with its neighbours (isotonic
 * regression, pool-adjacent-violators, weighted by the levels' noise); only a rise beyond it,
 * or a pooled level that moves further than the tolerance, is evidence of a reversed pixel.
 * A tiny step then keeps the curve strictly falling (its inverse lands inside the tie, which is
 * all the data can tell). tol[k] is the tolerance of the pair (k-1, k); w[k] > 0 the weights. */
int wdr_cal_falling_fit(const double *y, int n, const double *tol, const double *w, double *out)
{
    for (int k = 0; k < n; k++)
        if (!isfinite(y[k]))
            return WDR_FIT_NONFINITE;
    for (int k = 1; k < n; k++)
        if (y[k] > y[k - 1] + tol[k])
            return WDR_FIT_REVERSED;
    wdr_cal_isotonic_falling(y, w, n, out);
    for (int k = 0; k < n; k++) {
        double t = k > 0 ? tol[k] : tol[n > 1 ? 1 : 0];
        if (k + 1 < n && tol[k + 1] > t)
            t = tol[k + 1];
        if (fabs(y[k] - out[k]) > t)
            return WDR_FIT_REVERSED;
        if (k > 0 && out[k] > out[k - 1] - WDR_CAL_TIE_STEP)
            out[k] = out[k - 1] - WDR_CAL_TIE_STEP;
    }
    return WDR_FIT_OK;
}

/* SPLINE: the pixel's own responses are the model. Where the array's response falls clearly
 * between two levels (by far more than the pair's tolerance), a pixel that hardly moves there is
 * a stuck stretch, not noise. */
int wdr_cal_fit_spline_pixel(const double *y, const double *med, int n, const double *tol, const double *w, double *par)
{
    int st = wdr_cal_falling_fit(y, n, tol, w, par);
    for (int k = 1; !st && k < n; k++)
        if (med[k - 1] - med[k] > 8 * tol[k] && y[k - 1] - y[k] < 0.1 * (med[k - 1] - med[k]))
            st = WDR_FIT_FLAT;
    return st;
}

static int same_numbers(const double *a, const double *b, int n)
{
    for (int k = 0; k < n; k++)
        if (!(a[k] == b[k]))
            return 0;
    return 1;
}

/* The pixel's curve through its knots. Callers map many codes of one pixel in a row, and the
 * slopes' tridiagonal solve cost more than the inversion: the last curve is kept, per thread,
 * and reused while its knots, values and end ratios are the same numbers. */
static const wdr_pchip *pixel_curve(const wdr_cal_result *res, const double *par)
{
    static _Thread_local wdr_pchip curve;
    static _Thread_local double ends[2];
    static _Thread_local int valid;
    int n = res->nominal.curve.n;
    if (valid && curve.n == n && same_numbers(curve.y, par, n) && same_numbers(curve.lx, res->nominal.curve.lx, n) &&
        same_numbers(ends, res->nominal.end_ratio, 2))
        return &curve;
    valid = !wdr_pchip_init_ends(&curve, res->nominal.curve.lx, par, n, res->nominal.end_ratio);
    ends[0] = res->nominal.end_ratio[0];
    ends[1] = res->nominal.end_ratio[1];
    return valid ? &curve : NULL;
}

double wdr_cal_spline_recover(const wdr_cal_result *res, const double *par, double y)
{
    const wdr_pchip *p = pixel_curve(res, par);
    if (!p)
        return 0;
    double lx = wdr_pchip_invert(p, y);
    return lx > log(1e-22) ? exp(fmin(lx, log(1e-2))) : 0;
}
