/* Bad pixels from the calibration frames: dead, stuck, hot, saturated; array medians. */
#include "cal_stats.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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
double wdr_cal_median_of(const float *v, long n, float *scratch)
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
    return 1.4826 * wdr_cal_median_of(dev, n, scratch);
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
    double med_dark = wdr_cal_median_of(lv->dark, np, scratch);
    double sig = mad_sigma(lv->dark, np, med_dark, scratch);
    double med_low = wdr_cal_median_of(lv->frames, np, scratch);
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
    double first = wdr_cal_median_of(lv->frames, np, scratch);
    double last = wdr_cal_median_of(lv->frames + (long)(lv->n - 1) * np, np, scratch);
    for (int k = 0; k < lv->n; k++) {
        double m = wdr_cal_median_of(lv->frames + (long)k * np, np, scratch);
        *saturated_levels += m <= 0.5 || m >= cfg->raw_max - 0.5;
    }
    flag_range(lv, cfg, first - last, flags);
    if (lv->dark)
        flag_hot(lv, cfg, scratch, flags);
    free(scratch);
}
