/* LSQ: the physical basis fitted by variable projection (see cal_fit.h). */
#include "cal_fit_internal.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* LSQ: three basis weights found by QR for each trial offset; the offset by a 1-D search over
 * this fraction of the nominal swing either side of the pixel's bright-end deviation. */
#define LSQ_LINEAR 4
#define LSQ_SEARCH_FRAC 0.03
#define LSQ_SCAN 8    /* scan points either side */
#define LSQ_GOLDEN 20 /* refinement steps: the bracket shrinks to 1e-4 of a scan step */

/* The LSQ basis at offset-free code z (see cal_fit.h), in units of x_scale. I'/D is C / t(z),
 * one over the ramp time at that level. Darker than the lowest calibration level the nominal
 * response is linear in x, y = y_top - b0 x, so I'/D stays 1/b0 there, and I' = D / b0 goes on
 * smoothly past y_top (negative), where pixels with a high reset level still answer. */
static void lsq_basis(const wdr_cal_result *res, double z, double *phi)
{
    const wdr_nominal *n = &res->nominal;
    double x_lo = exp(n->curve.lx[0]) / res->x_scale, d = n->y_top - z, d_lo = n->y_top - n->curve.y[0];
    if (z >= n->curve.y[0]) {
        phi[0] = d * x_lo / d_lo;
        phi[1] = x_lo / d_lo;
    } else {
        double lx = wdr_nominal_invert_lx(n, z);
        phi[0] = exp(fmin(lx, log(1e-2))) / res->x_scale;
        phi[1] = phi[0] / d;
    }
    /* the photodiode's capacitance changes with its voltage, so a threshold offset's weight
     * drifts along the swing. A term linear in the level is already I' (I'/D times D), so the
     * next one is quadratic */
    double s = (z - n->curve.y[n->curve.n - 1]) / (n->curve.y[0] - n->curve.y[n->curve.n - 1]);
    phi[2] = phi[1] * s * s;
    phi[3] = 1;
}

/* theta: k1..k4 of the basis, then the source-follower offset o (codes). */
double wdr_cal_lsq_recover_u(const wdr_cal_result *res, const double *theta, double y)
{
    double phi[LSQ_LINEAR];
    lsq_basis(res, y - theta[LSQ_LINEAR], phi);
    return theta[0] * phi[0] + theta[1] * phi[1] + theta[2] * phi[2] + theta[3] * phi[3];
}

/* For a given offset the model is linear: solve it by QR and return the rms relative residual. */
static double lsq_solve_at(const wdr_cal_result *res, const double *y, const double *u, int n, double o,
                           double *theta)
{
    double a[WDR_CAL_MAX_LEVELS * LSQ_LINEAR], basis[WDR_CAL_MAX_LEVELS * LSQ_LINEAR], t[WDR_CAL_MAX_LEVELS];
    double w[WDR_CAL_MAX_LEVELS] = {0}, rcond;
    for (int k = 0; k < n; k++) {
        lsq_basis(res, y[k] - o, basis + k * LSQ_LINEAR);
        t[k] = u[k];
        w[k] = 1 / u[k]; /* relative residual: the contrast error */
    }
    memcpy(a, basis, sizeof(double) * (size_t)(n * LSQ_LINEAR)); /* the solver overwrites its matrix */
    if (wdr_lsq_solve(a, t, w, n, LSQ_LINEAR, theta, &rcond))
        return INFINITY;
    theta[LSQ_LINEAR] = o;
    double ss = 0;
    for (int k = 0; k < n; k++) {
        const double *phi = basis + k * LSQ_LINEAR;
        double r = (theta[0] * phi[0] + theta[1] * phi[1] + theta[2] * phi[2] + theta[3] * phi[3]) / u[k] - 1;
        ss += r * r;
    }
    return isfinite(ss) ? sqrt(ss / n) : INFINITY;
}

/* Variable projection over the one nonlinear parameter: a coarse scan of the offset around the
 * pixel's deviation at the brightest level, then golden-section refinement of the best bracket. */
static double lsq_search_offset(const wdr_cal_result *res, const double *y, const double *u, int n,
                                const double *med, double *theta)
{
    double o0 = y[n - 1] - med[n - 1], w = LSQ_SEARCH_FRAC * (med[0] - med[n - 1]), step = w / LSQ_SCAN;
    double best = o0, best_r = INFINITY, tmp[WDR_LSQ_PARAMS];
    for (int s = -LSQ_SCAN; s <= LSQ_SCAN; s++) {
        double r = lsq_solve_at(res, y, u, n, o0 + s * step, tmp);
        if (r < best_r)
            best_r = r, best = o0 + s * step;
    }
    const double g = 0.3819660112501051;
    double lo = best - step, hi = best + step, m1 = lo + g * (hi - lo), m2 = hi - g * (hi - lo);
    double r1 = lsq_solve_at(res, y, u, n, m1, tmp), r2 = lsq_solve_at(res, y, u, n, m2, tmp);
    for (int it = 0; it < LSQ_GOLDEN; it++) {
        if (r1 < r2)
            hi = m2, m2 = m1, r2 = r1, m1 = lo + g * (hi - lo), r1 = lsq_solve_at(res, y, u, n, m1, tmp);
        else
            lo = m1, m1 = m2, r1 = r2, m2 = hi - g * (hi - lo), r2 = lsq_solve_at(res, y, u, n, m2, tmp);
    }
    double o = r1 < r2 ? m1 : m2;
    double r = lsq_solve_at(res, y, u, n, o, theta);
    if (!(r <= best_r))
        r = lsq_solve_at(res, y, u, n, best, theta);
    return r;
}

/* The recovered current must rise as the code falls across the calibrated span; a dip within the
 * residual limit (ln x) is noise the fit followed, not a reversed pixel. */
static int lsq_rises(const wdr_cal_result *res, const double *theta, const double *y, int n, double limit)
{
    double x_max = -INFINITY;
    for (int s = 0; s <= 32; s++) {
        double x = wdr_cal_lsq_recover_u(res, theta, y[0] + (y[n - 1] - y[0]) * s / 32.0);
        if (x > x_max)
            x_max = x;
        else if (!(x > 0 && log(x_max / x) <= limit))
            return 0;
    }
    return 1;
}

int wdr_cal_fit_lsq_pixel(const wdr_cal_result *res, const double *y, const double *u, int n, const double *med,
                          const wdr_cal_residual_limit *lim, double *theta, double *resid)
{
    double r = lsq_search_offset(res, y, u, n, med, theta);
    if (resid)
        *resid = r;
    if (!isfinite(r))
        return WDR_FIT_ILL_COND;
    if (!(r <= lim->limit))
        return WDR_FIT_RESIDUAL;
    return lsq_rises(res, theta, y, n, lim->limit) ? WDR_FIT_OK : WDR_FIT_REVERSED;
}
