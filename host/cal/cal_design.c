/* The designed response of a board's nominal pixel (see cal_design.h). */
#include "cal_design.h"
#include "wdr_err.h"
#include <math.h>
#include <string.h>

int wdr_cal_design_init(wdr_cal_design *d, const wdr_board *b, const char *op_name, double t_int_s,
                        double t_after_s, int with_effects, char *err, int errlen)
{
    wdr_lum_stats st;
    memset(d, 0, sizeof *d);
    d->board = *b;
    wdr_ideal_pixel_init(b, &d->px);
    wdr_lum_stats_default(b->i_min_a, b->i_center_a, b->i_max_a, b->lum_per_amp, 0.18, &st);
    int rc = wdr_operator_init(&d->op, op_name, &st, err, errlen);
    if (rc)
        return rc;
    double g_min = wdr_ideal_target(&d->px, &d->op, b->i_min_a);
    d->t_int_s = t_int_s > 0 ? t_int_s : wdr_ideal_cross_time(&d->px, b->i_min_a, g_min);
    d->t_after_s = t_after_s;
    d->leak_v_per_s = with_effects && b->c_hold_f > 0 ? b->hold_leak_a / b->c_hold_f : 0;
    d->dark_a = with_effects ? b->dark_current_a : 0;
    return WDR_OK;
}

double wdr_cal_design_code(const wdr_cal_design *d, double x)
{
    const wdr_board *b = &d->board;
    double i = x + d->dark_a, g = wdr_ideal_target(&d->px, &d->op, i); /* the ramp maps the total current */
    double t_cross = fmin(wdr_ideal_cross_time(&d->px, i, g), d->t_int_s);
    double held = g - d->leak_v_per_s * (d->t_int_s - t_cross + d->t_after_s);
    double v = wdr_pixel_sf_out(&d->px.dev, held), full = (double)((1u << b->adc_bits) - 1u);
    return (b->adc_gain * v + b->adc_offset_v - b->adc_lo_v) / (b->adc_hi_v - b->adc_lo_v) * full;
}

/* Central difference in ln x: the design is smooth (no DAC steps), a step of 1e-4 leaves
 * truncation and rounding errors far below a thousandth of a code per unit of ln x. */
double wdr_cal_design_log_slope(const wdr_cal_design *d, double x)
{
    const double h = 1e-4;
    return (wdr_cal_design_code(d, x * exp(h)) - wdr_cal_design_code(d, x * exp(-h))) / (2 * h);
}

double wdr_cal_design_dac_step_codes(const wdr_cal_design *d, double x)
{
    const wdr_board *b = &d->board;
    double g = wdr_ideal_target(&d->px, &d->op, x + d->dark_a), dv = 1e-4;
    double gain = (wdr_pixel_sf_out(&d->px.dev, g + dv) - wdr_pixel_sf_out(&d->px.dev, g - dv)) / (2 * dv);
    double adc_lsb = (b->adc_hi_v - b->adc_lo_v) / (double)((1u << b->adc_bits) - 1u);
    double dac_lsb = (b->dac_hi_v - b->dac_lo_v) / (double)((1u << b->dac_bits) - 1u);
    return fabs(gain * b->adc_gain) * dac_lsb / adc_lsb;
}

double wdr_cal_design_end_ratio(const wdr_cal_design *d, double x0, double x1)
{
    double secant = (wdr_cal_design_code(d, x1) - wdr_cal_design_code(d, x0)) / log(x1 / x0);
    double r = wdr_cal_design_log_slope(d, x0) / secant;
    return isfinite(r) && r > 0 ? r : 0;
}
