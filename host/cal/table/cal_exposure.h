/* The LUT's exposure table anchored at the calibration's levels.
 *
 * The exposure block (firmware/wdr_lut.h, host/lib/ramp_exposure.c) says which current a corrected
 * code stands for, from the board's designed pixel. The corrected codes are the chip's own nominal
 * pixel's (the array median, cal_fit_nominal.c), and that differs from the design by the chip's
 * median mismatch: on sim-qvga's seed 5 the nominal read 0.02-0.12 ln dark of the design below
 * 1e-13 A, and the firmware's auto exposure, averaging the table over a frame, settled 2.3 % low
 * on the HDR wedge. At each calibration level the median pixel's code is measured, so the table
 * is moved there to the level's current: by the difference at each level, linear in code between
 * levels and held past the first and the last. Past the floor, where the block says the codes are
 * linear in current (Schlick), the line the firmware reads the dark tail from is fitted to the
 * levels there: the chips' codes at 1e-13 A lay 0.75 code apart, and the dark scene's key 4.4 %. */
#ifndef CAL_EXPOSURE_H
#define CAL_EXPOSURE_H
#include "board.h"
#include "cal_fit.h"
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct wdr_cal_exposure_anchors {
    int n;                   /* levels the table was moved at (0: the LUT has no exposure block) */
    double worst_ln;         /* the largest move, ln units */
    double worst_at_a;       /* at that level's current */
    bool dark_line;          /* the line past the floor was fitted to the levels past it */
    double dark_moved_codes; /* how far its end at no light moved, codes (the chip's less the design's) */
} wdr_cal_exposure_anchors;

/* Anchor the exposure block at the end of the LUT in bytes (in place, CRC too) at the n levels
 * amps (A; 0 entries, the dark reference, are skipped): level k's corrected code is
 * nominal(amps[k]) * code_scale (the table's output scale). b is the board file the block was built
 * for. level_codes (may be NULL: the nominal's) are the chip's mean corrected codes at the levels
 * (wdr_cal_mean_corrected_code): where the block says its dark end is linear
 * (WDR_LUT_EXPO_LINEAR_DARK), the line past the floor is fitted to the levels past it. A LUT
 * without a block is left as it is (out->n 0).
 * @retval WDR_OK, the LUT and block parse errors, WDR_E_NOMEM, WDR_E_INVAL (a block of another size
 *         than this board's design: its key cannot be recovered) */
int wdr_cal_exposure_anchor(uint8_t *bytes, size_t len, const wdr_board *b, const wdr_nominal *nominal,
                            double code_scale, const double *amps, int n, const double *level_codes,
                            wdr_cal_exposure_anchors *out);

/* The mean over the array of `frame` (raw codes, a calibration level's average) corrected by the
 * calibration table (flagged pixels patched, as the board does): what the firmware's frame
 * histogram averages at that light. @retval WDR_OK, the table's parse errors, WDR_E_NOMEM */
int wdr_cal_mean_corrected_code(const uint8_t *table, size_t len, const float *frame, double *mean);

#endif
