/* The designed response of a board's nominal pixel (see cal_design.h). */
#include "cal_design.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The first nodes of the realised ramp: the board's LUT (built as `wdrctl lut build` builds it),
 * its first code from t = 0 to the middle of its first step, then the middles of the next steps
 * (consecutive entries with one code are one step). */
static int realised_start(wdr_cal_design *d, const wdr_board *b, const char *op_name, char *err, int errlen)
{
    uint8_t *bytes;
    size_t len;
    wdr_lut_view lut;
    int rc = wdr_ramp_board_lut(b, op_name, &bytes, &len, NULL, err, errlen);
    if (rc)
        return rc;
    if (!(rc = wdr_lut_parse(bytes, len, &lut))) {
        double tick = lut.h.tick_ps * 1e-12, full = (double)((1u << lut.h.dac_bits) - 1u);
        double lsb = ((double)lut.h.dac_hi_v - lut.h.dac_lo_v) / full, start = 0;
        uint32_t t;
        uint16_t code, prev = 0;
        d->n_start = 0;
        for (uint32_t i = 0; i < lut.h.entry_count && d->n_start < WDR_CAL_DESIGN_START_NODES; i++) {
            wdr_lut_entry(&lut, i, &t, &code);
            if (i > 0 && code == prev)
                continue;
            if (i > 0) { /* the previous step ends here: its middle is a node */
                d->start_t[d->n_start] = 0.5 * (start + t * tick);
                d->start_v[d->n_start++] = lut.h.dac_lo_v + prev * lsb;
            } else {
                d->start_t[d->n_start] = 0;
                d->start_v[d->n_start++] = lut.h.dac_lo_v + code * lsb;
            }
            start = t * tick, prev = code;
        }
    }
    free(bytes);
    return rc;
}

int wdr_cal_design_init(wdr_cal_design *d, const wdr_board *b, const char *op_name, double t_int_s, double t_after_s,
                        int with_effects, char *err, int errlen)
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
    return with_effects ? realised_start(d, b, op_name, err, errlen) : WDR_OK;
}

static double start_ramp_at(const wdr_cal_design *d, double t)
{
    int k = 1;
    while (k < d->n_start - 1 && d->start_t[k] < t)
        k++;
    double t0 = d->start_t[k - 1], t1 = d->start_t[k], f = t1 > t0 ? (t - t0) / (t1 - t0) : 1;
    return d->start_v[k - 1] + fmin(fmax(f, 0), 1) * (d->start_v[k] - d->start_v[k - 1]);
}

/* Held G of the nominal pixel with total current i on the realised ramp's start, and when M2
 * turned off: the first t with i t = the charge G = V_ref(t) needs (bisection: the charge
 * needed falls as V_ref rises). 0 when the pixel crosses after the kept nodes. */
static int held_on_start(const wdr_cal_design *d, double i, double *held, double *t_cross)
{
    if (d->n_start < 2)
        return 0;
    double lo = 0, hi = d->start_t[d->n_start - 1];
    if (hi < wdr_ideal_cross_time(&d->px, i, start_ramp_at(d, hi)))
        return 0;
    for (int it = 0; it < 80; it++) {
        double mid = 0.5 * (lo + hi);
        if (mid < wdr_ideal_cross_time(&d->px, i, start_ramp_at(d, mid)))
            lo = mid;
        else
            hi = mid;
    }
    *t_cross = hi;
    *held = start_ramp_at(d, hi);
    return 1;
}

double wdr_cal_design_code(const wdr_cal_design *d, double x)
{
    const wdr_board *b = &d->board;
    double i = x + d->dark_a, g = wdr_ideal_target(&d->px, &d->op, i); /* the ramp maps the total current */
    double t_cross = fmin(wdr_ideal_cross_time(&d->px, i, g), d->t_int_s);
    if (held_on_start(d, i, &g, &t_cross))
        t_cross = fmin(t_cross, d->t_int_s);
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

void wdr_cal_margin_req_for(const wdr_cal_design *d, double dim_a, double bright_a, int frames, wdr_cal_margin_req *req)
{
    const wdr_board *b = &d->board;
    double lsb = (b->dac_hi_v - b->dac_lo_v) / (double)((1u << b->dac_bits) - 1u);
    *req = (wdr_cal_margin_req){.dim_a = dim_a,
                                .bright_a = bright_a,
                                .dac_lsb_v = lsb,
                                .frames = frames,
                                .codes_per_v = wdr_cal_design_dac_step_codes(d, dim_a) / lsb};
}
