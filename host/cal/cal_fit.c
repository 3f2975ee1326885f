/* Array calibration: bad pixels, nominal curve, per-pixel fits. Table building is in cal_table.c. */
#include "cal_fit.h"
#include "cal_design.h"
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
    c->max_residual = 0.05;
    c->tie_codes = 0.5;
}

/* ---- monotone cubic Hermite curve: spline slopes where they keep it monotone, else
 * Fritsch-Carlson (PCHIP) slopes; monotone data give a monotone curve ---- */

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
    int k = pchip_segment(p, lx);
    double h = p->lx[k + 1] - p->lx[k], t = (lx - p->lx[k]) / h, t2 = t * t, t3 = t2 * t;
    return (2 * t3 - 3 * t2 + 1) * p->y[k] + (t3 - 2 * t2 + t) * h * p->m[k] + (-2 * t3 + 3 * t2) * p->y[k + 1] +
           (t3 - t2) * h * p->m[k + 1];
}

double wdr_pchip_slope(const wdr_pchip *p, double lx)
{
    if (lx <= p->lx[0])
        return end_secant(p, 0);
    if (lx >= p->lx[p->n - 1])
        return end_secant(p, 1);
    int k = pchip_segment(p, lx);
    double h = p->lx[k + 1] - p->lx[k], t = (lx - p->lx[k]) / h, t2 = t * t;
    return (6 * t2 - 6 * t) / h * p->y[k] + (3 * t2 - 4 * t + 1) * p->m[k] + (-6 * t2 + 6 * t) / h * p->y[k + 1] +
           (3 * t2 - 2 * t) * p->m[k + 1];
}

