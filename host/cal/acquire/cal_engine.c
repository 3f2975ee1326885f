/* Calibration acquisition and the simulator frame source. */
#include "cal_engine.h"
#include "cal_margin.h"
#include "ramp.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int check_request(const wdr_cal_source *src, const double *amps, int n, int m_avg, char *err, int errlen)
{
    if (!src || !src->capture || src->width <= 0 || src->height <= 0 || n < 1 || n > WDR_CAL_MAX_LEVELS ||
        m_avg < 1) {
        snprintf(err, (size_t)errlen, "bad acquisition request: %d levels (1..%d), %d frames per level (>= 1)", n,
                 WDR_CAL_MAX_LEVELS, m_avg);
        return WDR_E_INVAL;
    }
    for (int k = 0; k < n; k++) {
        if (!isfinite(amps[k]) || amps[k] <= 0 || (k > 0 && !(amps[k] > amps[k - 1]))) {
            snprintf(err, (size_t)errlen, "calibration current %d = %g A must be positive and above the one before",
                     k, amps[k]);
            return WDR_E_INVAL;
        }
        if (k > 0 && amps[k] < amps[k - 1] * (1 + WDR_CAL_MIN_SEPARATION)) {
            snprintf(err, (size_t)errlen, "calibration currents %g A and %g A differ by %.2g %%: the fits cannot "
                     "separate them (at least %g %% apart)", amps[k - 1], amps[k], 100 * (amps[k] / amps[k - 1] - 1),
                     100 * WDR_CAL_MIN_SEPARATION);
            return WDR_E_INVAL;
        }
    }
    return WDR_OK;
}

/* Mean of m_avg frames into out, and one frame's temporal sd (RMS over the array of each pixel's
 * sample sd) into *noise when m_avg >= 2; acc holds 2 np values of scratch, one np. */
static int average_level(const wdr_cal_source *src, double amps, int m_avg, int *frame_no, double *acc, float *one,
                         float *out, double *noise, wdr_cal_progress_fn progress, void *pctx, int total)
{
    long np = (long)src->width * src->height;
    double *acc2 = acc + np;
    memset(acc, 0, sizeof(double) * 2 * (size_t)np);
    for (int f = 0; f < m_avg; f++) {
        int rc = src->capture(src->ctx, amps, *frame_no, one);
        if (rc)
            return rc;
        for (long i = 0; i < np; i++) {
            acc[i] += one[i];
            acc2[i] += (double)one[i] * one[i];
        }
        ++*frame_no;
        if (progress)
            progress(pctx, *frame_no, total, amps);
    }
    double var = 0;
    long used = 0;
    for (long i = 0; i < np; i++) {
        out[i] = (float)(acc[i] / m_avg);
        double v = m_avg > 1 ? (acc2[i] - acc[i] * acc[i] / m_avg) / (m_avg - 1) : 0;
        if (isfinite(v))
            var += v > 0 ? v : 0, used++;
    }
    *noise = m_avg > 1 && used ? sqrt(var / used) : 0;
    return WDR_OK;
}

int wdr_cal_acquire(const wdr_cal_source *src, const double *amps, int n, int m_avg, int with_dark,
                    wdr_cal_progress_fn progress, void *pctx, wdr_cal_levels *out, char *err, int errlen)
{
    memset(out, 0, sizeof *out);
    int rc = check_request(src, amps, n, m_avg, err, errlen);
    if (rc)
        return rc;
    long np = (long)src->width * src->height;
    out->width = src->width;
    out->height = src->height;
    out->n = n;
    out->m_avg = m_avg > 1 ? m_avg : 0; /* one frame measures no temporal noise */
    memcpy(out->amps, amps, sizeof(double) * (size_t)n);
    out->frames = malloc(sizeof(float) * (size_t)np * (size_t)n);
    out->dark = with_dark ? malloc(sizeof(float) * (size_t)np) : NULL;
    double *acc = malloc(sizeof(double) * 2 * (size_t)np);
    float *one = malloc(sizeof(float) * (size_t)np);
    if (!out->frames || (with_dark && !out->dark) || !acc || !one) {
        rc = WDR_E_NOMEM;
        snprintf(err, (size_t)errlen, "out of memory for %d levels of %ld pixels", n, np);
    }
    int frame_no = 0, total = (n + (with_dark ? 1 : 0)) * m_avg;
    if (!rc && with_dark && (rc = average_level(src, 0, m_avg, &frame_no, acc, one, out->dark, &out->dark_noise, progress, pctx, total)))
        snprintf(err, (size_t)errlen, "dark frame capture failed: %s", wdr_strerror(rc));
    for (int k = 0; !rc && k < n; k++)
        if ((rc = average_level(src, amps[k], m_avg, &frame_no, acc, one, out->frames + (long)k * np,
                                &out->noise[k], progress, pctx, total)))
            snprintf(err, (size_t)errlen, "capture at %g A (level %d) failed: %s", amps[k], k, wdr_strerror(rc));
    free(acc);
    free(one);
    if (rc)
        wdr_cal_levels_free(out);
    return rc;
}

