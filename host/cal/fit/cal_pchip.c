/* The monotone cubic in ln x: spline slopes where they keep it monotone, else Fritsch-Carlson
 * (PCHIP) slopes; monotone data give a monotone curve. Evaluation, slope and inverse. */
#include "cal_fit_internal.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static double pchip_end_slope(double h0, double h1, double d0, double d1)
{
    double m = ((2 * h0 + h1) * d0 - h0 * d1) / (h0 + h1);
    if (m * d0 <= 0)
        return 0;
    if (d0 * d1 <= 0 && fabs(m) > fabs(3 * d0))
        return 3 * d0;
    return m;
}

/* Three-point (quadratic) slope estimate at an end, without the monotone limiter. */
static double quadratic_end_slope(double h0, double h1, double d0, double d1)
{
    return ((2 * h0 + h1) * d0 - h0 * d1) / (h0 + h1);
}

/* Knot slopes of the C2 cubic spline, its end slopes clamped to the three-point estimates (a
 * natural end would force zero curvature where the response still bends). Tridiagonal solve. */
static void spline_slopes(const double *h, const double *d, int n, const double *ratio, double *m)
{
    double diag[WDR_PCHIP_MAX], rhs[WDR_PCHIP_MAX], up[WDR_PCHIP_MAX];
    diag[0] = 1, up[0] = 0, rhs[0] = n > 2 ? quadratic_end_slope(h[0], h[1], d[0], d[1]) : d[0];
    if (ratio && ratio[0] > 0)
        rhs[0] = ratio[0] * d[0]; /* the design's shape: a three-point slope misses a response that
                                     bends by a factor over one knot interval (the dark end) */
    for (int k = 1; k < n - 1; k++) {
        diag[k] = 2 * (h[k - 1] + h[k]);
        up[k] = h[k - 1];
        rhs[k] = 3 * (h[k] * d[k - 1] + h[k - 1] * d[k]);
    }
    diag[n - 1] = 1, rhs[n - 1] = n > 2 ? quadratic_end_slope(h[n - 2], h[n - 3], d[n - 2], d[n - 3]) : d[0];
    if (ratio && ratio[1] > 0)
        rhs[n - 1] = ratio[1] * d[n - 2];
    /* row k: lower = h[k] (k < n-1) or 0 (last, clamped), diag, upper = up[k] */
    for (int k = 1; k < n; k++) {
        double lower = k < n - 1 ? h[k] : 0, f = lower / diag[k - 1];
        diag[k] -= f * up[k - 1];
        rhs[k] -= f * rhs[k - 1];
    }
    m[n - 1] = rhs[n - 1] / diag[n - 1];
    for (int k = n - 2; k >= 0; k--)
        m[k] = (rhs[k] - up[k] * m[k + 1]) / diag[k];
}

/* Fritsch-Carlson: a segment stays monotone if its end slopes keep the data's sign and
 * alpha^2 + beta^2 <= 9; where the smooth spline breaks that, its knots fall back to the
 * harmonic-mean slopes, which always satisfy it. */
static int segment_monotone(double d, double m0, double m1)
{
    if (d == 0)
        return m0 == 0 && m1 == 0;
    double a = m0 / d, b = m1 / d;
    return a >= 0 && b >= 0 && a * a + b * b <= 9;
}

static void harmonic_slopes(const double *h, const double *d, int n, double *m)
{
    for (int k = 1; k < n - 1; k++) {
        if (d[k - 1] * d[k] <= 0) {
            m[k] = 0;
            continue;
        }
        double w1 = 2 * h[k] + h[k - 1], w2 = h[k] + 2 * h[k - 1];
        m[k] = (w1 + w2) / (w1 / d[k - 1] + w2 / d[k]);
    }
    m[0] = pchip_end_slope(h[0], h[1], d[0], d[1]);
    m[n - 1] = pchip_end_slope(h[n - 2], h[n - 3], d[n - 2], d[n - 3]);
}

int wdr_pchip_init(wdr_pchip *p, const double *lx, const double *y, int n)
{
    return wdr_pchip_init_ends(p, lx, y, n, NULL);
}

int wdr_pchip_init_ends(wdr_pchip *p, const double *lx, const double *y, int n, const double *end_ratio)
{
    double h[WDR_PCHIP_MAX], d[WDR_PCHIP_MAX], safe[WDR_PCHIP_MAX];
    if (n < 2 || n > WDR_PCHIP_MAX)
        return WDR_E_INVAL;
    p->n = n;
    for (int k = 0; k < n; k++) {
        if (!isfinite(lx[k]) || !isfinite(y[k]) || (k > 0 && !(lx[k] > lx[k - 1])))
            return WDR_E_INVAL;
        p->lx[k] = lx[k];
        p->y[k] = y[k];
    }
    for (int k = 0; k < n - 1; k++) {
        h[k] = lx[k + 1] - lx[k];
        d[k] = (y[k + 1] - y[k]) / h[k];
    }
    if (n == 2) {
        p->m[0] = p->m[1] = d[0];
        return WDR_OK;
    }
    spline_slopes(h, d, n, end_ratio, p->m);
    harmonic_slopes(h, d, n, safe);
    for (int k = 0; k < n - 1; k++)
        if (!segment_monotone(d[k], p->m[k], p->m[k + 1]))
            p->m[k] = safe[k], p->m[k + 1] = safe[k + 1];
    return WDR_OK;
}

