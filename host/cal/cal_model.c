/* Calibration models and the linear algebra under them. */
#include "cal_model.h"
#include <math.h>
#include <string.h>

#define LINALG_MAX_N 8
#define LSQ_MAX_M 64
/* Below this reciprocal condition a double solution keeps fewer than ~3 significant digits. */
#define RCOND_MIN 1e-13

const char *wdr_fit_status_name(int status)
{
    static const char *const names[WDR_FIT_COUNT] = {
        "ok", "non-finite input", "flat response (zero slope)", "reversed slope",
        "calibration currents too close", "ill-conditioned system", "pole inside the range",
        "residual too large"};
    return status >= 0 && status < WDR_FIT_COUNT ? names[status] : "unknown";
}

static int all_finite(const double *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* ---- LU with partial pivoting ---- */

/* Scale each column to unit max-norm so the pivots compare like with like; returns 0 on a zero column. */
static int equilibrate_columns(double *a, int m, int n, double *scale)
{
    for (int j = 0; j < n; j++) {
        double mx = 0;
        for (int i = 0; i < m; i++)
            mx = fmax(mx, fabs(a[i * n + j]));
        if (!(mx > 0))
            return 0;
        scale[j] = 1.0 / mx;
        for (int i = 0; i < m; i++)
            a[i * n + j] *= scale[j];
    }
    return 1;
}

static void swap_rows(double *a, double *b, int n, int r1, int r2)
{
    for (int j = 0; j < n; j++) {
        double t = a[r1 * n + j];
        a[r1 * n + j] = a[r2 * n + j];
        a[r2 * n + j] = t;
    }
    double t = b[r1];
    b[r1] = b[r2];
    b[r2] = t;
}

static int pick_pivot(const double *a, int n, int k)
{
    int p = k;
    for (int i = k + 1; i < n; i++)
        if (fabs(a[i * n + k]) > fabs(a[p * n + k]))
            p = i;
    return p;
}

/* Upper-triangular back substitution; diag stride lets LU (n) and QR (n) share it. */
static void back_substitute(const double *u, const double *b, int n, double *x)
{
    for (int i = n - 1; i >= 0; i--) {
        double s = b[i];
        for (int j = i + 1; j < n; j++)
            s -= u[i * n + j] * x[j];
        x[i] = s / u[i * n + i];
    }
}

static double diag_rcond(const double *u, int n)
{
    double lo = INFINITY, hi = 0;
    for (int i = 0; i < n; i++) {
        lo = fmin(lo, fabs(u[i * n + i]));
        hi = fmax(hi, fabs(u[i * n + i]));
    }
    return hi > 0 ? lo / hi : 0;
}

int wdr_lu_solve(double *a, double *b, int n, double rcond_min, double *x, double *rcond)
{
    double scale[LINALG_MAX_N];
    *rcond = 0;
    if (n < 1 || n > LINALG_MAX_N || !all_finite(a, n * n) || !all_finite(b, n))
        return WDR_FIT_NONFINITE;
    if (!equilibrate_columns(a, n, n, scale))
        return WDR_FIT_ILL_COND;
    for (int k = 0; k < n; k++) {
        int p = pick_pivot(a, n, k);
        if (p != k)
            swap_rows(a, b, n, p, k);
        if (a[k * n + k] == 0)
            return WDR_FIT_ILL_COND;
        for (int i = k + 1; i < n; i++) {
            double f = a[i * n + k] / a[k * n + k];
            for (int j = k; j < n; j++)
                a[i * n + j] -= f * a[k * n + j];
            b[i] -= f * b[k];
        }
    }
    *rcond = diag_rcond(a, n);
    if (*rcond < (rcond_min > 0 ? rcond_min : RCOND_MIN))
        return WDR_FIT_ILL_COND;
    back_substitute(a, b, n, x);
    for (int j = 0; j < n; j++)
        x[j] *= scale[j];
    return all_finite(x, n) ? WDR_FIT_OK : WDR_FIT_NONFINITE;
}

/* ---- Householder QR least squares ---- */

/* Reflect columns k.. and y so that column k is zero below the diagonal. */
static int householder_step(double *a, double *y, int m, int n, int k)
{
    double norm = 0;
    for (int i = k; i < m; i++)
        norm = hypot(norm, a[i * n + k]);
    if (norm == 0)
        return 0;
    double alpha = a[k * n + k] > 0 ? -norm : norm;
    double v[LSQ_MAX_M];
    for (int i = k; i < m; i++)
        v[i] = a[i * n + k];
    v[k] -= alpha;
    double vv = 0;
    for (int i = k; i < m; i++)
        vv += v[i] * v[i];
    for (int j = k; j < n; j++) {
        double s = 0;
        for (int i = k; i < m; i++)
            s += v[i] * a[i * n + j];
        s *= 2 / vv;
        for (int i = k; i < m; i++)
            a[i * n + j] -= s * v[i];
    }
    double s = 0;
    for (int i = k; i < m; i++)
        s += v[i] * y[i];
    s *= 2 / vv;
    for (int i = k; i < m; i++)
        y[i] -= s * v[i];
    return 1;
}

int wdr_lsq_solve(double *a, double *y, const double *w, int m, int n, double *c, double *rcond)
{
    double scale[LINALG_MAX_N];
    *rcond = 0;
    if (n < 1 || n > LINALG_MAX_N || m < n || m > LSQ_MAX_M || !all_finite(a, m * n) || !all_finite(y, m))
        return WDR_FIT_NONFINITE;
    for (int i = 0; w && i < m; i++) {
        if (!isfinite(w[i]) || w[i] < 0)
            return WDR_FIT_NONFINITE;
        for (int j = 0; j < n; j++)
            a[i * n + j] *= w[i];
        y[i] *= w[i];
    }
    if (!equilibrate_columns(a, m, n, scale))
        return WDR_FIT_ILL_COND;
    for (int k = 0; k < n; k++)
        if (!householder_step(a, y, m, n, k))
            return WDR_FIT_ILL_COND;
    *rcond = diag_rcond(a, n); /* the top n x n block of a is R, with row stride n */
    if (*rcond < RCOND_MIN)
        return WDR_FIT_ILL_COND;
    back_substitute(a, y, n, c);
    for (int j = 0; j < n; j++)
        c[j] *= scale[j];
    return all_finite(c, n) ? WDR_FIT_OK : WDR_FIT_NONFINITE;
}

/* ---- quadratic ---- */

int wdr_quadratic_root(double r, double b, double c, double *t, int *clamped)
{
    double disc = b * b - 4 * r * c;
    *clamped = 0;
    *t = 0;
    if (!isfinite(disc) || !isfinite(c))
        return WDR_FIT_NONFINITE;
    if (disc < 0) {
        disc = 0;
        *clamped = 1;
    }
    double q = -0.5 * (b + copysign(sqrt(disc), b));
    if (q == 0)
        return WDR_FIT_FLAT;
    *t = c / q;
    return isfinite(*t) ? WDR_FIT_OK : WDR_FIT_NONFINITE;
}

/* ---- 3-parameter model ---- */

/* Currents closer than this (relative) carry no usable difference in double arithmetic. */
#define MIN_REL_SEPARATION 1e-9

static int currents_ok(const double *u, int n)
{
    for (int i = 0; i < n; i++) {
        if (!isfinite(u[i]) || u[i] < 0)
            return WDR_FIT_NONFINITE;
        if (i > 0 && !(u[i] - u[i - 1] > MIN_REL_SEPARATION * u[i]))
            return WDR_FIT_CLOSE_CURRENTS;
    }
    return WDR_FIT_OK;
}

/* Responses must fall strictly with current (the pixel's output drops as light rises). */
static int responses_ok(const double *y, int n)
{
    if (!all_finite(y, n))
        return WDR_FIT_NONFINITE;
    for (int i = 1; i < n; i++) {
        if (y[i] == y[i - 1])
            return WDR_FIT_FLAT;
        if (y[i] > y[i - 1])
            return WDR_FIT_REVERSED;
    }
    return WDR_FIT_OK;
}

int wdr_simple3_fit3(const double u[3], const double y[3], wdr_simple3 *m)
{
    int st = currents_ok(u, 3);
    if (st || (st = responses_ok(y, 3)))
        return st;
    double d12 = y[0] - y[1], d23 = y[1] - y[2];
    /* (y1-y2)/(y2-y3) = (u2-u1)(1+c u3) / ((u3-u2)(1+c u1)) is linear in c */
    double rho = d12 * (u[2] - u[1]) / (d23 * (u[1] - u[0]));
    double den = rho * u[0] - u[2];
    if (!isfinite(rho) || den == 0)
        return WDR_FIT_ILL_COND;
    double c = (1 - rho) / den;
    if (!(1 + c * u[2] > 0) || !(1 + c * u[0] > 0))
        return WDR_FIT_POLE;
    double b = d12 * (1 + c * u[0]) * (1 + c * u[1]) / (u[1] - u[0]);
    double a = y[0] + b * u[0] / (1 + c * u[0]);
    if (!isfinite(a) || !isfinite(b) || !isfinite(c))
        return WDR_FIT_NONFINITE;
    m->a = a;
    m->b = b;
    m->c = c;
    m->d = 0;
    return WDR_FIT_OK;
}

double wdr_simple3_eval(const wdr_simple3 *m, double u)
{
    double t = u + m->d;
    return m->a - m->b * t / (1 + m->c * t);
}

double wdr_simple3_slope(const wdr_simple3 *m, double u)
{
    double den = 1 + m->c * (u + m->d);
    return -m->b / (den * den);
}

int wdr_simple3_invert(const wdr_simple3 *m, double y, double u_cap, double *u)
{
    double w = m->a - y, den = m->b - m->c * w;
    double t = w / den;
    if (!(den > 0) || !isfinite(t) || t - m->d > u_cap) {
        *u = u_cap;
        return WDR_FIT_POLE;
    }
    *u = t - m->d;
    return WDR_FIT_OK;
}

/* The paper's eq. 20, with the dark reference allowed at a current u0 >= 0: the Moebius family
 * is closed under shifts of u, so d cannot be fitted together with a, b, c; the paper takes
 * a, b, c from the three currents and then d as the shift that puts the dark reading at u0. */
int wdr_simple3_fit_dark(const double u[3], const double y[3], double u0, double y0, wdr_simple3 *m)
{
    int st = wdr_simple3_fit3(u, y, m);
    if (st)
        return st;
    double t0;
    if (!isfinite(y0) || y0 <= y[0] || wdr_simple3_invert(m, y0, 1e6, &t0))
        return WDR_FIT_REVERSED; /* the dark reference is not darker than the first current */
    m->d = t0 - u0;
    return isfinite(m->d) && m->d > -u[0] ? WDR_FIT_OK : WDR_FIT_ILL_COND;
}

/* ---- 4-parameter model ---- */

int wdr_complex4_fit4(const double u[4], const double y[4], wdr_complex4 *m)
{
    int st = currents_ok(u, 4);
    if (st || (st = responses_ok(y, 4)))
        return st;
    double a[16], b[4], x[4], rcond;
    for (int i = 0; i < 4; i++) {
        a[i * 4 + 0] = 1;
        a[i * 4 + 1] = u[i];
        a[i * 4 + 2] = -u[i] * u[i];
        a[i * 4 + 3] = -y[i] * u[i];
        b[i] = y[i];
    }
    st = wdr_lu_solve(a, b, 4, 0, x, &rcond);
    m->rcond = rcond;
    if (st)
        return st;
    m->p = x[0];
    m->q = x[1];
    m->r = x[2];
    m->s = x[3];
    m->d = 0;
    if (!(1 + m->s * u[3] > 0) || !(1 + m->s * u[0] > 0))
        return WDR_FIT_POLE;
    return WDR_FIT_OK;
}

double wdr_complex4_eval(const wdr_complex4 *m, double u)
{
    double t = u + m->d;
    return (m->p + m->q * t - m->r * t * t) / (1 + m->s * t);
}

/* dy/dt < 0 at a root t of the model for response y: sign of (1 + S t)(Q - 2 R t - S y). */
static int falling_at(const wdr_complex4 *m, double t, double y)
{
    return (1 + m->s * t) * (m->q - 2 * m->r * t - m->s * y) < 0;
}

/* The two roots are C/q and q/R. Along a falling response the current rises, and which formula
 * gives it depends on the sign of S y - Q, which flips where a burning-out response (R > 0) passes
 * the Reinhard asymptote; a tiny R of either sign puts the other root far away. The physical
 * root is one where the model falls: the smallest non-negative such root, else the falling one
 * nearest zero (darker than dark), else the root nearest zero. */
static double physical_root(const wdr_complex4 *m, double q, double c, double y)
{
    double t[2] = {c / q, m->r != 0 ? q / m->r : c / q}, best = NAN;
    for (int pass = 0; pass < 3 && isnan(best); pass++)
        for (int k = 0; k < 2; k++) {
            if (!isfinite(t[k]))
                continue;
            int ok = pass == 0 ? falling_at(m, t[k], y) && t[k] >= 0 : pass == 1 ? falling_at(m, t[k], y) : 1;
            double key = pass == 0 ? t[k] : fabs(t[k]), cur = pass == 0 ? best : fabs(best);
            if (ok && (isnan(best) || key < cur))
                best = t[k];
        }
    return best;
}

int wdr_complex4_invert(const wdr_complex4 *m, double y, double u_cap, double *u, int *clamped)
{
    /* R t^2 + (S y - Q) t + (y - P) = 0 */
    double b = m->s * y - m->q, c = y - m->p, disc = b * b - 4 * m->r * c;
    *clamped = 0;
    *u = 0;
    if (!isfinite(disc))
        return WDR_FIT_NONFINITE;
    if (disc < 0) {
        disc = 0;
        *clamped = 1;
    }
    double q = -0.5 * (b + copysign(sqrt(disc), b));
    if (q == 0)
        return WDR_FIT_FLAT;
    double t = physical_root(m, q, c, y);
    if (!isfinite(t))
        return WDR_FIT_NONFINITE;
    if (t - m->d > u_cap) {
        *u = u_cap;
        return WDR_FIT_POLE;
    }
    *u = t - m->d;
    return WDR_FIT_OK;
}

int wdr_complex4_fit_dark(const double u[4], const double y[4], double u0, double y0, wdr_complex4 *m)
{
    int st = wdr_complex4_fit4(u, y, m), clamped;
    if (st)
        return st;
    double t0;
    if (!isfinite(y0) || y0 <= y[0] || wdr_complex4_invert(m, y0, 1e6, &t0, &clamped) || clamped)
        return WDR_FIT_REVERSED;
    m->d = t0 - u0;
    return isfinite(m->d) && m->d > -u[0] ? WDR_FIT_OK : WDR_FIT_ILL_COND;
}
