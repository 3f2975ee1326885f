/* What a COMPACT table's encoding loses (see wdr_cal_compact_departure in cal_basis.h). */
#include "cal_basis.h"
#include "correct.h"
#include "wdr_err.h"
#include <math.h>
#include <stdlib.h>

/* Codes per unit of ln x: the weights' floor, as the learner's (cal_basis.c). Where the response
 * is flatter a code is no contrast error the board can show (sim-qvga Reinhard's dimmest samples
 * resolve 0.01 code per ln). */
#define MIN_LOG_SLOPE 1.0
#define SAMPLE_ROWS 8 /* rows evenly spread over the array: every good pixel of each is judged */

/* Row r's good pixels' float maps at the 64 currents (ref, NAN where none) and raw codes (raw). */
static void row_reference(const wdr_cal_result *res, const wdr_basis *basis, int r, double *ref, float *raw, double *w)
{
    const int width = res->width;
    for (int c = 0; c < width; c++) {
        long i = (long)r * width + c;
        wdr_map_samples s, moved;
        double coef[WDR_CAL_MAX_COEFFS];
        wdr_cal_map_samples(res, i, &s);
        moved = s;
        wdr_cal_basis_shift(basis, &moved); /* SHIFTED: the float map reads the moved codes */
        int ok = !res->flags[i] && wdr_cal_basis_coeffs(basis, &moved, coef);
        for (int k = 0; k < WDR_BASIS_SAMPLES; k++) {
            long at = (long)k * width + c;
            raw[at] = isfinite(s.y[k]) ? (float)s.y[k] : 0.0f;
            ref[at] = ok && isfinite(s.y[k]) ? wdr_cal_basis_value(basis, coef, moved.y[k]) : NAN;
            w[at] = fmin(s.w[k], 1 / MIN_LOG_SLOPE);
        }
    }
}

double wdr_cal_compact_departure(const wdr_cal_result *res, const wdr_basis *basis, const uint8_t *table, size_t len)
{
    wdr_cal_view v;
    const int width = res->width;
    if (wdr_cal_parse(table, len, &v) != WDR_OK || v.h.width != width)
        return INFINITY;
    const size_t cells = (size_t)WDR_BASIS_SAMPLES * width;
    double *ref = malloc(sizeof *ref * cells), *w = malloc(sizeof *w * cells), e2[WDR_BASIS_SAMPLES] = {0}, worst = 0;
    float *raw = malloc(sizeof *raw * cells), *out = malloc(sizeof *out * (size_t)width);
    long used[WDR_BASIS_SAMPLES] = {0};
    const int rows = res->height < SAMPLE_ROWS ? res->height : SAMPLE_ROWS;
    for (int q = 0; ref && w && raw && out && q < rows; q++) {
        const int r = (int)(((long)q * 2 + 1) * res->height / (2L * rows));
        row_reference(res, basis, r, ref, raw, w);
        for (int k = 0; k < WDR_BASIS_SAMPLES; k++) {
            if (wdr_correct_row_f32(&v, r, raw + (size_t)k * width, out) != WDR_OK)
                continue;
            for (int c = 0; c < width; c++) {
                size_t at = (size_t)k * width + c;
                if (!isfinite(ref[at]))
                    continue;
                double d = ((double)out[c] / v.h.out_scale - ref[at]) * w[at];
                e2[k] += d * d, used[k]++;
            }
        }
    }
    for (int k = 0; k < WDR_BASIS_SAMPLES; k++)
        if (used[k])
            worst = fmax(worst, sqrt(e2[k] / (double)used[k]));
    free(ref), free(w), free(raw), free(out);
    return 100 * worst;
}
