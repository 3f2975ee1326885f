/* Bad pixels from the calibration frames, one kind each (saturated, stuck, dead, hot); array medians. */
#include "cal_stats.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Robust sigmas of the dark reference (the spread of reset levels): the band where a pixel with
 * no current reads (healthy dark outputs on a 320x240 chip: -4.6..+4.1 sigma), and the least a
 * hot pixel's dark output sits towards bright. */
#define DARK_BAND_SIGMAS 6.0
#define HOT_SIGMAS 8.0

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

/* What the array says a pixel's frames are judged against: the median swing from the dimmest
 * to the brightest level, and where the dark frame lies (its median and robust spread: the spread
 * of reset levels, since a dark pixel reads close to its own reset level). */
typedef struct array_ref {
    double swing;            /* median code at the dimmest level minus at the brightest */
    double dark, dark_sigma; /* median and 1.4826 MAD of the dark reference */
    double hot_limit;        /* how far towards bright a dark output may sit */
} array_ref;

/* The dark reference: the dark frame, or without one the dimmest level (close to it: the dark
 * end of the response is nearly flat). */
static const float *dark_reference(const wdr_cal_levels *lv)
{
    return lv->dark ? lv->dark : lv->frames;
}

static void array_reference(const wdr_cal_levels *lv, const wdr_cal_config *cfg, float *scratch, array_ref *a)
{
    long np = (long)lv->width * lv->height;
    double first = wdr_cal_median_of(lv->frames, np, scratch);
    double last = wdr_cal_median_of(lv->frames + (long)(lv->n - 1) * np, np, scratch);
    a->swing = first - last;
    a->dark = wdr_cal_median_of(dark_reference(lv), np, scratch);
    a->dark_sigma = mad_sigma(dark_reference(lv), np, a->dark, scratch);
    a->hot_limit = fmax(HOT_SIGMAS * a->dark_sigma, cfg->hot_frac * fabs(a->dark - first));
}

/* One kind per pixel, by what each defect does to the frames (sim/SPEC.md, "Defects"), in this
 * order of precedence:
 *   saturated  the output sits at an ADC rail at some level: the code says nothing else;
 *   stuck      the output does not follow light and sits away from where dark pixels read: the
 *              hold node is held at a fixed voltage;
 *   dead       the output does not follow light and sits where dark pixels read (no current:
 *              the pixel holds its own reset level), or follows far less than the array's;
 *   hot        the dark output sits far towards bright (a large dark current) while the pixel
 *              still follows light (checked before the weak response of a dead pixel: a hot
 *              pixel's dim levels are flat at its dark current, so its swing is short too).
 * A stuck node held within the dark band gives the frames of a dead pixel and is called dead:
 * frames cannot tell them apart. */
static int pixel_kind(const wdr_cal_levels *lv, const wdr_cal_config *cfg, const array_ref *a, long i)
{
    long np = (long)lv->width * lv->height;
    double lo = INFINITY, hi = -INFINITY, sum = 0;
    int at_rail = 0;
    for (int k = 0; k < lv->n; k++) {
        double y = lv->frames[(long)k * np + i];
        if (!isfinite(y))
            return WDR_PIX_DEAD; /* no reading at all */
        lo = fmin(lo, y), hi = fmax(hi, y), sum += y;
        at_rail |= y <= 0.5 || y >= cfg->raw_max - 0.5;
    }
    if (at_rail)
        return WDR_PIX_SATURATED;
    double dark = dark_reference(lv)[i];
    if (hi - lo <= cfg->stuck_frac * a->swing)
        return fabs(sum / lv->n - a->dark) <= DARK_BAND_SIGMAS * a->dark_sigma ? WDR_PIX_DEAD : WDR_PIX_STUCK;
    if (lv->dark && (!isfinite(dark) || a->dark - dark > a->hot_limit))
        return WDR_PIX_HOT;
    double swing = lv->frames[i] - lv->frames[(long)(lv->n - 1) * np + i];
    return swing >= cfg->dead_frac * a->swing ? 0 : WDR_PIX_DEAD;
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
    for (int k = 0; k < lv->n; k++) {
        double m = wdr_cal_median_of(lv->frames + (long)k * np, np, scratch);
        *saturated_levels += m <= 0.5 || m >= cfg->raw_max - 0.5;
    }
    array_ref a;
    array_reference(lv, cfg, scratch, &a);
    for (long i = 0; i < np; i++)
        flags[i] = (uint8_t)pixel_kind(lv, cfg, &a, i);
    free(scratch);
}

const char *wdr_cal_flag_name(int bit)
{
    static const char *const names[WDR_CAL_FLAG_KINDS] = {"dead", "stuck", "hot", "saturated", "unfit"};
    return bit >= 0 && bit < WDR_CAL_FLAG_KINDS ? names[bit] : "?";
}

const char *wdr_cal_flag_counts_text(const long *n_flag, char *buf, size_t cap)
{
    size_t n = 0;
    buf[0] = 0;
    for (int b = 0; b < WDR_CAL_FLAG_KINDS && n < cap; b++)
        n += (size_t)snprintf(buf + n, cap - n, "%s%s %ld", b ? ", " : "", wdr_cal_flag_name(b), n_flag[b]);
    return buf;
}
