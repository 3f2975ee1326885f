/* Planted fault for the calibration pipeline check: the nominal pixel's evaluation and its fit in
 * one file (host/cal/cal_nominal.c before the split), so the per-pixel fit it calls calls back. */
double wdr_cal_fit_paper_pixel(double y);

double wdr_nominal_invert(double y)
{
    return -y;
}

double wdr_cal_fit_nominal(double y)
{
    return wdr_cal_fit_paper_pixel(y);
}
