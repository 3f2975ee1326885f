/* On-the-fly fixed-pattern-noise correction: the per-pixel kernel that READOUT runs on every row.
 * float32 only (Cortex-M7 single-precision FPU); no double, no heap. */
#ifndef WDR_CORRECT_H
#define WDR_CORRECT_H
#include "wdr_cal.h"
#include <stddef.h>
#include <stdint.h>

/* Correct one row of raw ADC codes into output codes (width values each). Flagged pixels are
 * replaced by the mean of the nearest unflagged corrected pixels left and right in the row.
 * Output is always a finite code in [0, out_max]. raw and out may not overlap.
 * @retval WDR_OK
 * @retval WDR_E_INVAL  row out of range or a NULL pointer */
int wdr_correct_row(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out);

/* The same correction on unquantised codes (simulator studies, host reports, torture tests):
 * out gets v * out_scale without rounding, clamped to [0, out_max]; non-finite input gives 0.
 * COMPACT: the fixed-point sums of the two codes around y, interpolated, without the final
 * rounding (the controller's own arithmetic between codes). Host only: defined in
 * host/lib/correct_f32.c (the controller never sees a float code); same errors. */
int wdr_correct_row_f32(const wdr_cal_view *cal, int row, const float *raw, float *out);

/* The checks both entry points make: 1 if the view, its form and coefficient count, the row and
 * both pointers are usable. */
int wdr_correct_row_ok(const wdr_cal_view *cal, int row, const void *raw, const void *out);

/* Make a BASIS view fast for wdr_correct_row: a code's position t(y), its point and its fraction
 * are the same for every pixel, so tabulate sum-ready basis values once per table instead of
 * interpolating them per pixel. points[y * n + k] = B_k(t(y)) for every code y in 0..raw_max
 * (capacity floats, at least (raw_max + 1) * n_coeffs); the view then describes the same map
 * as a BASIS table with one point per code (shared = points, shared_points = raw_max + 1,
 * in_scale 1, in_offset 0), and wdr_correct_row does one dot product per pixel. Results change
 * by float rounding only; codes above raw_max (no ADC of the table gives them) get raw_max's
 * value instead of the last shared point's. Call again whenever the shared block or the mapping changes; points
 * must outlive the view. wdr_correct_row_f32 on such a view interpolates between codes.
 * @retval WDR_OK
 * @retval WDR_E_INVAL      not a BASIS view with its shared block, or raw_max of 0
 * @retval WDR_E_TOO_LARGE  capacity below (raw_max + 1) * n_coeffs; the view is left unchanged */
int wdr_correct_per_code(wdr_cal_view *cal, float *points, size_t capacity);

/* The same for a COMPACT view: points[4y..4y+3] get code y's fixed-point base and points (int16
 * pairs, 2^-code_shift output codes each, correct_inline.h) for every code 0..raw_max (capacity
 * words, at least 4 (raw_max + 1)); the view's code_q and code_shift then point at them and
 * wdr_correct_row does two SMLAD per pixel. Results are the same bits as without them. Call again
 * whenever the shared block changes; points must outlive the view.
 * @retval WDR_OK
 * @retval WDR_E_INVAL      not a COMPACT view with its shared block, or raw_max of 0
 * @retval WDR_E_TOO_LARGE  capacity below 4 (raw_max + 1); the view is left unchanged */
int wdr_correct_per_code_compact(wdr_cal_view *cal, uint32_t *points, size_t capacity);

#endif
