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
    static const char *const names[WDR_FIT_COUNT] = {"ok",
                                                     "non-finite input",
                                                     "flat response (zero slope)",
                                                     "reversed slope",
                                                     "calibration currents too close",
                                                     "ill-conditioned system",
                                                     "pole inside the range",
                                                     "residual too large",
                                                     "dark reference off the model"};
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

/* Norm of column k from row k down, as a plain sum of squares: wdr_lsq_solve equilibrates every
 * column to a largest entry of 1 first, and the reflections keep each column's norm, so nothing
 * overflows; a remainder whose square underflows is far below RCOND_MIN, refused either way. (A
 * hypot() chain, safe for any scale, took a sixth of the calibration's time.) */
static double column_norm(const double *a, int m, int n, int k)
{
    double sum = 0;
    for (int i = k; i < m; i++)
        sum += a[i * n + k] * a[i * n + k];
    return sqrt(sum);
}

/* Reflect columns k.. and y so that column k is zero below the diagonal. */
static int householder_step(double *a, double *y, int m, int n, int k)
{
    double norm = column_norm(a, m, n, k);
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
 * a, b, c from the three currents and then d as the shift that puts the dark reading at u0.
 * y_first, u_first: the first light level, which the dark reading must lie above. */
static int simple3_shift_to_dark(wdr_simple3 *m, double u_first, double y_first, double u0, double y0)
{
    double t0;
    if (!isfinite(y0) || y0 <= y_first)
        return WDR_FIT_REVERSED; /* the dark reference is not darker than the first current */
    if (wdr_simple3_invert(m, y0, 1e6, &t0))
        return WDR_FIT_DARK;
    m->d = t0 - u0;
    /* the shift must leave the first light level at a positive model current: a model that
     * cannot bend to the dark end puts the dark reading further out than that (Drago) */
    return isfinite(m->d) && m->d > -u_first ? WDR_FIT_OK : WDR_FIT_DARK;
}

int wdr_simple3_fit_dark(const double u[3], const double y[3], double u0, double y0, wdr_simple3 *m)
{
    int st = wdr_simple3_fit3(u, y, m);
    return st ? st : simple3_shift_to_dark(m, u[0], y[0], u0, y0);
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

static int complex4_shift_to_dark(wdr_complex4 *m, double u_first, double y_first, double u0, double y0)
{
    double t0;
    int clamped;
    if (!isfinite(y0) || y0 <= y_first)
        return WDR_FIT_REVERSED;
    if (wdr_complex4_invert(m, y0, 1e6, &t0, &clamped) || clamped)
        return WDR_FIT_DARK; /* the dark reading lies above the model's highest response */
    m->d = t0 - u0;
    return isfinite(m->d) && m->d > -u_first ? WDR_FIT_OK : WDR_FIT_DARK;
}

int wdr_complex4_fit_dark(const double u[4], const double y[4], double u0, double y0, wdr_complex4 *m)
{
    int st = wdr_complex4_fit4(u, y, m);
    return st ? st : complex4_shift_to_dark(m, u[0], y[0], u0, y0);
}

/* ---- weighted least squares on the code residuals (Gauss-Newton) ----
 * A level's code carries its rounding (and what is left of the temporal noise) in codes, the
 * same at every level: least squares on the code residuals is the fit that averages it. */

#define GN_MAX_STEPS 50
#define GN_MAX_HALVINGS 30
#define GN_MAX_PARAMS 4

/* A model for the solver: f(t) and its gradient in the parameters; 0 where the denominator is
 * not positive (the pole side of the curve, never physical). */
typedef int (*gn_eval_fn)(const double *th, double t, double *f, double *grad);

static double weighted_ss(gn_eval_fn eval, const double *th, const double *u, const double *y, const double *w, int n)
{
    double ss = 0, f, grad[GN_MAX_PARAMS];
    for (int i = 0; i < n; i++) {
        if (!eval(th, u[i], &f, grad))
            return INFINITY;
        double r = (y[i] - f) * (w ? w[i] : 1);
        ss += r * r;
    }
    return isfinite(ss) ? ss : INFINITY;
}

/* One Gauss-Newton step: min |W (J step - r)| by QR. */
static int gn_step(gn_eval_fn eval, int p, const double *th, const double *u, const double *y, const double *w, int n,
                   double *step, double *rcond)
{
    double jac[LSQ_MAX_M * GN_MAX_PARAMS], r[LSQ_MAX_M], f;
    for (int i = 0; i < n; i++) {
        if (!eval(th, u[i], &f, jac + i * p))
            return WDR_FIT_POLE;
        r[i] = y[i] - f;
    }
    return wdr_lsq_solve(jac, r, w, n, p, step, rcond);
}

/* Gauss-Newton from th (pole-free at every point), each step halved until the weighted residual
 * falls; stops where no step lowers it, or the gain is at rounding level, or after GN_MAX_STEPS. */
static int gauss_newton(gn_eval_fn eval, int p, const double *u, const double *y, const double *w, int n, double *th,
                        double *rcond)
{
    double ss = weighted_ss(eval, th, u, y, w, n), trial[GN_MAX_PARAMS], step[GN_MAX_PARAMS];
    if (!isfinite(ss))
        return WDR_FIT_POLE;
    for (int it = 0; it < GN_MAX_STEPS && ss > 0; it++) {
        int st = gn_step(eval, p, th, u, y, w, n, step, rcond);
        if (st)
            return st;
        double lambda = 1, ss_new = INFINITY;
        for (int h = 0; h < GN_MAX_HALVINGS && !(ss_new < ss); h++, lambda *= 0.5) {
            for (int j = 0; j < p; j++)
                trial[j] = th[j] + lambda * step[j];
            ss_new = weighted_ss(eval, trial, u, y, w, n);
        }
        if (!(ss_new < ss))
            break; /* no step along the Gauss-Newton direction lowers the residual: the minimum */
        memcpy(th, trial, sizeof(double) * (size_t)p);
        double gain = ss - ss_new;
        ss = ss_new;
        if (gain <= 1e-13 * ss)
            break;
    }
    return all_finite(th, p) ? WDR_FIT_OK : WDR_FIT_NONFINITE;
}

/* What every least-squares fit asks of its data: currents rising, codes finite and falling from
 * the first to the last point (ties and small reversals between are the fit's to average). */
static int lsq_data_ok(const double *u, const double *y, int n, int p)
{
    if (n < p || n > LSQ_MAX_M)
        return WDR_FIT_ILL_COND;
    int st = currents_ok(u, n);
    if (st)
        return st;
    if (!all_finite(y, n))
        return WDR_FIT_NONFINITE;
    return y[n - 1] < y[0] ? WDR_FIT_OK : y[n - 1] == y[0] ? WDR_FIT_FLAT : WDR_FIT_REVERSED;
}

/* simple3: th = (a, b, c), f = a - b t / (1 + c t) */
static int simple3_gn_eval(const double *th, double t, double *f, double *grad)
{
    double den = 1 + th[2] * t;
    if (!(den > 0))
        return 0;
    *f = th[0] - th[1] * t / den;
    grad[0] = 1;
    grad[1] = -t / den;
    grad[2] = th[1] * t * t / (den * den);
    return 1;
}

/* The exact fit through the first, a middle and the last point (the middle nearest the centre
 * that the closed form accepts). */
static int simple3_start(const double *u, const double *y, int n, wdr_simple3 *m)
{
    int st = WDR_FIT_ILL_COND;
    for (int off = 0; off < n - 2; off++) {
        int k = n / 2 + (off % 2 ? -(off + 1) / 2 : off / 2);
        if (k < 1 || k > n - 2)
            continue;
        double uu[3] = {u[0], u[k], u[n - 1]}, yy[3] = {y[0], y[k], y[n - 1]};
        if (!(st = wdr_simple3_fit3(uu, yy, m)))
            return WDR_FIT_OK;
    }
    return st;
}

int wdr_simple3_fit_lsq(const double *u, const double *y, const double *w, int n, wdr_simple3 *m)
{
    if (n == 3)
        return wdr_simple3_fit3(u, y, m);
    int st = lsq_data_ok(u, y, n, 3);
    if (st || (st = simple3_start(u, y, n, m)))
        return st;
    double th[3] = {m->a, m->b, m->c}, rcond;
    if ((st = gauss_newton(simple3_gn_eval, 3, u, y, w, n, th, &rcond)))
        return st;
    if (!(th[1] > 0))
        return WDR_FIT_REVERSED; /* b > 0: the curve falls everywhere off its pole */
    m->a = th[0], m->b = th[1], m->c = th[2], m->d = 0;
    return WDR_FIT_OK;
}

int wdr_simple3_fit_lsq_dark(const double *u, const double *y, const double *w, int n, double u0, double y0,
                             wdr_simple3 *m)
{
    int st = wdr_simple3_fit_lsq(u, y, w, n, m);
    return st ? st : simple3_shift_to_dark(m, u[0], y[0], u0, y0);
}

/* complex4: th = (P, Q, R, S), f = (P + Q t - R t^2) / (1 + S t) */
static int complex4_gn_eval(const double *th, double t, double *f, double *grad)
{
    double den = 1 + th[3] * t;
    if (!(den > 0))
        return 0;
    *f = (th[0] + th[1] * t - th[2] * t * t) / den;
    grad[0] = 1 / den;
    grad[1] = t / den;
    grad[2] = -t * t / den;
    grad[3] = -t * *f / den;
    return 1;
}

/* Eq. 23 over all points: y = P + Q u - R u^2 - S u y, linear in the parameters (QR). */
static int complex4_start(const double *u, const double *y, const double *w, int n, double *th)
{
    double a[LSQ_MAX_M * 4], b[LSQ_MAX_M], rcond;
    for (int i = 0; i < n; i++) {
        a[i * 4 + 0] = 1;
        a[i * 4 + 1] = u[i];
        a[i * 4 + 2] = -u[i] * u[i];
        a[i * 4 + 3] = -y[i] * u[i];
        b[i] = y[i];
    }
    return wdr_lsq_solve(a, b, w, n, 4, th, &rcond);
}

/* complex4 with R held: th = (P, Q, S), f = (P + Q t - R t^2) / (1 + S t). R rides beside the
 * solver's parameters (per thread: fits may run in parallel). */
static _Thread_local double held_r;

static int complex4_held_r_gn_eval(const double *th, double t, double *f, double *grad)
{
    double den = 1 + th[2] * t;
    if (!(den > 0))
        return 0;
    *f = (th[0] + th[1] * t - held_r * t * t) / den;
    grad[0] = 1 / den;
    grad[1] = t / den;
    grad[2] = -t * *f / den;
    return 1;
}

static int complex4_falls_at_points(const wdr_complex4 *m, const double *u, int n)
{
    for (int i = 0; i < n; i++)
        if (!falling_at(m, u[i], wdr_complex4_eval(m, u[i])))
            return 0;
    return 1;
}

/* (P, Q, S) by least squares with R held; 1 when the curve falls at every point. */
static int complex4_fit_held_r(const double *u, const double *y, const double *w, int n, double r, double *th3,
                               wdr_complex4 *m)
{
    double rcond = 0;
    held_r = r;
    if (gauss_newton(complex4_held_r_gn_eval, 3, u, y, w, n, th3, &rcond))
        return 0;
    *m = (wdr_complex4){th3[0], th3[1], r, th3[2], 0, m->x_scale, rcond};
    return complex4_falls_at_points(m, u, n);
}

#define HELD_R_BISECTIONS 12

int wdr_complex4_fit_lsq(const double *u, const double *y, const double *w, int n, wdr_complex4 *m)
{
    if (n == 4)
        return wdr_complex4_fit4(u, y, m);
    int st = lsq_data_ok(u, y, n, 4);
    double th[4], rcond = 0;
    if (st || (st = complex4_start(u, y, w, n, th)) || (st = gauss_newton(complex4_gn_eval, 4, u, y, w, n, th, &rcond)))
        return st;
    *m = (wdr_complex4){th[0], th[1], th[2], th[3], 0, m->x_scale, rcond};
    if (complex4_falls_at_points(m, u, n))
        return WDR_FIT_OK;
    /* A curve that turns up inside the span is not a pixel's response: it comes from R < 0 fitted
     * to the rounding of a flat bright end (Reinhard's asymptote at 12 bits: a quarter of a
     * healthy chip was flagged "reversed"). R < 0 bends the curve up, R = 0 (a Moebius curve)
     * always falls: the least squares among falling curves is at the R between, nearest the free
     * fit's, where the curve just stops turning; found by bisection (R = 0 alone cost the middle
     * of the range twice its 12-bit floor, tests/calibration/test_cal_endslope.c). */
    if (!(th[2] < 0))
        return WDR_FIT_REVERSED;
    wdr_complex4 good = *m, trial = *m;
    double th3[3] = {th[0], th[1], th[3]}, good3[3], bad_r = th[2], good_r = 0;
    if (!complex4_fit_held_r(u, y, w, n, 0, th3, &good))
        return WDR_FIT_REVERSED;
    memcpy(good3, th3, sizeof good3);
    for (int k = 0; k < HELD_R_BISECTIONS; k++) {
        double r = 0.5 * (bad_r + good_r), t3[3] = {good3[0], good3[1], good3[2]};
        if (complex4_fit_held_r(u, y, w, n, r, t3, &trial)) {
            good = trial, good_r = r;
            memcpy(good3, t3, sizeof good3);
        } else
            bad_r = r;
    }
    *m = good;
    return WDR_FIT_OK;
}

int wdr_complex4_fit_lsq_dark(const double *u, const double *y, const double *w, int n, double u0, double y0,
                              wdr_complex4 *m)
{
    int st = wdr_complex4_fit_lsq(u, y, w, n, m);
    return st ? st : complex4_shift_to_dark(m, u[0], y[0], u0, y0);
}
