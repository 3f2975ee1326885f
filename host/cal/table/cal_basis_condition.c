/* The same span of basis functions, better conditioned for the COMPACT form's int16 coefficients
 * (see wdr_cal_basis_conditioned in cal_basis.h). */
#include "cal_basis.h"
#include "wdr_err.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define NMAX WDR_CAL_MAX_COEFFS
#define SAMPLE_PIXELS 512 /* pixels whose coefficients are decorrelated (evenly spread, good ones) */

/* Cyclic Jacobi: the symmetric n x n matrix a diagonalised in place, its eigenvectors the columns
 * of v. */
static void jacobi_eigen(double *a, double *v, int n)
{
    for (int i = 0; i < n * n; i++)
        v[i] = i % (n + 1) == 0;
    for (int sweep = 0; sweep < 50; sweep++) {
        double off = 0, diag = 0;
        for (int p = 0; p < n; p++) {
            diag += a[p * n + p] * a[p * n + p];
            for (int q = p + 1; q < n; q++)
                off += a[p * n + q] * a[p * n + q];
        }
        if (!(off > 1e-28 * diag))
            return;
        for (int p = 0; p < n; p++)
            for (int q = p + 1; q < n; q++) {
                double th = 0.5 * atan2(2 * a[p * n + q], a[q * n + q] - a[p * n + p]), c = cos(th), s = sin(th);
                for (int k = 0; k < n; k++) { /* columns p and q */
                    double x = a[k * n + p], y = a[k * n + q];
                    a[k * n + p] = c * x - s * y, a[k * n + q] = s * x + c * y;
                }
                for (int k = 0; k < n; k++) { /* rows p and q */
                    double x = a[p * n + k], y = a[q * n + k];
                    a[p * n + k] = c * x - s * y, a[q * n + k] = s * x + c * y;
                }
                for (int k = 0; k < n; k++) {
                    double x = v[k * n + p], y = v[k * n + q];
                    v[k * n + p] = c * x - s * y, v[k * n + q] = s * x + c * y;
                }
            }
    }
}

/* Upper factor r of the n x n symmetric g = r^T r; 0 when g is not positive definite. */
static int cholesky_upper(const double *g, double *r, int n)
{
    memset(r, 0, sizeof(double) * (size_t)n * n);
    for (int j = 0; j < n; j++) {
        double d = g[j * n + j];
        for (int k = 0; k < j; k++)
            d -= r[k * n + j] * r[k * n + j];
        if (!(d > 0))
            return 0;
        r[j * n + j] = sqrt(d);
        for (int i = j + 1; i < n; i++) {
            double e = g[j * n + i];
            for (int k = 0; k < j; k++)
                e -= r[k * n + j] * r[k * n + i];
            r[j * n + i] = e / r[j * n + j];
        }
    }
    return 1;
}

/* The sample pixels' coefficients over b (mean mu and covariance cov, n x n); 0 when fewer than
 * 2n pixels fit. */
static int coefficient_spread(const wdr_cal_result *res, const wdr_basis *b, double *mu, double *cov)
{
    const int n = b->n;
    long np = (long)res->width * res->height, good = 0, m = 0;
    for (long i = 0; i < np; i++)
        good += !res->flags[i];
    long stride = good / SAMPLE_PIXELS > 1 ? good / SAMPLE_PIXELS : 1;
    double s1[NMAX] = {0}, s2[NMAX * NMAX] = {0};
    for (long i = 0, g = 0; i < np; i++) {
        if (res->flags[i] || g++ % stride)
            continue;
        wdr_map_samples s;
        double c[NMAX];
        wdr_cal_map_samples(res, i, &s);
        wdr_cal_basis_shift(b, &s);
        if (!wdr_cal_basis_coeffs(b, &s, c))
            continue;
        m++;
        for (int k = 0; k < n; k++) {
            s1[k] += c[k];
            for (int q = 0; q < n; q++)
                s2[k * n + q] += c[k] * c[q];
        }
    }
    if (m < 2 * n)
        return 0;
    for (int k = 0; k < n; k++)
        mu[k] = s1[k] / (double)m;
    for (int k = 0; k < n; k++)
        for (int q = 0; q < n; q++)
            cov[k * n + q] = s2[k * n + q] / (double)m - mu[k] * mu[q];
    return 1;
}

/* a = r^-1 v (r upper triangular): the new functions are B a, the new coefficients a^-1 c. */
static void new_functions(const double *r, const double *v, double *a, int n)
{
    for (int col = 0; col < n; col++)
        for (int i = n - 1; i >= 0; i--) {
            double t = v[i * n + col];
            for (int k = i + 1; k < n; k++)
                t -= r[i * n + k] * a[k * n + col];
            a[i * n + col] = t / r[i * n + i];
        }
}

int wdr_cal_basis_conditioned(const wdr_cal_result *res, const wdr_basis *in, wdr_basis *out)
{
    const int n = in->n, K = in->points;
    double g[NMAX * NMAX] = {0}, cov[NMAX * NMAX], mu[NMAX], r[NMAX * NMAX], f[NMAX * NMAX], v[NMAX * NMAX],
                    a[NMAX * NMAX];
    *out = *in;
    out->table = NULL;
    if (n < 2 || n > (int)NMAX || !coefficient_spread(res, in, mu, cov))
        return WDR_E_NUMERIC;
    for (int j = 0; j < K; j++) /* the functions' Gram matrix over the table's points, in codes */
        for (int k = 0; k < n; k++)
            for (int q = 0; q < n; q++)
                g[k * n + q] += (double)in->table[(long)j * n + k] * in->table[(long)j * n + q];
    if (!cholesky_upper(g, r, n))
        return WDR_E_NUMERIC;
    for (int i = 0; i < n; i++) /* the spread in orthonormal coordinates: r cov r^T */
        for (int j = 0; j < n; j++) {
            double t = 0;
            for (int k = 0; k < n; k++)
                for (int q = 0; q < n; q++)
                    t += r[i * n + k] * cov[k * n + q] * r[j * n + q];
            f[i * n + j] = t;
        }
    jacobi_eigen(f, v, n);
    new_functions(r, v, a, n);
    out->table = malloc(sizeof(float) * (size_t)K * n);
    if (!out->table)
        return WDR_E_NOMEM;
    for (int j = 0; j < K; j++)
        for (int col = 0; col < n; col++) {
            double t = 0;
            for (int k = 0; k < n; k++)
                t += in->table[(long)j * n + k] * a[k * n + col];
            out->table[(long)j * n + col] = (float)t;
        }
    for (int col = 0; col < n; col++) { /* the mean map's coefficients: a^-1 mean = v^T r mean */
        double t = 0;
        for (int k = 0; k < n; k++)
            for (int q = 0; q < n; q++)
                t += v[k * n + col] * r[k * n + q] * in->mean_coeffs[q];
        out->mean_coeffs[col] = t;
    }
    if (wdr_cal_shared_check(out->table, (uint16_t)n, (uint32_t)K)) {
        free(out->table);
        out->table = NULL;
        return WDR_E_NUMERIC;
    }
    return WDR_OK;
}
