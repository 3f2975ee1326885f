/* BASIS table form: a shared table of basis functions of the raw code, learnt from the array.
 *
 * Why: a pixel's map (raw code -> nominal code) is smooth for most operators, but Drago and
 * Tumblin-Rushmeier bend sharply within a few codes at the dark end, where a contrast error of
 * 1 % is a few hundredths of a code, and a polynomial of <= 8 coefficients in the raw code cannot
 * follow. The pixels differ from each other by a few physical parameters, so their maps span a
 * low-dimensional family: n shared functions tabulated finely, and n coefficients per pixel,
 * follow the bend as closely as the shared table's resolution allows.
 *
 * How: the maps of a sample of good pixels are tabulated on the shared grid, weighted by the
 * nominal curve's 1/|dy/d ln x| (a code error there is a contrast error); their mean and first
 * n-1 principal components (subspace iteration on the weighted covariance) start the basis.
 * Alternating least squares then fits what the kernel computes, on each pixel's own samples:
 * the pixels' coefficients (Householder QR), then the table (conjugate gradients on the normal
 * equations, a small second-difference penalty keeping points no sample reaches smooth). */
#include "cal_basis.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SAMPLE_PIXELS 512  /* pixels the basis is learnt from (evenly spread over the array) */
#define PCA_ITERATIONS 60
#define ALS_ROUNDS 4
#define CG_STEPS 80
#define SMOOTH_PENALTY 1e-4 /* relative to the mean diagonal of the normal equations */
#define RANGE_PAD 0.02      /* of the code span, on each side of the sampled codes */
#define MIN_LOG_SLOPE 1.0   /* codes per unit of ln x: floor of the weights' slope */

typedef struct learner {
    const wdr_cal_result *res;
    int n, points, m;        /* basis size, table points, sample pixels */
    double lo, step;
    double *table;           /* points x n, point-major, double while learning */
    wdr_map_samples *s;      /* m sample pixels' samples */
    double *c;               /* m x n coefficients */
} learner;

/* Position of code y on the grid: point index j < points - 1 and fraction f, clamped as the
 * kernel clamps. */
static int grid_point(int points, double lo, double step, double y, double *f)
{
    double t = (y - lo) / step;
    t = t > 0 ? t : 0;
    t = t < points - 1 ? t : points - 1;
    int j = (int)t;
    j = j < points - 1 ? j : points - 2;
    *f = t - j;
    return j;
}

static double table_at(const learner *L, const double *tab, double y, int k)
{
    double f;
    int j = grid_point(L->points, L->lo, L->step, y, &f);
    const double *p = tab + (long)j * L->n;
    return p[k] + f * (p[L->n + k] - p[k]);
}

/* ---- sample pixels and the code range ---- */

static int pick_pixels(learner *L, long *idx)
{
    long np = (long)L->res->width * L->res->height, good = 0;
    for (long i = 0; i < np; i++)
        good += !L->res->flags[i];
    long stride = good / SAMPLE_PIXELS > 1 ? good / SAMPLE_PIXELS : 1;
    int m = 0;
    for (long i = 0, g = 0; i < np && m < SAMPLE_PIXELS; i++)
        if (!L->res->flags[i] && g++ % stride == 0)
            idx[m++] = i;
    return m;
}

static int code_range(learner *L)
{
    double ylo = INFINITY, yhi = -INFINITY;
    for (int p = 0; p < L->m; p++)
        for (int k = 0; k < WDR_BASIS_SAMPLES; k++) {
            double y = L->s[p].y[k];
            if (isfinite(y))
                ylo = fmin(ylo, y), yhi = fmax(yhi, y);
        }
    if (!(yhi - ylo > 1e-6))
        return 0;
    double pad = RANGE_PAD * (yhi - ylo);
    L->lo = ylo - pad;
    L->step = (yhi - ylo + 2 * pad) / (L->points - 1);
    return 1;
}

/* ---- start: mean and principal components of the weighted maps on the grid ---- */

static double grid_weight(const wdr_cal_result *res, double y)
{
    const wdr_nominal *nom = &res->nominal;
    double x = fmin(fmax(wdr_nominal_invert(nom, y), nom->x_lo), nom->x_hi);
    return 1 / fmax(wdr_nominal_log_slope(nom, x), MIN_LOG_SLOPE);
}

