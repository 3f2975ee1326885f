/* Planted fault for the calibration pipeline check: the fit stage. */
#include "cal_fit.h"

int wdr_cal_fit_array(int n)
{
    return n;
}