void wdr_cal_levels_free(wdr_cal_levels *lv)
{
    free(lv->frames);
    free(lv->dark);
    lv->frames = lv->dark = NULL;
}

static int subset_index_ok(const wdr_cal_levels *all, const int *idx, int k)
{
    if (idx[k] == -1)
        return k == 0 && all->dark;
    return idx[k] >= 0 && idx[k] < all->n && (k == 0 || idx[k] > idx[k - 1]);
}

int wdr_cal_levels_subset(const wdr_cal_levels *all, const int *idx, int n, wdr_cal_levels *out)
{
    long np = (long)all->width * all->height;
    memset(out, 0, sizeof *out);
    if (n < 1 || n > WDR_CAL_MAX_LEVELS)
        return WDR_E_INVAL;
    for (int k = 0; k < n; k++)
        if (!subset_index_ok(all, idx, k))
            return WDR_E_INVAL;
    out->frames = malloc(sizeof(float) * (size_t)np * (size_t)n);
    if (!out->frames)
        return WDR_E_NOMEM;
    out->width = all->width;
    out->height = all->height;
    out->n = n;
    out->m_avg = all->m_avg;
    out->dark_noise = all->dark_noise;
    for (int k = 0; k < n; k++) {
        const float *src = idx[k] < 0 ? all->dark : all->frames + (long)idx[k] * np;
        out->amps[k] = idx[k] < 0 ? 0 : all->amps[idx[k]];
        out->noise[k] = idx[k] < 0 ? all->dark_noise : all->noise[idx[k]];
        memcpy(out->frames + (long)k * np, src, sizeof(float) * (size_t)np);
    }
    return WDR_OK;
}

/* ---- simulator source ---- */

int wdr_cal_sim_capture(void *ctx, double amps, int frame_no, float *frame)
{
    wdr_cal_simsrc *s = ctx;
    int rc = wdr_sim_set_uniform(s->sim, amps);
    if (rc)
        return rc;
    uint64_t seed = s->seed + (uint64_t)frame_no;
    if (!s->quantised)
        return wdr_sim_render_float(s->sim, seed, frame);
    const wdr_board *b = wdr_sim_board(s->sim);
    long np = (long)b->width * b->height;
    uint16_t *codes = malloc(sizeof(uint16_t) * (size_t)np);
    if (!codes)
        return WDR_E_NOMEM;
    rc = wdr_sim_render(s->sim, seed, codes);
    for (long i = 0; !rc && i < np; i++)
        frame[i] = codes[i];
    free(codes);
    return rc;
}

static int build_lut(const wdr_board *b, const char *op_name, double margin_v, uint8_t **bytes, size_t *len,
                     char *err, int errlen)
{
    int rc = wdr_ramp_board_lut(b, op_name, bytes, len, NULL, err, errlen);
    if (rc || margin_v <= 0)
        return rc;
    uint8_t *ext;
    size_t ext_len;
    double added, done;
    rc = wdr_cal_lut_extend(*bytes, *len, margin_v, WDR_CAL_MARGIN_MAX_TIME_FRAC, &ext, &ext_len, &added, &done, err,
                            errlen);
    free(*bytes);
    *bytes = rc ? NULL : ext;
    *len = ext_len;
    return rc;
}

int wdr_cal_sim_setup(const wdr_board *b, const char *op_name, uint64_t chip_seed, int adc_quant, double margin_v,
                      wdr_sim **sim, uint8_t **lut_bytes, char *err, int errlen)
{
    size_t len;
    wdr_lut_view lut;
    *sim = NULL;
    int rc = build_lut(b, op_name, margin_v, lut_bytes, &len, err, errlen);
    if (rc)
        return rc;
    if ((rc = wdr_lut_parse(*lut_bytes, len, &lut))) {
        snprintf(err, (size_t)errlen, "built LUT does not parse: %s", wdr_strerror(rc));
        return rc;
    }
    *sim = wdr_sim_create(b, chip_seed);
    if (!*sim) {
        snprintf(err, (size_t)errlen, "out of memory for a %dx%d simulated chip", b->width, b->height);
        return WDR_E_NOMEM;
    }
    static const int temporal[] = {WDR_FX_SHOT, WDR_FX_KTC, WDR_FX_READ};
    for (int fx = 0; fx < WDR_FX_COUNT; fx++)
        wdr_sim_set_effect(*sim, fx, WDR_FX_ON);
    for (int k = 0; k < 3; k++)
        wdr_sim_set_effect(*sim, temporal[k], WDR_FX_OFF);
    wdr_sim_set_effect(*sim, WDR_FX_ADC_QUANT, adc_quant ? WDR_FX_ON : WDR_FX_OFF);
    if ((rc = wdr_sim_set_lut(*sim, &lut)))
        snprintf(err, (size_t)errlen, "simulator refused the LUT: %s", wdr_strerror(rc));
    return rc;
}