static void orthonormalise(double *v, int nv, int len)
{
    for (int k = 0; k < nv; k++) {
        double *a = v + (long)k * len;
        for (int q = 0; q < k; q++) {
            const double *b = v + (long)q * len;
            double d = 0;
            for (int j = 0; j < len; j++)
                d += a[j] * b[j];
            for (int j = 0; j < len; j++)
                a[j] -= d * b[j];
        }
        double norm = 0;
        for (int j = 0; j < len; j++)
            norm += a[j] * a[j];
        norm = sqrt(norm);
        for (int j = 0; j < len; j++)
            a[j] = norm > 0 ? a[j] / norm : (j == k); /* a lost direction restarts on a unit vector */
    }
}

/* Top nv eigenvectors of the symmetric K x K matrix cov by subspace iteration. */
static void top_eigenvectors(const double *cov, int K, int nv, double *v, double *tmp)
{
    for (int k = 0; k < nv; k++)
        for (int j = 0; j < K; j++)
            v[(long)k * K + j] = cos(0.37 * (k + 1) * j + k) + 1e-3 * j; /* deterministic, generic */
    orthonormalise(v, nv, K);
    for (int it = 0; it < PCA_ITERATIONS; it++) {
        for (int k = 0; k < nv; k++)
            for (int a = 0; a < K; a++) {
                double s = 0;
                for (int b = 0; b < K; b++)
                    s += cov[(long)a * K + b] * v[(long)k * K + b];
                tmp[(long)k * K + a] = s;
            }
        memcpy(v, tmp, sizeof(double) * (size_t)nv * (size_t)K);
        orthonormalise(v, nv, K);
    }
}

static int start_basis(learner *L, const long *idx)
{
    int K = L->points, n = L->n;
    double *g = malloc(sizeof(double) * (size_t)L->m * K), *mean = calloc((size_t)K, sizeof(double)),
           *wt = malloc(sizeof(double) * K), *cov = calloc((size_t)K * K, sizeof(double)),
           *v = malloc(sizeof(double) * (size_t)K * n), *tmp = malloc(sizeof(double) * (size_t)K * n);
    int ok = g && mean && wt && cov && v && tmp;
    if (ok) {
        for (int j = 0; j < K; j++)
            wt[j] = grid_weight(L->res, L->lo + j * L->step);
        for (int p = 0; p < L->m; p++)
            for (int j = 0; j < K; j++) {
                double y = wdr_cal_map(L->res, idx[p], L->lo + j * L->step);
                g[(long)p * K + j] = isfinite(y) ? y : 0;
                mean[j] += g[(long)p * K + j] / L->m;
            }
        for (int p = 0; p < L->m; p++) {
            double *r = g + (long)p * K;
            for (int j = 0; j < K; j++)
                r[j] = (r[j] - mean[j]) * wt[j];
            for (int a = 0; a < K; a++)
                for (int b = 0; b < K; b++)
                    cov[(long)a * K + b] += r[a] * r[b];
        }
        top_eigenvectors(cov, K, n - 1, v, tmp);
        for (int j = 0; j < K; j++) {
            L->table[(long)j * n] = mean[j];
            for (int k = 1; k < n; k++)
                L->table[(long)j * n + k] = v[(long)(k - 1) * K + j] / wt[j];
        }
    }
    free(g), free(mean), free(wt), free(cov), free(v), free(tmp);
    return ok;
}

/* ---- alternating least squares ---- */

static int fit_pixel(const learner *L, const double *tab, const wdr_map_samples *s, double *c)
{
    double a[WDR_BASIS_SAMPLES * WDR_CAL_MAX_COEFFS], t[WDR_BASIS_SAMPLES], rcond;
    for (int k = 0; k < WDR_BASIS_SAMPLES; k++) {
        t[k] = s->t[k];
        for (int q = 0; q < L->n; q++)
            a[k * L->n + q] = table_at(L, tab, s->y[k], q);
    }
    return !wdr_lsq_solve(a, t, s->w, WDR_BASIS_SAMPLES, L->n, c, &rcond);
}

