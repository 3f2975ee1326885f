/* A calibration margin for a DAC ramp. A ramp built for [i_min, i_max] ends where the nominal
 * pixel's dimmest current crosses. A pixel whose reset level or M2 threshold sits a few mV above
 * nominal then never crosses at low light: it holds the ramp's last code and tells nothing about
 * its current (with the default 0.35 um mismatch about half the pixels below 5e-14 A under
 * Reinhard). Continuing the ramp at its final slope for a few sigma of that mismatch lets every
 * pixel, and the dark frame, cross. */
#include "cal_engine.h"
#include "wdr_err.h"
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Final slope in codes per tick, from the last span of the ramp that rose by >= 8 codes. */
static double final_slope(const wdr_lut_view *lut, uint32_t *t_last, uint16_t *c_last)
{
    uint32_t n = lut->h.entry_count, t0 = 0;
    uint16_t c0 = 0;
    wdr_lut_entry(lut, n - 1, t_last, c_last);
    for (uint32_t i = n - 1; i-- > 0;) {
        wdr_lut_entry(lut, i, &t0, &c0);
        if (*c_last - c0 >= 8 || i == 0)
            break;
    }
    return *t_last > t0 && *c_last > c0 ? (double)(*c_last - c0) / (double)(*t_last - t0) : 0;
}

/* Codes the extension may add: the margin, capped by the DAC's top code, the time budget and the
 * 32-bit tick count. The last entry lands at t_last + ceil(extra step) and the integration ends
 * ceil(step) + 1 ticks later; that end must still be a u32 (a ramp ending near 2^32 ticks once
 * wrapped it to a few ticks, below its own last entry, and the result did not parse). */
static uint32_t extension_codes(const wdr_lut_view *lut, uint16_t c_last, uint32_t t_last, double step, double margin_v,
                                double max_time_frac)
{
    uint32_t max_code = (1u << lut->h.dac_bits) - 1u;
    double lsb = (lut->h.dac_hi_v - lut->h.dac_lo_v) / max_code;
    double want = ceil(margin_v / lsb - 1e-6), by_time = floor(max_time_frac * t_last / step); /* f32 volts */
    double room = (double)UINT32_MAX - t_last - ceil(step) - 2; /* ticks left for the extension's entries */
    double by_ticks = room > 0 ? floor(room / step) : 0;
    double extra = fmin(fmin(fmin(want, by_time), by_ticks), (double)(max_code - c_last));
    extra = fmin(extra, (double)(WDR_LUT_MAX_ENTRIES - lut->h.entry_count));
    return extra > 0 ? (uint32_t)extra : 0;
}

/* Entries n.. of the extension, one code at a time at the final slope; where the ramp ends
 * steeper than one code per tick, several codes fall on one tick, and only the highest is kept
 * there, so times rise strictly as the format requires. Returns the new entry count. */
static uint32_t extend_entries(uint32_t *t, uint16_t *c, uint32_t n, uint32_t t_last, uint16_t c_last, double step,
                               uint32_t extra)
{
    uint32_t m = n;
    for (uint32_t k = 1; k <= extra; k++) {
        uint32_t tk = t_last + (uint32_t)ceil(k * step);
        if (tk == t[m - 1]) /* same tick as the entry before (never one of the original's) */
            m--;
        t[m] = tk;
        c[m] = (uint16_t)(c_last + k);
        m++;
    }
    return m;
}

int wdr_cal_lut_extend(const uint8_t *in, size_t in_len, double margin_v, double max_time_frac, uint8_t **out,
                       size_t *out_len, double *added_s, double *margin_done_v, char *err, int errlen)
{
    wdr_lut_view lut;
    *out = NULL;
    int rc = wdr_lut_parse(in, in_len, &lut);
    if (rc) {
        snprintf(err, (size_t)errlen, "LUT does not parse: %s", wdr_strerror(rc));
        return rc;
    }
    uint32_t t_last, n = lut.h.entry_count;
    uint16_t c_last;
    double slope = final_slope(&lut, &t_last, &c_last);
    double step = slope > 0 ? 1 / slope : 0; /* ticks per code */
    uint32_t extra =
        step > 0 && margin_v > 0 ? extension_codes(&lut, c_last, t_last, step, margin_v, max_time_frac) : 0;
    if (extra == 0) {
        snprintf(err, (size_t)errlen,
                 "cannot extend the ramp by %.1f mV: final slope %.3g codes/tick, last code %u, "
                 "time limit %.0f %% of %u ticks (and 2^32 ticks in all)",
                 margin_v * 1e3, slope, c_last, max_time_frac * 100, t_last);
        return WDR_E_INVAL;
    }
    *margin_done_v = extra * (lut.h.dac_hi_v - lut.h.dac_lo_v) / ((1u << lut.h.dac_bits) - 1u);
    uint32_t *t = malloc(sizeof(uint32_t) * (n + extra));
    uint16_t *c = malloc(sizeof(uint16_t) * (n + extra));
    /* LUT 1.1: an exposure block travels with the ramp (the margin only adds codes past the floor) */
    size_t expo = in_len > wdr_lut_size(n) ? in_len - wdr_lut_size(n) : 0; /* its own length (bins) */
    *out_len = wdr_lut_size(n + extra) + expo;
    *out = malloc(*out_len);
    if (!t || !c || !*out) {
        free(t), free(c), free(*out);
        *out = NULL;
        return WDR_E_NOMEM;
    }
    for (uint32_t i = 0; i < n; i++)
        wdr_lut_entry(&lut, i, &t[i], &c[i]);
    uint32_t m = extend_entries(t, c, n, t_last, c_last, step, extra);
    wdr_lut_header h = lut.h;
    h.entry_count = m;
    *out_len = wdr_lut_size(m) + expo; /* m <= n + extra: steep ends keep one entry per tick */
    uint32_t t_end = t[m - 1] + (uint32_t)ceil(step) + 1;
    h.t_integration_ticks = t_end > lut.h.t_integration_ticks ? t_end : lut.h.t_integration_ticks;
    wdr_lut_encode(&h, t, c, *out);
    if (expo) /* right after the entries actually written */
        memcpy(*out + wdr_lut_size(m), in + wdr_lut_size(n), expo);
    *added_s = (double)(h.t_integration_ticks - lut.h.t_integration_ticks) * lut.h.tick_ps * 1e-12;
    free(t);
    free(c);
    return WDR_OK;
}
