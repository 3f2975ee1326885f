/* Planted fault for the calibration pipeline check: the statistics include a header of the fit
 * stage and call a fit, a later stage. */
#include "cal_fit.h"

int wdr_cal_level_count(int n)
{
    return wdr_cal_fit_array(n);
}