/* Newton on the segment's cubic, kept inside the segment by bisection. */
static double segment_invert(const wdr_pchip *p, int k, double y)
{
    double lo = p->lx[k], hi = p->lx[k + 1], dir = p->y[k + 1] > p->y[k] ? 1 : -1;
    double lx = lo + (hi - lo) * (y - p->y[k]) / (p->y[k + 1] - p->y[k]);
    for (int it = 0; it < 100 && hi - lo > 1e-16 * (1 + fabs(lx)); it++) {
        double r = (wdr_pchip_eval(p, lx) - y) * dir;
        if (fabs(r) <= 4e-16 * (1 + fabs(y)))
            break;
        if (r > 0)
            hi = lx;
        else
            lo = lx;
        double d = wdr_pchip_slope(p, lx) * dir, next = d > 0 ? lx - r / d : NAN;
        lx = next >= lo && next <= hi ? next : 0.5 * (lo + hi);
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

/* ---- the nominal pixel ---- */

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

/* ---- bad pixels ---- */

/* k-th smallest of v[0..n-1] by quickselect (v is reordered): medians of whole frames are
 * the bulk of a closed-form calibration's time, and a full sort is not needed. */
static float select_kth(float *v, long n, long k)
{
    long lo = 0, hi = n - 1;
    while (lo < hi) {
        float pivot = v[lo + (hi - lo) / 2];
        long i = lo, j = hi;
        while (i <= j) {
            while (v[i] < pivot)
                i++;
            while (v[j] > pivot)
                j--;
            if (i <= j) {
                float t = v[i];
                v[i++] = v[j];
                v[j--] = t;
            }
        }
        if (k <= j)
            hi = j;
        else if (k >= i)
            lo = i;
        else
            return v[k];
    }
    return v[k];
}

/* Median of the finite values among n (copied into scratch: the caller's data stays in order). */
static double median_of(const float *v, long n, float *scratch)
{
    long m = 0;
    for (long i = 0; i < n; i++)
        if (isfinite(v[i]))
            scratch[m++] = v[i];
    if (m == 0)
        return 0;
    double hi = select_kth(scratch, m, m / 2);
    if (m % 2)
        return hi;
    float lo = scratch[0]; /* after selection everything below m/2 is <= hi: take their maximum */
    for (long i = 1; i < m / 2; i++)
        lo = scratch[i] > lo ? scratch[i] : lo;
    return 0.5 * (lo + hi);
}

/* Robust spread: 1.4826 * median absolute deviation. */
static double mad_sigma(const float *v, long n, double med, float *scratch)
{
    float *dev = scratch + n;
    for (long i = 0; i < n; i++)
        dev[i] = isfinite(v[i]) ? fabsf(v[i] - (float)med) : 0.0f;
    return 1.4826 * median_of(dev, n, scratch);
}

static void flag_range(const wdr_cal_levels *lv, const wdr_cal_config *cfg, double med_swing, uint8_t *flags)
{
    long np = (long)lv->width * lv->height;
    for (long i = 0; i < np; i++) {
        double lo = INFINITY, hi = -INFINITY;
        for (int k = 0; k < lv->n; k++) {
            double y = lv->frames[(long)k * np + i];
            if (!isfinite(y)) {
                flags[i] |= WDR_PIX_DEAD;
                break;
            }
            lo = fmin(lo, y);
            hi = fmax(hi, y);
            if (y <= 0.5 || y >= cfg->raw_max - 0.5)
                flags[i] |= WDR_PIX_SATURATED;
        }
        double swing = lv->frames[i] - lv->frames[(long)(lv->n - 1) * np + i];
        if (hi - lo <= cfg->stuck_frac * med_swing)
            flags[i] |= WDR_PIX_STUCK;
        else if (!(swing >= cfg->dead_frac * med_swing))
            flags[i] |= WDR_PIX_DEAD;
    }
}

static void flag_hot(const wdr_cal_levels *lv, const wdr_cal_config *cfg, float *scratch, uint8_t *flags)
{
    long np = (long)lv->width * lv->height;
    double med_dark = median_of(lv->dark, np, scratch);
    double sig = mad_sigma(lv->dark, np, med_dark, scratch);
    double med_low = median_of(lv->frames, np, scratch);
    double limit = fmax(8 * sig, cfg->hot_frac * fabs(med_dark - med_low));
    for (long i = 0; i < np; i++)
        if (!isfinite(lv->dark[i]) || med_dark - lv->dark[i] > limit)
            flags[i] |= WDR_PIX_HOT;
}

void wdr_cal_detect_bad(const wdr_cal_levels *lv, const wdr_cal_config *cfg, uint8_t *flags, int *saturated_levels)
{
    long np = (long)lv->width * lv->height;
    float *scratch = malloc(sizeof(float) * 2 * (size_t)np);
    memset(flags, 0, (size_t)np);
    *saturated_levels = 0;
    if (!scratch || lv->n < 2) {
        free(scratch);
        return;
    }
    double first = median_of(lv->frames, np, scratch);
    double last = median_of(lv->frames + (long)(lv->n - 1) * np, np, scratch);
    for (int k = 0; k < lv->n; k++) {
        double m = median_of(lv->frames + (long)k * np, np, scratch);
        *saturated_levels += m <= 0.5 || m >= cfg->raw_max - 0.5;
    }
    flag_range(lv, cfg, first - last, flags);
    if (lv->dark)
        flag_hot(lv, cfg, scratch, flags);
    free(scratch);
}

/* ---- per-pixel fits ---- */

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

/* LSQ: three basis weights found by QR for each trial offset; the offset by a 1-D search over
 * this fraction of the nominal swing either side of the pixel's bright-end deviation. */
#define LSQ_LINEAR 4
#define LSQ_SEARCH_FRAC 0.03
#define LSQ_SCAN 8    /* scan points either side */
#define LSQ_GOLDEN 20 /* refinement steps: the bracket shrinks to 1e-4 of a scan step */

static int is_curve_model(int model)
{
    return model == WDR_MODEL_LSQ || model == WDR_MODEL_POLYMAP || model == WDR_MODEL_SPLINE;
}

/* The POLYMAP map's input variable: raw codes onto [-1, 1], the same as the table header's. */
static double lsq_u(const wdr_cal_result *res, double y) { return 2 * y / res->cfg.raw_max - 1; }

static double poly_eval(const double *c, int n, double u)
{
    double v = c[n - 1];
    for (int k = n - 2; k >= 0; k--)
        v = v * u + c[k];
    return v;
}

/* Fit one pixel with a paper model; u[] and y[] already ordered (dark reference first). */
static int fit_paper_pixel(const wdr_cal_result *res, const double *u, const double *y, double *par)
{
    int st, ref = res->cfg.use_dark_ref;
    if (res->model == WDR_MODEL_SIMPLE3) {
        wdr_simple3 m = {.x_scale = res->x_scale};
        st = ref ? wdr_simple3_fit_dark(u + 1, y + 1, u[0], y[0], &m) : wdr_simple3_fit3(u, y, &m);
        par[0] = m.a, par[1] = m.b, par[2] = m.c, par[3] = m.d;
    } else {
        wdr_complex4 m = {.x_scale = res->x_scale};
        st = ref ? wdr_complex4_fit_dark(u + 1, y + 1, u[0], y[0], &m) : wdr_complex4_fit4(u, y, &m);
        par[0] = m.p, par[1] = m.q, par[2] = m.r, par[3] = m.s, par[4] = m.d;
    }
    return st;
}

/* POLYMAP: the polynomial map from this pixel's codes to the nominal codes at the same currents,
 * weighted so each residual is in units of ln x (i.e. relative current, the contrast error). */
static int fit_polymap_pixel(const wdr_cal_result *res, const double *y, const double *target, const double *w,
                         int n, double *par)
{
    int nc = res->n_params;
    double a[WDR_CAL_MAX_LEVELS * WDR_CAL_MAX_COEFFS], t[WDR_CAL_MAX_LEVELS], rcond;
    for (int k = 0; k < n; k++) {
        double u = lsq_u(res, y[k]), p = 1;
        for (int j = 0; j < nc; j++, p *= u)
            a[k * nc + j] = p;
        t[k] = target[k];
    }
    int st = wdr_lsq_solve(a, t, w, n, nc, par, &rcond);
    if (st)
        return st;
    double ss = 0;
    for (int k = 0; k < n; k++) {
        double r = (poly_eval(par, nc, lsq_u(res, y[k])) - target[k]) * w[k];
        ss += r * r;
    }
    if (!(sqrt(ss / n) <= res->cfg.max_residual))
        return WDR_FIT_RESIDUAL;
    /* the map must keep the pixel's order of brightness across its calibrated span */
    for (int s = 0; s <= 16; s++) {
        double yy = y[n - 1] + (y[0] - y[n - 1]) * s / 16.0, u = lsq_u(res, yy), dv = 0, p = 1;
        for (int j = 1; j < nc; j++, p *= u)
            dv += j * par[j] * p;
        if (!(dv > 0))
            return WDR_FIT_REVERSED;
    }
    return WDR_FIT_OK;
}

/* Fast inverse of the nominal curve: table guess, then one Newton step (the curve is smooth
 * and the guess is within a fraction of a code). Outside the table: the full inverse. */
static double nominal_invert_lx(const wdr_nominal *n, double z)
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

static int build_inverse_table(wdr_nominal *n)
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
        double lx = nominal_invert_lx(n, z);
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
static double lsq_recover_u(const wdr_cal_result *res, const double *theta, double y)
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

static int fit_lsq_pixel(const wdr_cal_result *res, const double *y, const double *u, int n, const double *med,
                         double *theta)
{
    double r = lsq_search_offset(res, y, u, n, med, theta);
    if (!isfinite(r))
        return WDR_FIT_ILL_COND;
    if (!(r <= res->cfg.max_residual))
        return WDR_FIT_RESIDUAL;
    /* recovered current must rise as the code falls across the calibrated span */
    double prev = -INFINITY;
    for (int s = 0; s <= 32; s++) {
        double x = lsq_recover_u(res, theta, y[0] + (y[n - 1] - y[0]) * s / 32.0);
        if (!(x > prev))
            return WDR_FIT_REVERSED;
        prev = x;
    }
    return WDR_FIT_OK;
}

/* Nominal dark level: the response is linear in x below the lowest currents, so the secant of
 * the two lowest levels continued to zero current. (The dark frame is no substitute: dark current
 * moves it, and under slow ramps it holds the ramp's last code.) */
static double dark_top(const wdr_cal_levels *lv, const double *med)
{
    double b = (med[0] - med[1]) / (lv->amps[1] - lv->amps[0]);
    return med[0] + b * lv->amps[0];
}

/* A falling curve through quantised codes: where the response is flat the codes of neighbouring
 * levels tie, or even rise by less than an LSB. Within the tie tolerance that is quantisation, and
 * a tiny step keeps the curve strictly falling (its inverse then lands inside the tie, which is
 * all the data can tell); a larger rise is a reversed pixel. */
#define TIE_STEP 1e-5

static int falling_repair(const double *y, int n, double tie, double *out)
{
    for (int k = 0; k < n; k++) {
        if (!isfinite(y[k]))
            return WDR_FIT_NONFINITE;
        out[k] = y[k];
        if (k > 0 && y[k] > y[k - 1] + tie)
            return WDR_FIT_REVERSED;
        if (k > 0 && out[k] > out[k - 1] - TIE_STEP)
            out[k] = out[k - 1] - TIE_STEP;
    }
    return WDR_FIT_OK;
}

/* SPLINE: the pixel's own responses are the model. Where the array's response falls clearly
 * between two levels, a pixel that hardly moves there is a stuck stretch, not quantisation. */
static int fit_spline_pixel(const double *y, const double *med, int n, double tie, double *par)
{
    int st = falling_repair(y, n, tie, par);
    for (int k = 1; !st && k < n; k++)
        if (med[k - 1] - med[k] > 8 * tie && y[k - 1] - y[k] < 0.1 * (med[k - 1] - med[k]))
            st = WDR_FIT_FLAT;
    return st;
}

static double spline_recover(const wdr_cal_result *res, const double *par, double y)
{
    wdr_pchip p;
    if (wdr_pchip_init_ends(&p, res->nominal.curve.lx, par, res->nominal.curve.n, res->nominal.end_ratio))
        return 0;
    double lx = wdr_pchip_invert(&p, y);
    return lx > log(1e-22) ? exp(fmin(lx, log(1e-2))) : 0;
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

static int fit_nominal(const wdr_cal_levels *lv, wdr_cal_result *res, const double *med, char *err, int errlen)
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
    if (is_curve_model(res->model)) {
        double falling[WDR_CAL_MAX_LEVELS] = {0};
        st = falling_repair(med, lv->n, res->cfg.tie_codes, falling); /* strictly falling: invertible */
        if (!st && !(falling[0] - falling[lv->n - 1] > lv->n * TIE_STEP))
            st = WDR_FIT_FLAT;
        design_end_ratios(lv, res->cfg.design, n->end_ratio);
        if (!st)
            st = wdr_pchip_init_ends(&n->curve, lx, falling, lv->n, n->end_ratio) ? WDR_FIT_REVERSED : WDR_FIT_OK;
        n->y_top = !st ? dark_top(lv, falling) : 0;
        if (!st && res->model == WDR_MODEL_LSQ && build_inverse_table(n))
            return WDR_E_NOMEM;
    } else {
        st = fit_paper_pixel(res, u, med, par);
        if (st && res->cfg.use_dark_ref) {
            /* the median's dark reading does not fit the model: its current scale keeps d = 0 */
            wdr_cal_result plain = *res;
            plain.cfg.use_dark_ref = 0;
            memset(par, 0, sizeof par);
            st = fit_paper_pixel(&plain, u + 1, med + 1, par);
        }
    }
    n->s3 = (wdr_simple3){par[0], par[1], par[2], par[3], res->x_scale};
    n->c4 = (wdr_complex4){par[0], par[1], par[2], par[3], par[4], res->x_scale, 0};
    if (st)
        snprintf(err, (size_t)errlen, "the array's median response cannot be fitted: %s", wdr_fit_status_name(st));
    return st ? WDR_E_NUMERIC : WDR_OK;
}

static int check_levels(const wdr_cal_levels *lv, const wdr_cal_config *cfg, char *err, int errlen)
{
    int need = levels_needed(cfg);
    if (cfg->model <= WDR_MODEL_NONE || cfg->model >= WDR_MODEL_COUNT) {
        snprintf(err, (size_t)errlen, "unknown calibration model %d", cfg->model);
        return WDR_E_INVAL;
    }
    if (is_curve_model(cfg->model) ? lv->n < need : lv->n != need) {
        snprintf(err, (size_t)errlen, "model needs %s%d calibration levels, got %d",
                 is_curve_model(cfg->model) ? "at least " : "", need, lv->n);
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
static int level_medians(const wdr_cal_levels *lv, const uint8_t *flags, double *med)
{
    long np = (long)lv->width * lv->height;
    float *good = malloc(sizeof(float) * 2 * (size_t)np);
    if (!good)
        return WDR_E_NOMEM;
    for (int k = 0; k < lv->n; k++) {
        long m = 0;
        for (long i = 0; i < np; i++)
            if (!flags[i])
                good[m++] = lv->frames[(long)k * np + i];
        med[k] = m ? median_of(good, m, good + np) : 0;
    }
    free(good);
    return WDR_OK;
}

static void fit_all_pixels(const wdr_cal_levels *lv, wdr_cal_result *res, const double *med)
{
    long np = (long)lv->width * lv->height;
    double u[WDR_CAL_MAX_LEVELS], y[WDR_CAL_MAX_LEVELS], w[WDR_CAL_MAX_LEVELS];
    for (int k = 0; k < lv->n; k++) {
        u[k] = lv->amps[k] / res->x_scale;
        w[k] = 1 / fmax(wdr_nominal_log_slope(&res->nominal, lv->amps[k]), 1e-9);
    }
    for (long i = 0; i < np; i++) {
        double *par = res->params + i * res->n_params;
        if (res->flags[i])
            continue;
        for (int k = 0; k < lv->n; k++)
            y[k] = lv->frames[(long)k * np + i];
        int st;
        if (res->model == WDR_MODEL_LSQ)
            st = fit_lsq_pixel(res, y, u, lv->n, med, par);
        else if (res->model == WDR_MODEL_POLYMAP)
            st = fit_polymap_pixel(res, y, med, w, lv->n, par);
        else if (res->model == WDR_MODEL_SPLINE)
            st = fit_spline_pixel(y, med, lv->n, res->cfg.tie_codes, par);
        else
            st = fit_paper_pixel(res, u, y, par);
        if (st) {
            res->status[i] = (uint8_t)st;
            res->flags[i] |= WDR_PIX_UNFIT;
        }
    }
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
    if ((rc = level_medians(lv, res->flags, med)) || (rc = fit_nominal(lv, res, med, err, errlen)))
        return rc;
    fit_all_pixels(lv, res, med);
    count_flags(res);
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
        u = lsq_recover_u(res, p, y);
        return isfinite(u) ? u * res->x_scale : 0;
    } else if (res->model == WDR_MODEL_SPLINE) {
        return spline_recover(res, p, y);
    } else {
        return wdr_nominal_invert(&res->nominal, poly_eval(p, res->n_params, lsq_u(res, y)));
    }
    if (clamped && !*status)
        *status = WDR_FIT_ILL_COND;
    return u * res->x_scale;
}

double wdr_cal_map(const wdr_cal_result *res, long i, double y)
{
    int st;
    if (res->model == WDR_MODEL_POLYMAP)
        return poly_eval(res->params + i * res->n_params, res->n_params, lsq_u(res, y));
    return wdr_nominal_eval(&res->nominal, wdr_cal_recover(res, i, y, &st));
}
