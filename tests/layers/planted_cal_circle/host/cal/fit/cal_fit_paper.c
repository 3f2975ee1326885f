/* Planted fault for the calibration pipeline check: a per-pixel fit judged against the nominal
 * inverse, which lives in the file that calls this fit. */
double wdr_nominal_invert(double y);

double wdr_cal_fit_paper_pixel(double y)
{
    return wdr_nominal_invert(y);
}