/* out = (A^T W^2 A + lambda D^T D) in, A the samples' rows in the table's unknowns. */
static void normal_apply(const learner *L, double lambda, const double *in, double *out)
{
    int n = L->n;
    memset(out, 0, sizeof(double) * (size_t)L->points * n);
    for (int p = 0; p < L->m; p++) {
        const double *c = L->c + (long)p * n;
        for (int k = 0; k < WDR_BASIS_SAMPLES; k++) {
            double f, v = 0, w2 = L->s[p].w[k] * L->s[p].w[k];
            int j = grid_point(L->points, L->lo, L->step, L->s[p].y[k], &f);
            const double *i0 = in + (long)j * n;
            for (int q = 0; q < n; q++)
                v += c[q] * ((1 - f) * i0[q] + f * i0[n + q]);
            double *o0 = out + (long)j * n;
            for (int q = 0; q < n; q++) {
                o0[q] += w2 * v * c[q] * (1 - f);
                o0[n + q] += w2 * v * c[q] * f;
            }
        }
    }
    for (int j = 1; j < L->points - 1; j++)
        for (int q = 0; q < n; q++) {
            double d2 = lambda * (in[(long)(j - 1) * n + q] - 2 * in[(long)j * n + q] + in[(long)(j + 1) * n + q]);
            out[(long)(j - 1) * n + q] += d2;
            out[(long)j * n + q] -= 2 * d2;
            out[(long)(j + 1) * n + q] += d2;
        }
}

static double normal_lambda(const learner *L)
{
    double diag = 0;
    for (int p = 0; p < L->m; p++)
        for (int k = 0; k < WDR_BASIS_SAMPLES; k++) {
            double c2 = 0;
            for (int q = 0; q < L->n; q++)
                c2 += L->c[(long)p * L->n + q] * L->c[(long)p * L->n + q];
            c2 *= L->s[p].w[k] * L->s[p].w[k];
            diag += c2;
        }
    return SMOOTH_PENALTY * diag / ((double)L->points * L->n);
}

/* Conjugate gradients from the current table; vectors of points * n. */
static int refit_table(learner *L, double *work)
{
    long len = (long)L->points * L->n;
    double *rhs = work, *r = work + len, *p = work + 2 * len, *ap = work + 3 * len;
    double lambda = normal_lambda(L);
    memset(rhs, 0, sizeof(double) * (size_t)len);
    for (int q = 0; q < L->m; q++) {
        const double *c = L->c + (long)q * L->n;
        for (int k = 0; k < WDR_BASIS_SAMPLES; k++) {
            double f, w2t = L->s[q].w[k] * L->s[q].w[k] * L->s[q].t[k];
            int j = grid_point(L->points, L->lo, L->step, L->s[q].y[k], &f);
            for (int i = 0; i < L->n; i++) {
                rhs[(long)j * L->n + i] += w2t * c[i] * (1 - f);
                rhs[(long)(j + 1) * L->n + i] += w2t * c[i] * f;
            }
        }
    }
    normal_apply(L, lambda, L->table, ap);
    double rr = 0;
    for (long i = 0; i < len; i++) {
        r[i] = rhs[i] - ap[i];
        p[i] = r[i];
        rr += r[i] * r[i];
    }
    for (int it = 0; it < CG_STEPS && rr > 0; it++) {
        normal_apply(L, lambda, p, ap);
        double pap = 0, rn = 0;
        for (long i = 0; i < len; i++)
            pap += p[i] * ap[i];
        if (!(pap > 0))
            break;
        double alpha = rr / pap;
        for (long i = 0; i < len; i++) {
            L->table[i] += alpha * p[i];
            r[i] -= alpha * ap[i];
            rn += r[i] * r[i];
        }
        for (long i = 0; i < len; i++)
            p[i] = r[i] + rn / rr * p[i];
        rr = rn;
    }
    for (long i = 0; i < len; i++)
        if (!isfinite(L->table[i]))
            return 0;
    return 1;
}

static int alternate(learner *L)
{
    double *work = malloc(sizeof(double) * 4 * (size_t)L->points * L->n);
    int ok = work != NULL;
    for (int round = 0; ok && round < ALS_ROUNDS; round++) {
        for (int p = 0; p < L->m; p++)
            if (!fit_pixel(L, L->table, &L->s[p], L->c + (long)p * L->n))
                memset(L->c + (long)p * L->n, 0, sizeof(double) * L->n); /* leaves the table's fit */
        ok = refit_table(L, work);
    }
    free(work);
    return ok;
}

