/* The figures `--form auto` chooses by, and the choice. Measured, not modelled: analog worst
 * contrast error of each form on each operator through the kernel's arithmetic, 19-level spline
 * fit, 31 judged currents (tests/bench/bench_target_study.h): bench_target's 64x48 chip (seed 11)
 * for all forms, and for compact and shifted the worst over bench_shifted's chips: seeds 11, 3, 7
 * at 64x48 and 96x72 for Reinhard, Tumblin-Rushmeier and Drago; the other four at seed 11 only
 * (reinhard_white compact: seeds 11, 3). Tumblin-Rushmeier's shifted form reaches 1.56 % at 96x72
 * (0.88-0.98 % at 64x48; 1.00-1.21 % at 160x120, seeds 11, 3, 7), so auto gives it basis-8.
 * The 12-bit ratio to the floor is bench_floor's (64x48, seed 11, converters on, temporal noise
 * off; basis-8 on Reinhard 0.98x as test_cal_endslope): it rejects compact on Schlick (1.65x), where shifted takes it
 * (0.97x). Within an operator the rows are ordered smallest first: bytes per pixel, then (equal bytes) the cheaper
 * calibration (compact learns its basis once, shifted twice). */
#include "cal_form_auto.h"
#include "wdr_cal.h"
#include "wdr_lut.h"
#include <math.h>
#include <stddef.h>

/* analog worst % (c s p b) and 12-bit ratio to the floor (cf sf pf bf) of compact, shifted, poly-5,
 * basis-8 */
#define ROWS(op, c, s, p, b, cf, sf, pf, bf)                                                                           \
    {op, WDR_FORM_COMPACT, 4, 9, c, cf}, {op, WDR_FORM_SHIFTED, 4, 9, s, sf}, {op, WDR_FORM_POLY, 5, 21, p, pf},       \
    {                                                                                                                  \
        op, WDR_FORM_BASIS, 8, 33, b, bf                                                                               \
    }

const wdr_form_figure wdr_form_figures[] = {
    ROWS(WDR_OP_REINHARD, 0.827, 0.928, 0.262, 0.195, 0.867, 0.944, 0.872, 0.980),
    ROWS(WDR_OP_REINHARD_WHITE, 0.712, 0.579, 0.273, 0.499, 1.102, 1.034, 1.004, 1.011),
    ROWS(WDR_OP_SCHLICK, 0.545, 0.474, 0.646, 0.376, 1.653, 0.974, 0.909, 0.951),
    ROWS(WDR_OP_TUMBLIN_RUSHMEIER, 3.068, 1.557, 11.465, 0.720, 1.038, 0.704, 2.447, 0.802),
    ROWS(WDR_OP_DRAGO, 1.758, 0.757, 2.155, 0.631, 1.089, 0.874, 0.904, 0.906),
    ROWS(WDR_OP_EXPONENTIAL, 0.720, 0.744, 0.636, 0.768, 0.768, 0.825, 0.943, 0.919),
    ROWS(WDR_OP_LOGARITHMIC, 0.227, 0.201, 0.445, 0.177, 0.820, 1.150, 0.801, 0.939),
};
const int wdr_form_figures_n = (int)(sizeof wdr_form_figures / sizeof wdr_form_figures[0]);

int wdr_form_meets(const wdr_form_figure *f, wdr_form_target t)
{
    return f->analog_pct <= t.analog_pct && (isnan(f->floor_ratio) || f->floor_ratio <= t.floor_ratio);
}

const wdr_form_figure *wdr_form_auto(const wdr_form_figure *table, int n, int op, wdr_form_target t,
                                     const wdr_form_figure **rejected, int *n_rejected)
{
    *n_rejected = 0;
    for (int i = 0; i < n; i++) {
        if (table[i].op != op)
            continue;
        if (wdr_form_meets(&table[i], t))
            return &table[i];
        if (*n_rejected < WDR_FORM_AUTO_MAX)
            rejected[(*n_rejected)++] = &table[i];
    }
    return NULL;
}
