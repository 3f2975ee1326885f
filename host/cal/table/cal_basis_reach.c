/* The shared functions held flat past the codes the array reaches (see wdr_cal_basis_held in
 * cal_basis.h). */
#include "cal_basis.h"
#include "wdr_err.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The lowest and highest raw code any good pixel reads at the 64 calibrated currents, moved by its
 * shift as the kernel moves it; 0 when no pixel reads a finite code. */
static int reached_codes(const wdr_cal_result *res, const wdr_basis *b, double *lo, double *hi)
{
    const long np = (long)res->width * res->height;
    *lo = INFINITY, *hi = -INFINITY;
    for (long i = 0; i < np; i++) {
        if (res->flags[i])
            continue;
        wdr_map_samples s;
        wdr_cal_map_samples(res, i, &s);
        wdr_cal_basis_shift(b, &s);
        for (int k = 0; k < WDR_BASIS_SAMPLES; k++)
            if (isfinite(s.y[k]))
                *lo = fmin(*lo, s.y[k]), *hi = fmax(*hi, s.y[k]);
    }
    return *hi >= *lo;
}

int wdr_cal_basis_held(const wdr_cal_result *res, const wdr_basis *in, wdr_basis *out)
{
    double lo, hi;
    *out = *in;
    out->table = NULL;
    if (!reached_codes(res, in, &lo, &hi))
        return WDR_E_NUMERIC;
    /* the grid points whose interval holds a reached code: the kernel interpolates between j and
     * j + 1, so both ends of the first and the last such interval stay */
    int j0 = (int)floor((lo - in->lo) / in->step), j1 = (int)ceil((hi - in->lo) / in->step);
    j0 = j0 < 0 ? 0 : j0 > in->points - 1 ? in->points - 1 : j0;
    j1 = j1 < j0 ? j0 : j1 > in->points - 1 ? in->points - 1 : j1;
    const int n = in->n;
    out->table = malloc(sizeof(float) * (size_t)in->points * n);
    if (!out->table)
        return WDR_E_NOMEM;
    for (int j = 0; j < in->points; j++) {
        int from = j < j0 ? j0 : j > j1 ? j1 : j;
        memcpy(out->table + (long)j * n, in->table + (long)from * n, sizeof(float) * (size_t)n);
    }
    return WDR_OK;
}
