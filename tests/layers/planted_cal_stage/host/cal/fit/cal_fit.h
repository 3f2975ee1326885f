/* Planted fault for the calibration pipeline check: a header of the fit stage. */
int wdr_cal_fit_array(int n);
