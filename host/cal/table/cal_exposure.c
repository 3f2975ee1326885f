/* The LUT's exposure table anchored at the calibration's levels (see cal_exposure.h). */
#include "cal_exposure.h"
#include "ramp.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The table at a code, as the firmware reads it (fw_expo.c: linear between bins, flat past the last). */
static double table_at(const wdr_lut_exposure *ex, double code)
{
    double u = fmax(code, 0) / (double)(1u << ex->code_shift);
    uint32_t bin = (uint32_t)u;
    if (bin >= ex->bins - 1u)
        return ex->ln_q8[ex->bins - 1u];
    return ex->ln_q8[bin] + (u - bin) * (ex->ln_q8[bin + 1u] - ex->ln_q8[bin]);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* 256 ln(ref / I_key): the block holds ln(I / I_key), the key it was built for is not stored, and
 * the design at a reference key (the board's i_center) differs from it by that constant. The
 * median over the bins both leave unclamped. */
static int key_offset_q8(const wdr_board *b, const wdr_lut_view *lut, const wdr_lut_exposure *ex, double *off)
{
    wdr_lut_exposure *design = malloc(sizeof *design);
    double *d = malloc(sizeof *d * ex->bins);
    int rc = design && d ? wdr_ramp_lut_exposure_table(b, lut, b->i_center_a, design) : WDR_E_NOMEM;
    int m = 0;
    for (uint32_t k = 0; !rc && k < ex->bins && design->bins == ex->bins; k++)
        if (abs(ex->ln_q8[k]) < WDR_LUT_EXPO_MAX_LN_Q8 && abs(design->ln_q8[k]) < WDR_LUT_EXPO_MAX_LN_Q8)
            d[m++] = (double)ex->ln_q8[k] - design->ln_q8[k];
    if (!rc && m == 0)
        rc = WDR_E_INVAL; /* another board's block: nothing to compare */
    if (!rc) {
        qsort(d, (size_t)m, sizeof *d, cmp_double);
        *off = d[m / 2];
    }
    free(design);
    free(d);
    return rc;
}

/* The table's sloped part: bins after the last at its highest value (the ceiling) and before the
 * first at its lowest (the floor), as the firmware finds them. */
static void sloped_part(const wdr_lut_exposure *ex, uint32_t *first, uint32_t *last)
{
    uint32_t first_min, last_max;
    wdr_lut_exposure_flat_ends(ex, &first_min, &last_max);
    *first = last_max + 1u;
    *last = first_min > 0 ? first_min - 1u : 0;
}

/* The move at a code: linear between anchors (sorted by code), held past the first and the last. */
static double move_at(const double *code, const double *move, int n, double c)
{
    if (c <= code[0])
        return move[0];
    for (int k = 1; k < n; k++)
        if (c <= code[k])
            return move[k - 1] + (move[k] - move[k - 1]) * (c - code[k - 1]) / (code[k] - code[k - 1]);
    return move[n - 1];
}

/* Levels whose median code lies on the sloped part: their code and the table's move there (1/256).
 * Every such level, the ends too, where one DAC step holds 0.1-0.24 ln: the chip's mismatch
 * dithers where along a step each pixel crosses, so the median code follows the light smoothly
 * there as well. Tried: no anchor where a step holds over 0.05 ln (0.1 ln), and sim-qvga's HDR
 * wedge settled -2.03 % (-1.50 %) on its worst seed, -0.88 % with them all. */
static int anchors(const wdr_lut_exposure *ex, const wdr_board *b, const wdr_nominal *nom, double scale,
                   const double *amps, int n, double off, double *code, double *move, double *at)
{
    uint32_t first, last;
    sloped_part(ex, &first, &last);
    double lo = (double)(first << ex->code_shift), hi = (double)(last << ex->code_shift);
    int m = 0;
    for (int k = 0; k < n; k++) {
        double c = amps[k] > 0 ? wdr_nominal_eval(nom, amps[k]) * scale : NAN;
        if (!(c >= lo && c <= hi))
            continue; /* the dark reference, or a level past the floor or the ceiling */
        code[m] = c, at[m] = amps[k];
        move[m++] = 256 * log(amps[k] / b->i_center_a) + off - table_at(ex, c);
    }
    for (int i = 1; i < m; i++) /* insertion sort by code: levels rise in current, codes fall */
        for (int j = i; j > 0 && code[j] < code[j - 1]; j--) {
            double t;
            t = code[j], code[j] = code[j - 1], code[j - 1] = t;
            t = move[j], move[j] = move[j - 1], move[j - 1] = t;
            t = at[j], at[j] = at[j - 1], at[j - 1] = t;
        }
    return m;
}

/* Every bin moved (the flat ends by the end anchors' moves, so they stay flat and the firmware
 * finds the floor and the ceiling in the same bins), never rising with the code. */
static void move_table(wdr_lut_exposure *ex, const double *code, const double *move, int m)
{
    for (uint32_t k = 0; k < ex->bins; k++) {
        double q = ex->ln_q8[k] + move_at(code, move, m, (double)(k << ex->code_shift));
        q = fmax(-WDR_LUT_EXPO_MAX_LN_Q8, fmin(WDR_LUT_EXPO_MAX_LN_Q8, q));
        ex->ln_q8[k] = (int16_t)lround(q);
        if (k > 0 && ex->ln_q8[k] > ex->ln_q8[k - 1])
            ex->ln_q8[k] = ex->ln_q8[k - 1];
    }
}

int wdr_cal_exposure_anchor(uint8_t *bytes, size_t len, const wdr_board *b, const wdr_nominal *nominal,
                            double code_scale, const double *amps, int n, wdr_cal_exposure_anchors *out)
{
    wdr_lut_view lut;
    memset(out, 0, sizeof *out);
    int rc = wdr_lut_parse(bytes, len, &lut);
    size_t end = rc ? 0 : wdr_lut_size(lut.h.entry_count);
    if (rc || len <= end || n <= 0)
        return rc;
    wdr_lut_exposure *ex = malloc(sizeof *ex);
    double *buf = malloc(sizeof *buf * 3 * (size_t)n), off = 0;
    if (!ex || !buf)
        rc = WDR_E_NOMEM;
    if (!rc)
        rc = wdr_lut_exposure_parse(bytes + end, len - end, ex);
    if (!rc)
        rc = key_offset_q8(b, &lut, ex, &off);
    int m = rc ? 0 : anchors(ex, b, nominal, code_scale, amps, n, off, buf, buf + n, buf + 2 * n);
    if (m > 0) {
        move_table(ex, buf, buf + n, m);
        wdr_lut_exposure_encode(ex, bytes + end);
        out->n = m;
        for (int k = 0; k < m; k++)
            if (fabs(buf[n + k]) / 256 > out->worst_ln)
                out->worst_ln = fabs(buf[n + k]) / 256, out->worst_at_a = buf[2 * n + k];
    }
    free(ex);
    free(buf);
    return rc;
}
