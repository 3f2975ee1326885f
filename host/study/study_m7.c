/* M7 instructions per pixel per table form: measured, not modelled. The counts are those
 * tests/bench/bench_target prints (QEMU mps2-an500, -icount shift=0, the firmware's kernel on a
 * 640 x 8 frame, 12-bit codes; correction alone, and the row path: correction, ROW framing, CRC),
 * copied here from its run at this tree's commit; `bench_target --counts FILE` writes them and
 * `test_study_m7 FILE` (.ci/test) fails when they drift from these by more than 0.5 %. Only the
 * coefficient counts bench_target runs are known (poly 5, basis 8); others are NAN. */
#include "study.h"
#include "wdr_cal.h"
#include <math.h>

static const study_m7_count counts[] = {
    {WDR_FORM_IDENTITY, 0, 8.13, 17.55}, {WDR_FORM_MOEBIUS, 3, 26.57, 36.10}, {WDR_FORM_POLY, 5, 51.65, 61.18},
    {WDR_FORM_BASIS, 8, 90.75, 100.28},  {WDR_FORM_COMPACT, 4, 22.54, 32.07}, {WDR_FORM_SHIFTED, 4, 21.58, 31.12},
};

const study_m7_count *study_m7_counts(int *n)
{
    *n = (int)(sizeof counts / sizeof counts[0]);
    return counts;
}

void study_m7_for(int form, int n_coeffs, double *corr_px, double *row_px)
{
    *corr_px = *row_px = NAN;
    for (size_t i = 0; i < sizeof counts / sizeof counts[0]; i++)
        if (counts[i].form == form && counts[i].n_coeffs == n_coeffs)
            *corr_px = counts[i].corr_px, *row_px = counts[i].row_px;
}
