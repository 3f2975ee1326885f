/* Shared by the calibration and torture tests: cmocka helpers and a simulated chip in one call. */
#ifndef CAL_TEST_SUPPORT_H
#define CAL_TEST_SUPPORT_H
#include "cal_engine.h"
#include "cal_fit.h"
#include "cal_metrics.h"
#include "correct.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "wdr_test.h"

/* Every float of a table's coefficient planes and shared block is finite (the parser checks it too). */
static inline int table_all_finite(const wdr_cal_view *v)
{
    for (uint32_t j = 0; v->shared && j < v->h.shared_points * v->h.n_coeffs; j++)
        if (!isfinite(v->shared[j]))
            return 0;
    for (int r = 0; r < v->h.height; r++)
        for (int k = 0; k < v->h.n_coeffs; k++) {
            const float *c = wdr_cal_row_coeffs(v, r, k);
            for (int i = 0; i < v->h.width; i++)
                if (!isfinite(c[i]))
                    return 0;
        }
    return 1;
}

/* Run the float32 kernel over every raw code 0..raw_max for every pixel of row r: all outputs
 * must be finite and within [0, out_max]. Returns the number of bad outputs. */
static inline long kernel_sweep_bad(const wdr_cal_view *v)
{
    int w = v->h.width;
    float *raw = malloc(sizeof(float) * (size_t)w), *out = malloc(sizeof(float) * (size_t)w);
    uint16_t *raw16 = malloc(sizeof(uint16_t) * (size_t)w), *out16 = malloc(sizeof(uint16_t) * (size_t)w);
    long bad = 0;
    for (int r = 0; r < v->h.height; r++)
        for (int code = 0; code <= v->h.raw_max; code += 7) {
            for (int i = 0; i < w; i++)
                raw[i] = (float)code, raw16[i] = (uint16_t)code;
            if (wdr_correct_row_f32(v, r, raw, out) || wdr_correct_row(v, r, raw16, out16))
                return -1;
            for (int i = 0; i < w; i++)
                bad += !isfinite(out[i]) || out[i] < 0 || out[i] > v->h.out_max;
        }
    free(raw), free(out), free(raw16), free(out16);
    return bad;
}

/* Plant ppm of each defect kind (dead, hot, stuck, saturated) at seeded positions, plus one of each
 * at the four corners, where neighbour-based code is weakest. @retval the simulator's status */
static inline int plant_defects(wdr_sim *sim, int width, int height, double ppm)
{
    long np = (long)width * height, corner[4] = {0, np - 1, (long)(height - 1) * width, width - 1};
    uint8_t kind[4] = {WDR_DEFECT_DEAD, WDR_DEFECT_HOT, WDR_DEFECT_STUCK, WDR_DEFECT_SATURATED};
    wdr_sim_defects d = {.ppm = {0, ppm, ppm, ppm, ppm},
                         .seed = 99,
                         .n_listed = 4,
                         .listed_index = corner,
                         .listed_kind = kind};
    return wdr_sim_set_defects(sim, &d);
}

#endif