/* ---- the float table ---- */

static int to_float_table(const learner *L, wdr_basis *b)
{
    long len = (long)L->points * L->n;
    b->table = malloc(sizeof(float) * (size_t)len);
    if (!b->table)
        return WDR_E_NOMEM;
    for (long i = 0; i < len; i++)
        b->table[i] = fabs(L->table[i]) < 1e30 ? (float)L->table[i] : 0.0f;
    b->n = L->n, b->points = L->points, b->lo = L->lo, b->step = L->step;
    return wdr_cal_shared_check(b->table, (uint16_t)b->n, (uint32_t)b->points) ? WDR_E_NUMERIC : WDR_OK;
}

int wdr_cal_basis_learn(const wdr_cal_result *res, int n, wdr_basis *b, char *err, int errlen)
{
    learner L = {.res = res, .n = n, .points = (int)(WDR_CAL_MAX_SHARED_FLOATS / (unsigned)n)};
    long idx[SAMPLE_PIXELS];
    memset(b, 0, sizeof *b);
    L.m = pick_pixels(&L, idx);
    if (L.m < 2 * n) {
        snprintf(err, (size_t)errlen, "shared basis: %d good pixels, need at least %d", L.m, 2 * n);
        return WDR_E_NUMERIC;
    }
    L.s = malloc(sizeof *L.s * (size_t)L.m);
    L.c = malloc(sizeof(double) * (size_t)L.m * n);
    L.table = malloc(sizeof(double) * (size_t)L.points * n);
    int rc = L.s && L.c && L.table ? WDR_OK : WDR_E_NOMEM;
    for (int p = 0; !rc && p < L.m; p++)
        wdr_cal_map_samples(res, idx[p], &L.s[p]);
    if (!rc && !code_range(&L)) {
        snprintf(err, (size_t)errlen, "shared basis: the pixels' codes span no range");
        rc = WDR_E_NUMERIC;
    }
    if (!rc && !start_basis(&L, idx))
        rc = WDR_E_NOMEM;
    if (!rc && !alternate(&L)) {
        snprintf(err, (size_t)errlen, "shared basis: the table fit did not stay finite");
        rc = WDR_E_NUMERIC;
    }
    if (!rc && (rc = to_float_table(&L, b)) == WDR_E_NUMERIC)
        snprintf(err, (size_t)errlen, "shared basis: degenerate (a basis function is zero everywhere)");
    if (rc == WDR_E_NOMEM)
        snprintf(err, (size_t)errlen, "shared basis: out of memory");
    free(L.s), free(L.c), free(L.table);
    if (rc)
        wdr_cal_basis_free(b);
    return rc;
}

void wdr_cal_basis_free(wdr_basis *b)
{
    free(b->table);
    b->table = NULL;
}

/* As the kernel: float position and float interpolation. */
static double kernel_basis(const wdr_basis *b, double y, int k)
{
    float a = (float)(1 / b->step), off = (float)(-b->lo / b->step), last = (float)(b->points - 1);
    float t = (float)y * a + off;
    t = t > 0.0f ? t : 0.0f;
    t = t < last ? t : last;
    int j = (int)t;
    j = j < (int)last ? j : (int)last - 1;
    float f = t - (float)j;
    const float *p0 = b->table + (long)j * b->n, *p1 = p0 + b->n;
    return p0[k] + f * (p1[k] - p0[k]);
}

int wdr_cal_basis_coeffs(const wdr_basis *b, const wdr_map_samples *s, double *c)
{
    double a[WDR_BASIS_SAMPLES * WDR_CAL_MAX_COEFFS], t[WDR_BASIS_SAMPLES], rcond;
    for (int k = 0; k < WDR_BASIS_SAMPLES; k++) {
        t[k] = s->t[k];
        for (int q = 0; q < b->n; q++)
            a[k * b->n + q] = kernel_basis(b, s->y[k], q);
    }
    if (wdr_lsq_solve(a, t, s->w, WDR_BASIS_SAMPLES, b->n, c, &rcond))
        return 0;
    for (int q = 0; q < b->n; q++)
        if (!(fabs(c[q]) < 1e30))
            return 0;
    return 1;
}
