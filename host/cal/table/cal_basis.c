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
 * the pixels' coefficients (Householder QR, 64 log-spaced currents), then the table (conjugate
 * gradients on the block-tridiagonal normal equations, from 320 currents per pixel that also
 * cover the code range evenly, a small second-difference penalty keeping the few points no
 * sample reaches smooth). */
#include "cal_basis.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SAMPLE_PIXELS 512 /* pixels the basis is learnt from (evenly spread over the array) */
#define PCA_ITERATIONS 60
#define ALS_ROUNDS 4
/* SHIFTED: more rounds, each also moving weight to the currents where the pixels' spread is worst
 * (Lawson's minimax reweighting per current): the judged figure is the worst current, not the
 * mean, and four functions cannot bring every current down together (TR, seed 11, 64x48: worst
 * 1.44 % -> 1.09 % on the learner's samples). */
#define MINIMAX_ROUNDS 8 /* 14 rounds: 1.23 % against 1.11 % (TR, seed 11, anchor 6): it overfits */
/* The anchor sample (of the 64 log-spaced currents, 0 the dimmest) for the code shifts: near the
 * dark end, where Drago's and Tumblin-Rushmeier's maps bend and each pixel's dark level puts the
 * bend at its own code. Worst TR error (seed 11, 64x48, through the kernel) by anchor: 3 1.21 %,
 * 6 1.11 %, 10 0.97 %, 12 0.98 %, 14 0.97 %, 20 0.98 %, 30 1.83 %; no shift 2.14 %. */
#define SHIFT_ANCHOR 12
#define SHIFT_SEARCH 2 /* the final fit tries the anchor's shift +-2 (+-1: 1.01 %, +-4: 1.00 %) */
#define SHIFT_MAX 63
#define HOLDOUT_PHASE 1 /* basis_worst's pick for re-picked against anchor shifts: pixels not learnt on */
#define CG_STEPS 80
#define DENSE_CODES 256 /* the table's fit: samples evenly spaced in code, 2 grid steps apart at n = 8 */
/* Relative to the mean diagonal of the normal equations. The diagonal is dominated by the ends,
 * where the weights (one over a small slope) are largest: 1e-4 outweighed the samples mid-range
 * and the analog fit's objective rose from round to round; 1e-6 only holds what no sample reaches. */
#define SMOOTH_PENALTY 1e-6
#define RANGE_PAD 0.02    /* of the code span, on each side of the sampled codes */
#define MIN_LOG_SLOPE 1.0 /* codes per unit of ln x: floor of the weights' slope */

static double kernel_basis(const wdr_basis *b, double y, int k);

