/* The calibration margin sized from the chip's frames (see cal_margin.h). */
#include "cal_margin.h"
#include "ramp.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Standard normal quantile past which one pixel of n lies, and a half sigma more: the largest of n
 * Gaussian pixels is rarely further (sqrt(2 ln n) + 1.5: 5.9 sigma on QVGA, 6.5 on VGA). */
static double tail_sigmas(long n)
{
    return sqrt(2 * log((double)(n > 2 ? n : 2))) + 1.5;
}

int wdr_cal_margin_measure(const float *dim, const float *bright, long np, double noise_codes,
                           const wdr_cal_margin_req *req, double margin_in_use_v, wdr_cal_margin *out)
{
    double *x = malloc(sizeof(double) * (size_t)(np > 0 ? np : 1));
    if (!x)
        return WDR_E_NOMEM;
    long n = 0;
    for (long i = 0; i < np; i++) { /* the dim level's hold minus the bright one's: the follower's offset cancels */
        double d = ((double)dim[i] - bright[i]) / req->codes_per_v;
        if (isfinite(d))
            x[n++] = d;
    }
    if (n < 16) {
        free(x);
        return WDR_E_INVAL;
    }
    double *sorted = malloc(sizeof(double) * (size_t)n);
    if (!sorted) {
        free(x);
        return WDR_E_NOMEM;
    }
    memcpy(sorted, x, sizeof(double) * (size_t)n);
    qsort(sorted, (size_t)n, sizeof(double), cmp_double);
    /* The median and the lower half only: pixels at the ramp's top are cut off above, and
     * defects (dead, stuck, saturated, hot: no response, or an early crossing) lie below. */
    double median = sorted[n / 2], spread = median - sorted[(long)(0.1587 * (double)n)];
    double latest = sorted[n - 1] - median;
    free(sorted);
    if (!(median > 0)) { /* no response between the levels: nothing to measure */
        free(x);
        return WDR_E_INVAL;
    }
    out->n_pixels = n;
    out->spread_v = spread;
    out->latest_v = latest > 0 ? latest : 0;
    out->guard_v = 2 * req->dac_lsb_v + 5 * noise_codes / req->codes_per_v + 0.05 * out->latest_v;
    /* A pixel at the ramp's top reads the margin in use less the median pixel's own (small)
     * need: anything within two guards of it may lie further up. */
    out->n_late = 0;
    for (long i = 0; i < n; i++)
        out->n_late += x[i] - median >= margin_in_use_v - 2 * out->guard_v;
    free(x);
    out->margin_v = out->latest_v + out->guard_v;
    if (out->n_late)
        out->margin_v =
            fmax(fmax(1.5 * margin_in_use_v, out->margin_v + out->guard_v), tail_sigmas(n) * spread + out->guard_v);
    return WDR_OK;
}

/* One round: the margin on the ramp, then the two levels. */
static int probe_round(const wdr_cal_source *src, const wdr_cal_margin_req *req, wdr_cal_margin_set_fn set, void *ctx,
                       double margin_v, wdr_cal_margin *out, char *err, int errlen)
{
    double done = 0, added = 0, amps[2] = {req->dim_a, req->bright_a};
    int rc = set(ctx, margin_v, &done, &added, err, errlen);
    if (rc)
        return rc;
    wdr_cal_levels lv;
    char why[256];
    if ((rc = wdr_cal_acquire(src, amps, 2, req->frames, 0, NULL, NULL, &lv, why, sizeof why))) {
        snprintf(err, (size_t)errlen, "margin probe: %s", why);
        return rc;
    }
    long np = (long)lv.width * lv.height;
    rc = wdr_cal_margin_measure(lv.frames, lv.frames + np, np, lv.noise[0], req, done, out);
    wdr_cal_levels_free(&lv);
    if (rc == WDR_E_INVAL)
        snprintf(err, (size_t)errlen,
                 "margin probe: the pixels hold the same level at %.3g A as at %.3g A: "
                 "no response to measure the crossing levels on",
                 req->dim_a, req->bright_a);
    out->added_s = added;
    out->margin_v = rc ? done : out->margin_v;
    return rc;
}

