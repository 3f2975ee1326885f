#include "sim_rng.h"
#include <math.h>
#include <pthread.h>

float sim_norm_table[(1 << SIM_NORM_TABLE_BITS) + 1];
static pthread_once_t table_once = PTHREAD_ONCE_INIT;

/* Acklam's coefficients for the inverse normal CDF. */
static const double qa[] = {-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
                            1.383577518672690e+02, -3.066479806614716e+01, 2.506628277459239e+00};
static const double qb[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                            6.680131188771972e+01, -1.328068155288572e+01};
static const double qc[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                            -2.549732539343734e+00, 4.374664141464968e+00, 2.938163982698783e+00};
static const double qd[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                            3.754408661907416e+00};

static double tail_quantile(double p)
{
    double q = sqrt(-2 * log(p));
    return (((((qc[0] * q + qc[1]) * q + qc[2]) * q + qc[3]) * q + qc[4]) * q + qc[5]) /
           ((((qd[0] * q + qd[1]) * q + qd[2]) * q + qd[3]) * q + 1);
}

double sim_norm_quantile(double u)
{
    const double p_low = 0.02425;
    if (u <= 0)
        u = 1e-300;
    if (u >= 1)
        u = 1 - 1e-16;
    if (u < p_low)
        return tail_quantile(u);
    if (u > 1 - p_low)
        return -tail_quantile(1 - u);
    double q = u - 0.5, r = q * q;
    return (((((qa[0] * r + qa[1]) * r + qa[2]) * r + qa[3]) * r + qa[4]) * r + qa[5]) * q /
           (((((qb[0] * r + qb[1]) * r + qb[2]) * r + qb[3]) * r + qb[4]) * r + 1);
}

static void fill_table(void)
{
    const int n = 1 << SIM_NORM_TABLE_BITS;
    for (int i = 1; i < n; i++)
        sim_norm_table[i] = (float)sim_norm_quantile((double)i / n);
    /* the end cells are never interpolated (sim_normal uses the exact tail there) */
    sim_norm_table[0] = sim_norm_table[1];
    sim_norm_table[n] = sim_norm_table[n - 1];
}

void sim_rng_init(void) { pthread_once(&table_once, fill_table); }