typedef struct learner {
    const wdr_cal_result *res;
    int n, points, m; /* basis size, table points, sample pixels */
    double lo, step;
    double *table;        /* points x n, point-major, double while learning */
    wdr_map_samples *s;   /* m sample pixels' samples */
    double *c;            /* m x n coefficients */
    int d;                /* samples per pixel of the table's fit (dense_currents) */
    double *dy, *dt, *dw; /* m x d: codes, targets, weights */
    double *dl;           /* d: ln x of the dense samples (the minimax weights follow ln x) */
    double *w0, *dw0;     /* the weights before the minimax factors (m x 64, m x d) */
    double *shift;        /* m: SHIFTED, each sample pixel's code shift; else NULL */
    double *shift0;       /* m: SHIFTED, the shift the anchor alone gives (the search's centre) */
    double *y0, *dy0;     /* SHIFTED: the codes before any shift (m x 64, m x d) */
    double anchor_code;
    int minimax; /* SHIFTED: the minimax reweighting (with or without shifts) */
    int repick;  /* SHIFTED: the shifts re-picked after every round but the last */
    double u[WDR_BASIS_SAMPLES];
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

/* Up to SAMPLE_PIXELS good pixels evenly spread; phase, where in each stride the pick falls
 * (basis_worst's HOLDOUT_PHASE judges on pixels the learner never saw). */
static int pick_pixels_from(learner *L, long *idx, long phase)
{
    long np = (long)L->res->width * L->res->height, good = 0;
    for (long i = 0; i < np; i++)
        good += !L->res->flags[i];
    long stride = good / SAMPLE_PIXELS > 1 ? good / SAMPLE_PIXELS : 1;
    int m = 0;
    for (long i = 0, g = 0; i < np && m < SAMPLE_PIXELS; i++)
        if (!L->res->flags[i] && g++ % stride == (stride > 1 ? phase % stride : 0))
            idx[m++] = i;
    return m;
}

static int pick_pixels(learner *L, long *idx)
{
    return pick_pixels_from(L, idx, 0);
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

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Currents for the table's fit: the 64 log-spaced ones of the coefficient fit and DENSE_CODES
 * more evenly spaced in the nominal code. Log spacing alone puts the samples 60-90 codes apart
 * mid-range (300-400 codes per unit of ln x) on a grid of 8-code steps: the grid points between
 * them are then held only by the spread of the pixels' offsets, and the fit, run to convergence,
 * bends them to the levels' rounding (12 bits: 1.5x the floor after 8 rounds; the 4 rounds
 * stopped early gave 1.24x). dens[k]: sqrt of the current's share of ln x over the log spacing,
 * so the weighted sum still measures the error evenly in ln x, as the contrast error is judged. */
static void dense_currents(const wdr_nominal *nom, double *xs, double *dens, int d)
{
    int nl = WDR_BASIS_SAMPLES, nc = d - nl;
    double lx0 = log(nom->x_lo), lx1 = log(nom->x_hi), y0 = wdr_nominal_eval(nom, nom->x_lo),
           y1 = wdr_nominal_eval(nom, nom->x_hi);
    for (int k = 0; k < nl; k++)
        xs[k] = lx0 + (lx1 - lx0) * k / (nl - 1);
    for (int k = 0; k < nc; k++) {
        double x = wdr_nominal_invert(nom, y0 + (y1 - y0) * (k + 0.5) / nc);
        xs[nl + k] = log(fmin(fmax(x, nom->x_lo), nom->x_hi));
    }
    qsort(xs, (size_t)d, sizeof *xs, cmp_double);
    double ref = (lx1 - lx0) / (nl - 1);
    for (int k = 0; k < d; k++) {
        double a = xs[k > 0 ? k - 1 : k], b = xs[k < d - 1 ? k + 1 : k];
        dens[k] = sqrt(fmax(0.5 * (b - a), 1e-9) / ref);
    }
    for (int k = 0; k < d; k++)
        xs[k] = exp(xs[k]);
}

static int dense_samples(learner *L, const long *idx)
{
    int d = WDR_BASIS_SAMPLES + DENSE_CODES;
    double *xs = malloc(sizeof(double) * d), *dens = malloc(sizeof(double) * d);
    L->d = d;
    L->dy = malloc(sizeof(double) * (size_t)L->m * d);
    L->dt = malloc(sizeof(double) * (size_t)L->m * d);
    L->dw = malloc(sizeof(double) * (size_t)L->m * d);
    L->dy0 = L->shift ? malloc(sizeof(double) * (size_t)L->m * d) : NULL;
    int ok = xs && dens && L->dy && L->dt && L->dw && (!L->shift || L->dy0);
    if (ok) {
        dense_currents(&L->res->nominal, xs, dens, d);
        for (int p = 0; p < L->m; p++) {
            double *w = L->dw + (long)p * d, *y = L->dy + (long)p * d;
            wdr_cal_map_samples_at(L->res, idx[p], xs, d, y, L->dt + (long)p * d, w);
            if (L->dy0)
                memcpy(L->dy0 + (long)p * d, y, sizeof(double) * d);
            for (int k = 0; k < d; k++) {
                w[k] *= dens[k];
                if (L->shift)
                    y[k] = fmin(y[k] + L->shift[p], L->res->cfg.raw_max);
            }
        }
    }
    L->dl = ok ? malloc(sizeof(double) * d) : NULL;
    for (int k = 0; ok && L->dl && k < d; k++)
        L->dl[k] = log(xs[k]);
    free(xs), free(dens);
    return ok && L->dl;
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
                double y = wdr_cal_map(L->res, idx[p], L->lo + j * L->step - (L->shift ? L->shift[p] : 0));
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

/* The data part of the table's normal equations, A^T W^2 A: a sample between points j and j + 1
 * couples only their n values each, so it is block tridiagonal (diagonal blocks nd, upper nu,
 * n x n per point), assembled once per round; the conjugate gradients then cost nothing per
 * sample, however densely the maps are sampled. */
static void normal_build(const learner *L, double *nd, double *nu)
{
    int n = L->n;
    size_t blocks = sizeof(double) * (size_t)L->points * n * n;
    memset(nd, 0, blocks), memset(nu, 0, blocks);
    for (int p = 0; p < L->m; p++) {
        const double *c = L->c + (long)p * n;
        for (int k = 0; k < L->d; k++) {
            long e = (long)p * L->d + k;
            double f, w2 = L->dw[e] * L->dw[e];
            int j = grid_point(L->points, L->lo, L->step, L->dy[e], &f);
            double a0 = w2 * (1 - f) * (1 - f), a1 = w2 * f * f, a01 = w2 * (1 - f) * f;
            double *d0 = nd + (long)j * n * n, *d1 = d0 + n * n, *u0 = nu + (long)j * n * n;
            for (int q = 0; q < n; q++)
                for (int r = 0; r < n; r++) {
                    double cc = c[q] * c[r];
                    d0[q * n + r] += a0 * cc, d1[q * n + r] += a1 * cc, u0[q * n + r] += a01 * cc;
                }
        }
    }
}

/* out = (A^T W^2 A + lambda D^T D) in, A the samples' rows in the table's unknowns. */
static void normal_apply(const learner *L, const double *nd, const double *nu, double lambda, const double *in,
                         double *out)
{
    int n = L->n;
    memset(out, 0, sizeof(double) * (size_t)L->points * n);
    for (int j = 0; j < L->points; j++) {
        const double *d = nd + (long)j * n * n, *u = nu + (long)j * n * n, *i0 = in + (long)j * n;
        double *o0 = out + (long)j * n;
        for (int q = 0; q < n; q++)
            for (int r = 0; r < n; r++)
                o0[q] += d[q * n + r] * i0[r];
        if (j + 1 < L->points)
            for (int q = 0; q < n; q++)
                for (int r = 0; r < n; r++) {
                    o0[q] += u[q * n + r] * i0[n + r];
                    o0[n + r] += u[q * n + r] * i0[q];
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
        for (int k = 0; k < L->d; k++) {
            double c2 = 0;
            for (int q = 0; q < L->n; q++)
                c2 += L->c[(long)p * L->n + q] * L->c[(long)p * L->n + q];
            c2 *= L->dw[(long)p * L->d + k] * L->dw[(long)p * L->d + k];
            diag += c2;
        }
    return SMOOTH_PENALTY * diag / ((double)L->points * L->n);
}

/* Conjugate gradients from the current table; vectors of points * n. */
static int refit_table(learner *L, double *work)
{
    long len = (long)L->points * L->n;
    double *rhs = work, *r = work + len, *p = work + 2 * len, *ap = work + 3 * len;
    double *nd = work + 4 * len, *nu = nd + len * L->n;
    double lambda = normal_lambda(L);
    normal_build(L, nd, nu);
    memset(rhs, 0, sizeof(double) * (size_t)len);
    for (int q = 0; q < L->m; q++) {
        const double *c = L->c + (long)q * L->n;
        for (int k = 0; k < L->d; k++) {
            long e = (long)q * L->d + k;
            double f, w2t = L->dw[e] * L->dw[e] * L->dt[e];
            int j = grid_point(L->points, L->lo, L->step, L->dy[e], &f);
            for (int i = 0; i < L->n; i++) {
                rhs[(long)j * L->n + i] += w2t * c[i] * (1 - f);
                rhs[(long)(j + 1) * L->n + i] += w2t * c[i] * f;
            }
        }
    }
    normal_apply(L, nd, nu, lambda, L->table, ap);
    double rr = 0;
    for (long i = 0; i < len; i++) {
        r[i] = rhs[i] - ap[i];
        p[i] = r[i];
        rr += r[i] * r[i];
    }
    for (int it = 0; it < CG_STEPS && rr > 0; it++) {
        normal_apply(L, nd, nu, lambda, p, ap);
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

/* ---- minimax weights (SHIFTED) ---- */

/* The factor at ln x, linear between the 64 log-spaced currents. */
static double weight_at(const learner *L, double lx)
{
    double lx0 = log(L->res->nominal.x_lo), lx1 = log(L->res->nominal.x_hi);
    double t = (lx - lx0) / (lx1 - lx0) * (WDR_BASIS_SAMPLES - 1);
    t = t < 0 ? 0 : t > WDR_BASIS_SAMPLES - 1 ? WDR_BASIS_SAMPLES - 1 : t;
    int j = (int)t < WDR_BASIS_SAMPLES - 1 ? (int)t : WDR_BASIS_SAMPLES - 2;
    return L->u[j] + (t - j) * (L->u[j + 1] - L->u[j]);
}

static void fit_pixels(learner *L)
{
    for (int p = 0; p < L->m; p++)
        if (!fit_pixel(L, L->table, &L->s[p], L->c + (long)p * L->n))
            memset(L->c + (long)p * L->n, 0, sizeof(double) * L->n); /* leaves the table's fit */
}

/* Lawson's step: each current's weight (squared) grows with its rms error over the pixels,
 * measured with the original weights; mean 1, kept within 1e-3..1e3. */
static void reweight(learner *L)
{
    double e2[WDR_BASIS_SAMPLES] = {0}, mean = 0;
    for (int p = 0; p < L->m; p++)
        for (int k = 0; k < WDR_BASIS_SAMPLES; k++) {
            double v = 0;
            for (int q = 0; q < L->n; q++)
                v += L->c[(long)p * L->n + q] * table_at(L, L->table, L->s[p].y[k], q);
            double e = (v - L->s[p].t[k]) * L->w0[(long)p * WDR_BASIS_SAMPLES + k];
            e2[k] += e * e;
        }
    for (int k = 0; k < WDR_BASIS_SAMPLES; k++)
        mean += (L->u[k] *= sqrt(e2[k] / L->m)) / WDR_BASIS_SAMPLES;
    for (int k = 0; k < WDR_BASIS_SAMPLES; k++)
        L->u[k] = mean > 0 ? fmin(fmax(L->u[k] / mean, 1e-3), 1e3) : 1;
    for (int p = 0; p < L->m; p++)
        for (int k = 0; k < WDR_BASIS_SAMPLES; k++)
            L->s[p].w[k] = L->w0[(long)p * WDR_BASIS_SAMPLES + k] * sqrt(L->u[k]);
    for (int k = 0; k < L->d; k++) {
        double f = sqrt(weight_at(L, L->dl[k]));
        for (int p = 0; p < L->m; p++)
            L->dw[(long)p * L->d + k] = L->dw0[(long)p * L->d + k] * f;
    }
}

static int keep_weights(learner *L)
{
    L->w0 = malloc(sizeof(double) * (size_t)L->m * WDR_BASIS_SAMPLES);
    L->dw0 = malloc(sizeof(double) * (size_t)L->m * L->d);
    if (!L->w0 || !L->dw0)
        return 0;
    for (int p = 0; p < L->m; p++)
        memcpy(L->w0 + (long)p * WDR_BASIS_SAMPLES, L->s[p].w, sizeof(double) * WDR_BASIS_SAMPLES);
    memcpy(L->dw0, L->dw, sizeof(double) * (size_t)L->m * L->d);
    return 1;
}

/* ---- the shifts re-picked (SHIFTED) ---- */

/* Weighted squared residual of sample pixel p's fit with its codes moved by shift d. */
static double learner_shift_cost(const learner *L, int p, int d)
{
    wdr_map_samples t = L->s[p];
    double c[WDR_CAL_MAX_COEFFS], e2 = 0;
    for (int k = 0; k < WDR_BASIS_SAMPLES; k++)
        t.y[k] = fmin(L->y0[(long)p * WDR_BASIS_SAMPLES + k] + d, L->res->cfg.raw_max);
    if (!fit_pixel(L, L->table, &t, c))
        return INFINITY;
    for (int k = 0; k < WDR_BASIS_SAMPLES; k++) {
        double v = 0;
        for (int q = 0; q < L->n; q++)
            v += c[q] * table_at(L, L->table, t.y[k], q);
        e2 += (v - t.t[k]) * (v - t.t[k]) * t.w[k] * t.w[k];
    }
    return e2;
}

static void move_pixel(learner *L, int p, int d)
{
    L->shift[p] = d;
    for (int k = 0; k < WDR_BASIS_SAMPLES; k++)
        L->s[p].y[k] = fmin(L->y0[(long)p * WDR_BASIS_SAMPLES + k] + d, L->res->cfg.raw_max);
    for (int k = 0; k < L->d; k++)
        L->dy[(long)p * L->d + k] = fmin(L->dy0[(long)p * L->d + k] + d, L->res->cfg.raw_max);
}

/* Each sample pixel takes the shift that fits it best on the table as learnt so far, searched
 * where the final fit searches (wdr_cal_basis_shift: the anchor's shift +-SHIFT_SEARCH). The
 * table is then learnt on the shifts the pixels will be fitted with, not on the anchor's alone. */
static int clamp_shift(double d);

static void repick_shifts(learner *L)
{
    for (int p = 0; p < L->m; p++) {
        int best = (int)L->shift[p];
        double cost = INFINITY;
        /* within the flag byte's range, as the final fit's search (clamp_shift) */
        for (int d = clamp_shift(L->shift0[p] - SHIFT_SEARCH); d <= clamp_shift(L->shift0[p] + SHIFT_SEARCH); d++) {
            double e = learner_shift_cost(L, p, d);
            if (e < cost)
                cost = e, best = d;
        }
        move_pixel(L, p, best);
    }
}

static int alternate(learner *L)
{
    double *work = malloc(sizeof(double) * (4 + 2 * (size_t)L->n) * (size_t)L->points * L->n);
    int ok = work != NULL && (!L->minimax || keep_weights(L));
    int rounds = L->minimax ? MINIMAX_ROUNDS : ALS_ROUNDS;
    for (int round = 0; ok && round < rounds; round++) {
        fit_pixels(L);
        if (L->minimax && round > 0) {
            reweight(L);
            fit_pixels(L);
        }
        ok = refit_table(L, work);
        if (ok && L->repick && round + 1 < rounds)
            repick_shifts(L);
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
    b->shifted = L->shift != NULL, b->anchor_code = L->anchor_code, b->raw_max = L->res->cfg.raw_max;
    for (int k = 0; k < WDR_BASIS_SAMPLES; k++)
        b->u[k] = sqrt(L->u[k]);
    return wdr_cal_shared_check(b->table, (uint16_t)b->n, (uint32_t)b->points) ? WDR_E_NUMERIC : WDR_OK;
}

/* SHIFTED: the anchor code (the sample pixels' mean there) and each sample pixel's shift. */
static int shift_samples(learner *L)
{
    L->shift = malloc(sizeof(double) * (size_t)L->m);
    L->shift0 = malloc(sizeof(double) * (size_t)L->m);
    L->y0 = malloc(sizeof(double) * (size_t)L->m * WDR_BASIS_SAMPLES);
    if (!L->shift || !L->shift0 || !L->y0)
        return 0;
    wdr_basis b = {.shifted = 1, .raw_max = L->res->cfg.raw_max};
    for (int p = 0; p < L->m; p++)
        b.anchor_code += L->s[p].y[SHIFT_ANCHOR] / L->m;
    L->anchor_code = b.anchor_code;
    for (int p = 0; p < L->m; p++) {
        memcpy(L->y0 + (long)p * WDR_BASIS_SAMPLES, L->s[p].y, sizeof L->s[p].y);
        L->shift0[p] = L->shift[p] = wdr_cal_basis_shift(&b, &L->s[p]);
    }
    return 1;
}

/* What alternate changes in a learner, kept so a second table can be learnt from the same start. */
typedef struct learner_start {
    double *table, *dy, *dw, *shift;
    wdr_map_samples *s;
    double u[WDR_BASIS_SAMPLES];
} learner_start;

static int keep_start(const learner *L, learner_start *k)
{
    size_t tab = sizeof(double) * (size_t)L->points * L->n, md = sizeof(double) * (size_t)L->m * L->d;
    k->table = malloc(tab), k->dy = malloc(md), k->dw = malloc(md);
    k->shift = malloc(sizeof(double) * (size_t)L->m), k->s = malloc(sizeof *L->s * (size_t)L->m);
    if (!k->table || !k->dy || !k->dw || !k->shift || !k->s)
        return 0;
    memcpy(k->table, L->table, tab), memcpy(k->dy, L->dy, md), memcpy(k->dw, L->dw, md);
    memcpy(k->shift, L->shift, sizeof(double) * (size_t)L->m), memcpy(k->s, L->s, sizeof *L->s * (size_t)L->m);
    memcpy(k->u, L->u, sizeof k->u);
    return 1;
}

static void back_to_start(learner *L, const learner_start *k)
{
    size_t md = sizeof(double) * (size_t)L->m * L->d;
    memcpy(L->table, k->table, sizeof(double) * (size_t)L->points * L->n);
    memcpy(L->dy, k->dy, md), memcpy(L->dw, k->dw, md);
    memcpy(L->shift, k->shift, sizeof(double) * (size_t)L->m), memcpy(L->s, k->s, sizeof *L->s * (size_t)L->m);
    memcpy(L->u, k->u, sizeof k->u);
    free(L->w0), free(L->dw0);
    L->w0 = L->dw0 = NULL; /* alternate keeps the weights afresh */
}

static void free_start(learner_start *k)
{
    free(k->table), free(k->dy), free(k->dw), free(k->shift), free(k->s);
}

/* The twin: the table learnt with the anchor's shifts alone (no re-pick) from the start the
 * re-picked one had; learnt apart, that start was 1.8 s of the 1.9 s the twin cost a calibration.
 * WDR_OK, or an error that leaves *twin empty. */
static int learn_twin(learner *L, const learner_start *k, wdr_basis *twin)
{
    memset(twin, 0, sizeof *twin);
    twin->mean_coeffs[0] = 1;
    back_to_start(L, k);
    L->repick = 0;
    int rc = alternate(L) ? to_float_table(L, twin) : WDR_E_NUMERIC;
    if (rc)
        wdr_cal_basis_free(twin);
    return rc;
}

/* shifts: 0 none, 1 per-pixel code shifts from the anchor, 2 those re-picked between rounds;
 * minimax: the minimax reweighting; twin (shifts 2 only, else NULL): also the table with the
 * anchor's shifts alone, from the same start, *twin_rc saying whether it stood. */
static int learn_one(const wdr_cal_result *res, int n, int shifts, int minimax, wdr_basis *b, wdr_basis *twin,
                     int *twin_rc, char *err, int errlen)
{
    learner_start k = {0};
    learner L = {.res = res,
                 .n = n,
                 .points = (int)(WDR_CAL_MAX_SHARED_FLOATS / (unsigned)n),
                 .minimax = minimax,
                 .repick = shifts > 1};
    for (int k = 0; k < WDR_BASIS_SAMPLES; k++)
        L.u[k] = 1;
    long idx[SAMPLE_PIXELS];
    memset(b, 0, sizeof *b);
    b->mean_coeffs[0] = 1; /* function 0 is the mean map */
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
    if (!rc && shifts && !shift_samples(&L))
        rc = WDR_E_NOMEM;
    if (!rc && !code_range(&L)) {
        snprintf(err, (size_t)errlen, "shared basis: the pixels' codes span no range");
        rc = WDR_E_NUMERIC;
    }
    if (!rc && !dense_samples(&L, idx))
        rc = WDR_E_NOMEM;
    if (!rc && !start_basis(&L, idx))
        rc = WDR_E_NOMEM;
    if (!rc && twin && !keep_start(&L, &k))
        rc = WDR_E_NOMEM;
    if (!rc && !alternate(&L)) {
        snprintf(err, (size_t)errlen, "shared basis: the table fit did not stay finite");
        rc = WDR_E_NUMERIC;
    }
    if (!rc && (rc = to_float_table(&L, b)) == WDR_E_NUMERIC)
        snprintf(err, (size_t)errlen, "shared basis: degenerate (a basis function is zero everywhere)");
    if (rc == WDR_E_NOMEM)
        snprintf(err, (size_t)errlen, "shared basis: out of memory");
    if (twin)
        *twin_rc = rc ? rc : learn_twin(&L, &k, twin);
    free_start(&k);
    free(L.s), free(L.c), free(L.table), free(L.dy), free(L.dt), free(L.dw);
    free(L.dl), free(L.w0), free(L.dw0), free(L.shift), free(L.shift0), free(L.y0), free(L.dy0);
    if (rc)
        wdr_cal_basis_free(b);
    return rc;
}

/* The learner's judgement of a finished basis, as the table will be fitted (wdr_cal_basis_shift,
 * wdr_cal_basis_coeffs): the worst over the 64 log-spaced currents of the rms contrast residual
 * over the sample pixels (infinite when a fit fails). */
static double basis_worst(const wdr_cal_result *res, const wdr_basis *b, long phase)
{
    learner L = {.res = res};
    long idx[SAMPLE_PIXELS];
    int m = pick_pixels_from(&L, idx, phase);
    double e2[WDR_BASIS_SAMPLES] = {0}, worst = 0;
    for (int p = 0; p < m; p++) {
        wdr_map_samples s;
        double c[WDR_CAL_MAX_COEFFS];
        wdr_cal_map_samples(res, idx[p], &s);
        wdr_cal_basis_shift(b, &s);
        if (!wdr_cal_basis_coeffs(b, &s, c))
            return INFINITY;
        for (int k = 0; k < WDR_BASIS_SAMPLES; k++) {
            double v = 0;
            for (int q = 0; q < b->n; q++)
                v += c[q] * kernel_basis(b, s.y[k], q);
            e2[k] += (v - s.t[k]) * (v - s.t[k]) * s.w[k] * s.w[k];
        }
    }
    for (int k = 0; k < WDR_BASIS_SAMPLES; k++)
        worst = fmax(worst, e2[k]);
    return worst;
}

/* SHIFTED: three minimax tables, the best on the learner's judgement. Shifts re-picked as the
 * table is learnt gain where the bend sits (Tumblin-Rushmeier, sim-qvga seeds 1/2/3:
 * 1.102/0.894/0.956 -> 0.855/0.774/0.851 %) but lost on bench_target's chip (64x48 seed 11: 0.978
 * -> 1.059 %), where they fit the 512 pixels learnt on better and the others worse; so the
 * anchor's shifts stay a candidate, judged against the re-picked on pixels the learner never saw
 * (HOLDOUT_PHASE). Without shifts (all pixels shift 0): the operators whose maps do not bend lose
 * with shifts (Reinhard, seed 11: 1.32 % with, 0.6 % without), those that bend gain (TR 2.14 % ->
 * 0.98 %); judged on the learner's own pixels, as before, since the held-out pick chose shifts
 * wrongly there (Reinhard sim-qvga seed 3: 0.400 -> 0.990 %). */
int wdr_cal_basis_learn(const wdr_cal_result *res, int n, int shifted, wdr_basis *b, char *err, int errlen)
{
    if (!shifted)
        return learn_one(res, n, 0, 0, b, NULL, NULL, err, errlen);
    wdr_basis cand[3]; /* re-picked, the anchor's shifts, no shifts */
    int twin_rc = WDR_E_NUMERIC, rc = learn_one(res, n, 2, 1, &cand[0], &cand[1], &twin_rc, err, errlen);
    if (rc)
        return rc;
    int ok1 = !twin_rc, ok2 = !learn_one(res, n, 0, 1, &cand[2], NULL, NULL, err, errlen);
    int best = ok1 && basis_worst(res, &cand[1], HOLDOUT_PHASE) < basis_worst(res, &cand[0], HOLDOUT_PHASE) ? 1 : 0;
    if (ok2 && basis_worst(res, &cand[2], 0) < basis_worst(res, &cand[best], 0))
        best = 2;
    for (int i = 0; i < 3; i++)
        if (i != best && (i == 0 || (i == 1 ? ok1 : ok2)))
            wdr_cal_basis_free(&cand[i]);
    *b = cand[best];
    return WDR_OK; /* a candidate that failed leaves the others */
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

double wdr_cal_basis_value(const wdr_basis *b, const double *c, double y)
{
    double v = 0;
    for (int k = 0; k < b->n; k++)
        v += c[k] * kernel_basis(b, y, k);
    return v;
}

int wdr_cal_basis_coeffs(const wdr_basis *b, const wdr_map_samples *s, double *c)
{
    double a[WDR_BASIS_SAMPLES * WDR_CAL_MAX_COEFFS], t[WDR_BASIS_SAMPLES], rcond;
    for (int k = 0; k < WDR_BASIS_SAMPLES; k++) {
        t[k] = s->t[k];
        for (int q = 0; q < b->n; q++)
            a[k * b->n + q] = kernel_basis(b, s->y[k], q);
    }
    double w[WDR_BASIS_SAMPLES];
    for (int k = 0; k < WDR_BASIS_SAMPLES; k++)
        w[k] = s->w[k] * b->u[k];
    if (wdr_lsq_solve(a, t, w, WDR_BASIS_SAMPLES, b->n, c, &rcond))
        return 0;
    for (int q = 0; q < b->n; q++)
        if (!(fabs(c[q]) < 1e30))
            return 0;
    return 1;
}

static int clamp_shift(double d)
{
    return (int)fmin(fmax(d, -(double)SHIFT_MAX - 1), SHIFT_MAX);
}

static void move_samples(const wdr_basis *b, const wdr_map_samples *s, int shift, wdr_map_samples *out)
{
    *out = *s;
    for (int k = 0; k < WDR_BASIS_SAMPLES; k++)
        out->y[k] = fmin(s->y[k] + shift, b->raw_max);
}

/* Weighted squared residual of the pixel's fit at one shift (infinite when the fit fails). */
static double shift_cost(const wdr_basis *b, const wdr_map_samples *s)
{
    double c[WDR_CAL_MAX_COEFFS], e2 = 0;
    if (!wdr_cal_basis_coeffs(b, s, c))
        return INFINITY;
    for (int k = 0; k < WDR_BASIS_SAMPLES; k++) {
        double v = 0;
        for (int q = 0; q < b->n; q++)
            v += c[q] * kernel_basis(b, s->y[k], q);
        double e = (v - s->t[k]) * s->w[k] * b->u[k];
        e2 += e * e;
    }
    return e2;
}

int wdr_cal_basis_shift(const wdr_basis *b, wdr_map_samples *s)
{
    if (!b->shifted || !isfinite(s->y[SHIFT_ANCHOR]))
        return 0;
    int best = clamp_shift(round(b->anchor_code - s->y[SHIFT_ANCHOR]));
    if (b->table) { /* the learnt table: the shift that fits best near the anchor's */
        int mid = best, r = SHIFT_SEARCH;
        double cost = INFINITY;
        for (int d = clamp_shift(mid - r); d <= clamp_shift(mid + r); d++) {
            wdr_map_samples t;
            move_samples(b, s, d, &t);
            double e = shift_cost(b, &t);
            if (e < cost)
                cost = e, best = d;
        }
    }
    wdr_map_samples t;
    move_samples(b, s, best, &t);
    *s = t;
    return best;
}