int wdr_cal_margin_size(const wdr_cal_source *src, const wdr_cal_margin_req *req, wdr_cal_margin_set_fn set, void *ctx,
                        wdr_cal_margin *out, char *err, int errlen)
{
    memset(out, 0, sizeof *out);
    out->dim_a = req->dim_a, out->bright_a = req->bright_a;
    double margin = WDR_CAL_MARGIN_START_V, in_use = 0, added = 0;
    for (int round = 1;; round++) {
        int rc = probe_round(src, req, set, ctx, margin, out, err, errlen);
        if (rc)
            return rc;
        out->rounds = round;
        in_use = margin, added = out->added_s;
        if (!out->n_late)
            break;
        if (round == WDR_CAL_MARGIN_ROUNDS) {
            snprintf(err, (size_t)errlen,
                     "calibration margin: after %d rounds %ld pixels still cross at the top of "
                     "the ramp (%.1f mV of margin, crossing-level spread %.1f mV sd)",
                     round, out->n_late, margin * 1e3, out->spread_v * 1e3);
            return WDR_E_INVAL;
        }
        margin = out->margin_v; /* larger: the chip's tail lies beyond the ramp's top */
    }
    double want = out->margin_v, done = in_use;
    if (fabs(want - in_use) >= 0.5 * req->dac_lsb_v) { /* the margin measured, up or down */
        int rc = set(ctx, want, &done, &added, err, errlen);
        if (rc)
            return rc;
    }
    out->margin_v = done, out->added_s = added;
    return WDR_OK;
}

/* Ticks of the LUT's last entry, and a tick in seconds. */
static int last_entry_s(const uint8_t *in, size_t len, double *t_last_s)
{
    wdr_lut_view v;
    int rc = wdr_lut_parse(in, len, &v);
    if (rc)
        return rc;
    uint32_t t;
    uint16_t c;
    wdr_lut_entry(&v, v.h.entry_count - 1, &t, &c);
    *t_last_s = (double)t * v.h.tick_ps * 1e-12;
    return WDR_OK;
}

int wdr_cal_lut_with_margin(const uint8_t *in, size_t in_len, double margin_v, uint8_t **out, size_t *out_len,
                            double *added_s, double *done_v, char *err, int errlen)
{
    double t_last_s = 0;
    *out = NULL;
    int rc = last_entry_s(in, in_len, &t_last_s);
    if (rc) {
        snprintf(err, (size_t)errlen, "LUT does not parse: %s", wdr_strerror(rc));
        return rc;
    }
    double frac = t_last_s > 0 ? WDR_CAL_MARGIN_MAX_S / t_last_s : 1e9; /* the time the margin takes, up to 1 s */
    rc = wdr_cal_lut_extend(in, in_len, margin_v, frac, out, out_len, added_s, done_v, err, errlen);
    if (rc)
        return rc;
    wdr_lut_view v;
    wdr_lut_parse(in, in_len, &v);
    double lsb = (v.h.dac_hi_v - v.h.dac_lo_v) / ((1u << v.h.dac_bits) - 1u);
    if (*done_v < margin_v - 0.5 * lsb) {
        snprintf(err, (size_t)errlen, "the chip needs %.1f mV of calibration margin, the ramp can add %.1f mV: %s",
                 margin_v * 1e3, *done_v * 1e3,
                 *added_s >= 0.99 * WDR_CAL_MARGIN_MAX_S
                     ? "more would add over 1 s of integration at the ramp's final slope (WDR_CAL_MARGIN_MAX_S)"
                     : "the DAC's top code (or the 32-bit tick count) stops it");
        free(*out);
        *out = NULL;
        return WDR_E_INVAL;
    }
    return WDR_OK;
}

/* The simulator as the chip the margin is set on (cal_margin.h). */
int wdr_cal_sim_set_margin(void *ctx, double margin_v, double *done_v, double *added_s, char *err, int errlen)
{
    wdr_cal_sim_margin *m = ctx;
    uint8_t *base, *ext;
    size_t len, ext_len;
    wdr_lut_view lut;
    int rc = wdr_ramp_board_lut(m->board, m->op_name, &base, &len, NULL, err, errlen);
    if (rc)
        return rc;
    rc = wdr_cal_lut_with_margin(base, len, margin_v, &ext, &ext_len, added_s, done_v, err, errlen);
    free(base);
    if (rc)
        return rc;
    if ((rc = wdr_lut_parse(ext, ext_len, &lut)) || (rc = wdr_sim_set_lut(m->sim, &lut))) {
        snprintf(err, (size_t)errlen, "simulator refused the LUT with a %.1f mV margin: %s", *done_v * 1e3,
                 wdr_strerror(rc));
        free(ext);
        return rc;
    }
    free(m->lut); /* the chip now reads the new bytes */
    m->lut = ext;
    return WDR_OK;
}
