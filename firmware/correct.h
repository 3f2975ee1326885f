/* On-the-fly fixed-pattern-noise correction: the per-pixel kernel that READOUT runs on every row.
 * float32 only (Cortex-M7 single-precision FPU); no double, no heap. */
#ifndef WDR_CORRECT_H
#define WDR_CORRECT_H
#include "wdr_cal.h"
#include <stdint.h>

/* Correct one row of raw ADC codes into output codes (width values each). Flagged pixels are
 * replaced by the mean of the nearest unflagged corrected pixels left and right in the row.
 * Output is always a finite code in [0, out_max]. raw and out may not overlap.
 * @retval WDR_OK
 * @retval WDR_E_INVAL  row out of range or a NULL pointer */
int wdr_correct_row(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out);

/* The same correction on unquantised codes (simulator studies, host reports, torture tests):
 * out gets v * out_scale without rounding, clamped to [0, out_max]; non-finite input gives 0. */
int wdr_correct_row_f32(const wdr_cal_view *cal, int row, const float *raw, float *out);

#endif
