/* The nominal pixel: what a corrected pixel reports for a current, and its fast inverse table
 * (LSQ). Fitted to the array median by cal_fit_nominal.c: this file only evaluates it, so the
 * per-pixel fits that judge pixels against the nominal curve call down to it, never back up. */
#include "cal_fit_internal.h"
#include "wdr_err.h"
#include <math.h>
#include <stdlib.h>

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
