/* The simulated chip of one design point: the board with the point's converters and size, the
 * operator's ramp as a LUT (with the calibration margin), converter ranges fitted to the signal
 * when asked, and a simulator with every effect on. */
#include "cal_engine.h"
#include "ramp.h"
#include "study_internal.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int board_for_point(const study *s, const study_point *p, study_chip *c, char *err, int errlen)
{
    char path[4200];
    wdr_board_path(s->board, path, sizeof path);
    wdr_board_defaults(&c->full);
    int rc = wdr_board_load_named(s->board, &c->full, err, errlen);
    if (rc)
        return rc;
    wdr_board *b = &c->b;
    *b = c->full;
    b->width = (uint16_t)p->width, b->height = (uint16_t)p->height;
    b->adc_bits = p->adc_bits, b->dac_bits = p->dac_bits;
    if (isfinite(p->adc_lo_v))
        b->adc_lo_v = p->adc_lo_v, b->adc_hi_v = p->adc_hi_v;
    if (isfinite(p->dac_lo_v))
        b->dac_lo_v = p->dac_lo_v, b->dac_hi_v = p->dac_hi_v;
    b->dac_timing = p->timing;
    if (p->uniform_entries)
        b->dac_uniform_entries = p->uniform_entries;
    if (p->dac_timer_hz > 0)
        b->dac_timer_hz = p->dac_timer_hz;
    return wdr_board_validate(b, path, err, errlen);
}

static int operator_for_point(const study_point *p, const wdr_board *b, wdr_operator *op, char *err, int errlen)
{
    wdr_lum_stats st;
    wdr_lum_stats_default(b->i_min_a, b->i_center_a, b->i_max_a, b->lum_per_amp, 0.18, &st);
    int rc = wdr_operator_init(op, p->op, &st, err, errlen);
    char buf[STUDY_OP_PARAMS], *save = NULL;
    snprintf(buf, sizeof buf, "%s", p->op_params);
    for (char *kv = strtok_r(buf, ";", &save); !rc && kv; kv = strtok_r(NULL, ";", &save))
        rc = wdr_operator_set_param(op, kv, err, errlen);
    return rc ? rc : wdr_operator_validate(op, err, errlen);
}

/* The ramp spans [v0, v1]; the calibration margin continues it upwards. */
static void fit_dac_range(wdr_board *b, const wdr_ramp *r)
{
    double v0 = r->v[0], v1 = r->v[r->n - 1] + WDR_CAL_MARGIN_V, m = STUDY_FIT_MARGIN * (v1 - v0);
    b->dac_lo_v = fmax(b->dac_lo_v, v0 - m);
    b->dac_hi_v = fmin(b->dac_hi_v, v1 + m);
}

static int build_lut(study_chip *c, int fit, char *err, int errlen)
{
    wdr_ideal_pixel px;
    wdr_ramp r;
    wdr_ideal_pixel_init(&c->b, &px);
    int rc = wdr_ramp_build(&px, &c->op, c->b.i_min_a, c->b.i_max_a, 8192, WDR_RAMP_REPAIR, &r, err, errlen);
    if (rc)
        return rc;
    if (fit)
        fit_dac_range(&c->b, &r);
    c->ramp_span_v = r.v[r.n - 1] - r.v[0];
    wdr_pixel_dev d;
    wdr_pixel_nominal(&c->b, &d);
    double vm = 0.5 * (r.v[0] + r.v[r.n - 1]);
    c->sf_gain = (wdr_pixel_sf_out(&d, vm + 0.01) - wdr_pixel_sf_out(&d, vm - 0.01)) / 0.02;
    uint8_t *bytes;
    size_t len;
    rc = wdr_ramp_quantise(&r, &c->b, &c->op, c->b.dac_timing, c->b.dac_uniform_entries, &bytes, &len, err, errlen);
    wdr_ramp_free(&r);
    if (rc)
        return rc;
    double added, done;
    rc = wdr_cal_lut_extend(bytes, len, WDR_CAL_MARGIN_V, WDR_CAL_MARGIN_MAX_TIME_FRAC, &c->lut, &c->lut_len, &added,
                            &done, err, errlen);
    free(bytes);
    return rc;
}

