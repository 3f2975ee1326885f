/* The LUT's exposure table anchored at the calibration's levels (see cal_exposure.h). */
#include "cal_exposure.h"
#include "correct.h"
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
    /* up to the floor's code, which the firmware censors from (expo_limits): a level between it and
     * the flat run is read by the line past the floor, not the table. Up to the flat run, sim-qvga
     * seed 4's 4.64e-13 A level at code 3101.6 moved the table 0.03 ln, held to the floor and past
     * it: Schlick's HDR wedge settled +3.07 % (-0.78 % now) */
    double lo = (double)(first << ex->code_shift),
           hi = fmin((double)(last << ex->code_shift), WDR_LUT_EXPO_FLOOR_CODE(last + 1u, ex->code_shift) - 0.5);
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

/* The line past the floor that fw_expo.c's dark_tail_from_codes reads: through bin b0 (the floor's
 * code's bin, left where the sloped part's anchors put it) and bin b1 (the first of the floor's
 * flat run), current linear in code. It is turned about b0 to the calibration's levels past the
 * floor, least squares in code over (current, code) pairs (ln in the table's units, code): ln[b1]
 * and the flat run after it get the value of the line that fits. The tail's span moves about
 * 0.7 ln per code of that line's end (sim-qvga Schlick), and the design's line is the board's
 * nominal pixel's: at 1e-13 A the chips' median codes of seeds 3, 5 and 6 lay 0.75 code apart,
 * and the dark scene's key settled at +3.81 / +0.62 / +5.04 %. False where no level lies past the
 * floor or the fit would not stay below bin b1 - 1's value. */
static bool anchor_dark_line(wdr_lut_exposure *ex, const double *ln_at, const double *code, int n, double *moved)
{
    uint32_t b1, last_max;
    wdr_lut_exposure_flat_ends(ex, &b1, &last_max);
    double floor_code = WDR_LUT_EXPO_FLOOR_CODE(b1, ex->code_shift) - 0.5;
    uint32_t b0 = floor_code > 0 ? (uint32_t)floor_code >> ex->code_shift : 0;
    if (!(ex->flags & WDR_LUT_EXPO_LINEAR_DARK) || b1 <= b0 || b1 >= ex->bins)
        return false;
    double c0 = (double)(b0 << ex->code_shift), codes = (double)((b1 - b0) << ex->code_shift);
    double l0 = ex->ln_q8[b0] / 256.0, drop = 1 - exp(ex->ln_q8[b1] / 256.0 - l0), saa = 0, sad = 0;
    for (int k = 0; k < n; k++) {
        if (!(code[k] > floor_code))
            continue;                                /* not past the floor: the sloped part's */
        double a = (1 - exp(ln_at[k] - l0)) * codes; /* code - c0 = a / drop on the line */
        saa += a * a, sad += a * (code[k] - c0);
    }
    double u = saa > 0 ? sad / saa : 0; /* 1 / drop */
    if (!(u > 1) || !(drop > 0))
        return false;
    int16_t v = (int16_t)lround(fmax(256 * (l0 + log1p(-1 / u)), -WDR_LUT_EXPO_MAX_LN_Q8));
    if (v >= ex->ln_q8[b1 - 1u])
        return false;
    *moved = codes * (u - 1 / drop); /* the line's end at no light, codes */
    for (uint32_t k = b1; k < ex->bins; k++)
        ex->ln_q8[k] = v;
    return true;
}

int wdr_cal_mean_corrected_code(const uint8_t *table, size_t len, const float *frame, double *mean)
{
    wdr_cal_view v;
    int rc = wdr_cal_parse(table, len, &v);
    float *row = rc ? NULL : malloc(sizeof *row * v.h.width);
    if (!rc && !row)
        rc = WDR_E_NOMEM;
    double sum = 0;
    for (int r = 0; !rc && r < v.h.height; r++) {
        rc = wdr_correct_row_f32(&v, r, frame + (size_t)r * v.h.width, row);
        for (int i = 0; !rc && i < v.h.width; i++)
            sum += row[i];
    }
    free(row);
    if (!rc)
        *mean = sum / ((double)v.h.width * v.h.height);
    return rc;
}

/* The levels' (ln in the table's units, code) pairs for anchor_dark_line: the codes given, else the
 * nominal's (as anchors()). ln_at and code have room for n. */
static bool dark_line(wdr_lut_exposure *ex, const wdr_board *b, const wdr_nominal *nom, double scale,
                      const double *amps, int n, double off, const double *level_codes, double *ln_at, double *code,
                      double *moved)
{
    int m = 0;
    for (int k = 0; k < n; k++) {
        if (!(amps[k] > 0))
            continue;
        ln_at[m] = log(amps[k] / b->i_center_a) + off / 256;
        code[m++] = level_codes ? level_codes[k] : wdr_nominal_eval(nom, amps[k]) * scale;
    }
    return anchor_dark_line(ex, ln_at, code, m, moved);
}

int wdr_cal_exposure_anchor(uint8_t *bytes, size_t len, const wdr_board *b, const wdr_nominal *nominal,
                            double code_scale, const double *amps, int n, const double *level_codes,
                            wdr_cal_exposure_anchors *out)
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
        out->n = m;
        for (int k = 0; k < m; k++)
            if (fabs(buf[n + k]) / 256 > out->worst_ln)
                out->worst_ln = fabs(buf[n + k]) / 256, out->worst_at_a = buf[2 * n + k];
        out->dark_line =
            dark_line(ex, b, nominal, code_scale, amps, n, off, level_codes, buf, buf + n, &out->dark_moved_codes);
        wdr_lut_exposure_encode(ex, bytes + end);
    }
    free(ex);
    free(buf);
    return rc;
}