static int pchip_segment(const wdr_pchip *p, double lx)
{
    int lo = 0, hi = p->n - 1;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (lx < p->lx[mid])
            hi = mid;
        else
            lo = mid;
    }
    return lo;
}

/* The Hermite cubic of segment k and its derivative, at lx inside it. */
static double segment_value(const wdr_pchip *p, int k, double lx)
{
    double h = p->lx[k + 1] - p->lx[k], t = (lx - p->lx[k]) / h, t2 = t * t, t3 = t2 * t;
    return (2 * t3 - 3 * t2 + 1) * p->y[k] + (t3 - 2 * t2 + t) * h * p->m[k] + (-2 * t3 + 3 * t2) * p->y[k + 1] +
           (t3 - t2) * h * p->m[k + 1];
}

static double segment_slope(const wdr_pchip *p, int k, double lx)
{
    double h = p->lx[k + 1] - p->lx[k], t = (lx - p->lx[k]) / h, t2 = t * t;
    return (6 * t2 - 6 * t) / h * p->y[k] + (3 * t2 - 4 * t + 1) * p->m[k] + (-6 * t2 + 6 * t) / h * p->y[k + 1] +
           (3 * t2 - 2 * t) * p->m[k + 1];
}

/* Outside the knots the curve continues as a straight line in ln x along the end secant: the
 * end tangent of a flattening response can be zero, and a flat extension has no inverse. */
static double end_secant(const wdr_pchip *p, int last)
{
    int k = last ? p->n - 2 : 0;
    return (p->y[k + 1] - p->y[k]) / (p->lx[k + 1] - p->lx[k]);
}

double wdr_pchip_eval(const wdr_pchip *p, double lx)
{
    if (lx <= p->lx[0])
        return p->y[0] + end_secant(p, 0) * (lx - p->lx[0]);
    if (lx >= p->lx[p->n - 1])
        return p->y[p->n - 1] + end_secant(p, 1) * (lx - p->lx[p->n - 1]);
    return segment_value(p, pchip_segment(p, lx), lx);
}

double wdr_pchip_slope(const wdr_pchip *p, double lx)
{
    if (lx <= p->lx[0])
        return end_secant(p, 0);
    if (lx >= p->lx[p->n - 1])
        return end_secant(p, 1);
    return segment_slope(p, pchip_segment(p, lx), lx);
}

/* Newton on the segment's cubic, kept inside the segment by bisection. It stops once a step no
 * longer moves lx or the bracket holds no double between its ends: the cubic's own rounding (a
 * few ulp of y) can exceed the residual bound, and then the bracket closes to adjacent doubles
 * that Newton only swaps (before this stop, one call in seven ran all 100 iterations, and the
 * calibration spent a third of its time there). */
static double segment_invert(const wdr_pchip *p, int k, double y)
{
    double lo = p->lx[k], hi = p->lx[k + 1], dir = p->y[k + 1] > p->y[k] ? 1 : -1;
    double lx = lo + (hi - lo) * (y - p->y[k]) / (p->y[k + 1] - p->y[k]);
    for (int it = 0; it < 100 && hi - lo > 1e-16 * (1 + fabs(lx)); it++) {
        double r = (segment_value(p, k, lx) - y) * dir;
        if (fabs(r) <= 4e-16 * (1 + fabs(y)))
            break;
        if (r > 0)
            hi = lx;
        else
            lo = lx;
        double d = segment_slope(p, k, lx) * dir, next = d > 0 ? lx - r / d : NAN;
        next = next >= lo && next <= hi ? next : 0.5 * (lo + hi);
        if (next == lx || !(nextafter(lo, hi) < hi))
            break;
        lx = next;
    }
    return lx;
}

double wdr_pchip_invert(const wdr_pchip *p, double y)
{
    int n = p->n, dir = p->y[n - 1] > p->y[0] ? 1 : -1;
    if ((y - p->y[0]) * dir <= 0) {
        double s = end_secant(p, 0);
        return s != 0 ? p->lx[0] + (y - p->y[0]) / s : p->lx[0];
    }
    if ((y - p->y[n - 1]) * dir >= 0) {
        double s = end_secant(p, 1);
        return s != 0 ? p->lx[n - 1] + (y - p->y[n - 1]) / s : p->lx[n - 1];
    }
    int lo = 0, hi = n - 1; /* invariant: y between y[lo] and y[hi] */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if ((y - p->y[mid]) * dir < 0)
            hi = mid;
        else
            lo = mid;
    }
    return segment_invert(p, lo, y);
}