static int new_sim(study_chip *c, uint64_t seed, int temporal, char *err, int errlen)
{
    wdr_lut_view lut;
    int rc = wdr_lut_parse(c->lut, c->lut_len, &lut);
    if (rc)
        return snprintf(err, (size_t)errlen, "built LUT does not parse: %s", wdr_strerror(rc)), rc;
    c->t_ramp_s = lut.h.t_integration_ticks * (double)lut.h.tick_ps * 1e-12;
    wdr_sim_destroy(c->sim);
    if (!(c->sim = wdr_sim_create(&c->b, seed)))
        return snprintf(err, (size_t)errlen, "out of memory for a %dx%d chip", c->b.width, c->b.height), WDR_E_NOMEM;
    wdr_sim_set_threads(c->sim, 1); /* the study runs points in parallel instead */
    for (int fx = 0; fx < WDR_FX_COUNT; fx++)
        wdr_sim_set_effect(c->sim, fx, WDR_FX_ON);
    static const int noise[] = {WDR_FX_SHOT, WDR_FX_KTC, WDR_FX_READ};
    for (int k = 0; k < 3; k++)
        wdr_sim_set_effect(c->sim, noise[k], temporal ? WDR_FX_ON : WDR_FX_OFF);
    wdr_sim_set_effect(c->sim, WDR_FX_DEFECTS, WDR_FX_OFF); /* a clean chip: every flag is a false one */
    if ((rc = wdr_sim_set_lut(c->sim, &lut)))
        snprintf(err, (size_t)errlen, "simulator refused the LUT: %s", wdr_strerror(rc));
    return rc;
}

/* The ADC input range the array's signal covers from dark to the brightest current, measured
 * unquantised and unclipped on the chip itself, plus the margin. */
static int fit_adc_range(study_chip *c, const study *s, char *err, int errlen)
{
    int rc = new_sim(c, s->seed, 0, err, errlen);
    long np = (long)c->b.width * c->b.height;
    float *f = malloc(sizeof(float) * (size_t)np);
    if (!f)
        return WDR_E_NOMEM;
    wdr_sim_set_effect(c->sim, WDR_FX_ADC_QUANT, WDR_FX_OFF);
    wdr_sim_set_effect(c->sim, WDR_FX_CLIPPING, WDR_FX_OFF);
    double lo = INFINITY, hi = -INFINITY, full = (double)((1u << c->b.adc_bits) - 1u);
    const double amps[] = {0, s->range_lo, s->range_hi};
    for (int k = 0; !rc && k < 3; k++) {
        if (!(rc = wdr_sim_set_uniform(c->sim, amps[k])) && !(rc = wdr_sim_render_float(c->sim, 7, f)))
            for (long i = 0; i < np; i++)
                lo = fmin(lo, f[i]), hi = fmax(hi, f[i]);
    }
    free(f);
    if (rc || !(hi > lo))
        return snprintf(err, (size_t)errlen, "cannot measure the ADC signal range"), rc ? rc : WDR_E_NUMERIC;
    double span = c->b.adc_hi_v - c->b.adc_lo_v, v0 = c->b.adc_lo_v + lo / full * span,
           v1 = c->b.adc_lo_v + hi / full * span, m = STUDY_FIT_MARGIN * (v1 - v0);
    c->b.adc_lo_v = v0 - m, c->b.adc_hi_v = v1 + m;
    return WDR_OK;
}

int study_chip_open(const study *s, const study_point *p, study_chip *c, char *err, int errlen)
{
    memset(c, 0, sizeof *c);
    int rc = board_for_point(s, p, c, err, errlen);
    if (!rc)
        rc = operator_for_point(p, &c->b, &c->op, err, errlen);
    if (!rc)
        rc = build_lut(c, p->fit_ranges, err, errlen);
    if (!rc && p->fit_ranges)
        rc = fit_adc_range(c, s, err, errlen);
    if (!rc)
        rc = new_sim(c, s->seed, 1, err, errlen);
    return rc;
}

void study_chip_close(study_chip *c)
{
    wdr_sim_destroy(c->sim);
    free(c->lut);
    c->sim = NULL, c->lut = NULL;
}
