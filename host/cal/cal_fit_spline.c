/* SPLINE: the pixel's own monotone responses as its model; the falling repair of quantised ties. */
#include "cal_fit_internal.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A falling curve through quantised codes: where the response is flat the codes of neighbouring
 * levels tie, or even rise by less than an LSB. Within the tie tolerance that is quantisation, and
 * a tiny step keeps the curve strictly falling (its inverse then lands inside the tie, which is
 * all the data can tell); a larger rise is a reversed pixel. */
int wdr_cal_falling_repair(const double *y, int n, double tie, double *out)
{
    for (int k = 0; k < n; k++) {
        if (!isfinite(y[k]))
            return WDR_FIT_NONFINITE;
        out[k] = y[k];
        if (k > 0 && y[k] > y[k - 1] + tie)
            return WDR_FIT_REVERSED;
        if (k > 0 && out[k] > out[k - 1] - WDR_CAL_TIE_STEP)
            out[k] = out[k - 1] - WDR_CAL_TIE_STEP;
    }
    return WDR_FIT_OK;
}

/* SPLINE: the pixel's own responses are the model. Where the array's response falls clearly
 * between two levels, a pixel that hardly moves there is a stuck stretch, not quantisation. */
int wdr_cal_fit_spline_pixel(const double *y, const double *med, int n, double tie, double *par)
{
    int st = wdr_cal_falling_repair(y, n, tie, par);
    for (int k = 1; !st && k < n; k++)
        if (med[k - 1] - med[k] > 8 * tie && y[k - 1] - y[k] < 0.1 * (med[k - 1] - med[k]))
            st = WDR_FIT_FLAT;
    return st;
}

double wdr_cal_spline_recover(const wdr_cal_result *res, const double *par, double y)
{
    wdr_pchip p;
    if (wdr_pchip_init_ends(&p, res->nominal.curve.lx, par, res->nominal.curve.n, res->nominal.end_ratio))
        return 0;
    double lx = wdr_pchip_invert(&p, y);
    return lx > log(1e-22) ? exp(fmin(lx, log(1e-2))) : 0;
}
