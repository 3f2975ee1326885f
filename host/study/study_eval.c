/* One design point: calibrate the simulated chip as a board would (levels x frames, dark frame),
 * build the firmware table, then judge it on uniform images over the requested range and cost
 * it. Everything runs from the study's seed: the same point gives the same bits. */
#include "cal_basis.h"
#include "cal_design.h"
#include "cal_select.h"
#include "correct.h"
#include "study_internal.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define N_EVAL 24 /* judged currents, log-spaced over the requested range */
#define FRAME_SEED_EVAL 100000000ull
#define DISPLAY_GAMMA 2.2

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Measured costs are CPU time of this (single-threaded) worker, not wall time: on a shared
 * machine the wall clock counts the other processes too. */
static double cpu_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void set_temporal(wdr_sim *sim, int on)
{
    static const int noise[] = {WDR_FX_SHOT, WDR_FX_KTC, WDR_FX_READ};
    for (int k = 0; k < 3; k++)
        wdr_sim_set_effect(sim, noise[k], on ? WDR_FX_ON : WDR_FX_OFF);
}

/* ---- calibration ---- */

typedef struct calib {
    wdr_cal_design design; /* the designed response: the spline's end slopes (as wdrctl calibrate) */
    wdr_cal_config cfg;
    wdr_cal_levels lv;
    wdr_cal_result res;
    uint8_t *table;
    size_t table_len;
    wdr_cal_view tab;
    int levels_acquired; /* light levels captured on the board (the dark frame not counted) */
} calib;

/* Light levels; the paper models fit 3 or 4 exactly and more by least squares (the dark frame
 * is their reference besides). */
static int levels_needed(const study_point *p)
{
    return p->n_levels;
}

/* Log-spaced levels over the range, M frames each plus dark; the paper models get the dark
 * frame as their dark-end reference (level 0), as `wdrctl calibrate` does. */
static int acquire_log(const study *s, const study_point *p, const wdr_cal_source *src, calib *c, char *err, int errlen)
{
    double amps[WDR_CAL_MAX_LEVELS];
    int n = levels_needed(p);
    for (int k = 0; k < n; k++)
        amps[k] = s->range_lo * pow(s->range_hi / s->range_lo, (double)k / (n - 1));
    c->levels_acquired = n;
    int rc = wdr_cal_acquire(src, amps, n, p->frames_cal, 1, NULL, NULL, &c->lv, err, errlen);
    if (rc || !c->cfg.use_dark_ref)
        return rc;
    int idx[WDR_CAL_MAX_LEVELS];
    idx[0] = -1;
    for (int k = 0; k < n; k++)
        idx[k + 1] = k;
    wdr_cal_levels with_dark;
    if ((rc = wdr_cal_levels_subset(&c->lv, idx, n + 1, &with_dark)))
        return rc;
    with_dark.dark = c->lv.dark, c->lv.dark = NULL;
    wdr_cal_levels_free(&c->lv);
    c->lv = with_dark;
    return WDR_OK;
}

/* A grid of 6 levels per decade, M frames each, and the subset that minimises the worst contrast
 * error (wdr_cal_select_currents); the board captures the whole grid. */
static int acquire_select(const study *s, const study_point *p, const wdr_cal_source *src, calib *c, char *err,
                          int errlen)
{
    double amps[WDR_CAL_MAX_LEVELS];
    int n = (int)floor(log10(s->range_hi / s->range_lo) * 6 + 1e-9) + 1;
    n = n > WDR_CAL_MAX_LEVELS - 1 ? WDR_CAL_MAX_LEVELS - 1 : n;
    for (int k = 0; k < n; k++)
        amps[k] = s->range_lo * pow(s->range_hi / s->range_lo, (double)k / (n - 1));
    wdr_cal_levels grid;
    wdr_cal_choice ch;
    c->levels_acquired = n;
    int rc = wdr_cal_acquire(src, amps, n, p->frames_cal, 1, NULL, NULL, &grid, err, errlen);
    if (!rc)
        rc = wdr_cal_select_currents(&grid, &c->cfg, levels_needed(p), s->range_lo, s->range_hi, 256, &ch, err, errlen);
    if (!rc && (rc = wdr_cal_levels_from_choice(&grid, &ch, &c->lv)) == WDR_OK)
        grid.dark = NULL; /* now owned by c->lv */
    wdr_cal_levels_free(&grid);
    return rc;
}

/* IEEE binary16 rounding of a float32 coefficient (11 significant bits, finite range 65504). */
static int round_half(float *v)
{
    int e;
    double m = frexp(*v, &e);
    if (e < -13) /* subnormal half: a fixed step of 2^-24 */
        *v = (float)(ldexp(nearbyint(ldexp(*v, 24)), -24));
    else
        *v = (float)ldexp(nearbyint(ldexp(m, 11)), e - 11);
    return fabsf(*v) <= 65504.0f;
}

/* Coefficients at the point's precision, rounded in the parsed table the kernel reads. */
static int round_coefficients(calib *c, int bits)
{
    if (bits >= 32 || wdr_cal_form_compact(c->tab.h.form)) /* COMPACT, SHIFTED: int16 already */
        return 1;
    for (int row = 0; row < c->tab.h.height; row++)
        for (int k = 0; k < c->tab.h.n_coeffs; k++) {
            float *co = (float *)wdr_cal_row_coeffs(&c->tab, row, k);
            for (int x = 0; x < c->tab.h.width; x++)
                if (!round_half(&co[x]))
                    return 0;
        }
    return 1;
}

static int calibrate(const study *s, const study_point *p, study_chip *chip, calib *c, study_result *r)
{
    char err[160];
    wdr_cal_simsrc ss = {chip->sim, 1, 1000};
    wdr_cal_source src = {chip->b.width, chip->b.height, wdr_cal_sim_capture, &ss};
    wdr_cal_config_defaults(&c->cfg, p->model);
    c->cfg.form = p->form;
    if (p->n_coeffs)
        c->cfg.n_coeffs = p->n_coeffs;
    if (wdr_cal_form_compact((uint16_t)p->form))
        c->cfg.n_coeffs = WDR_CAL_COMPACT_COEFFS;
    c->cfg.raw_max = (1u << p->adc_bits) - 1u;
    c->cfg.out_max = (uint16_t)c->cfg.raw_max;
    c->cfg.range_lo = s->range_lo, c->cfg.range_hi = s->range_hi;
    const wdr_board *b = &chip->b;
    int rc =
        wdr_cal_design_init(&c->design, b, p->op, chip->t_ramp_s, b->height / 2 * b->row_time_s, 1, err, sizeof err);
    if (rc)
        return snprintf(r->why, sizeof r->why, "designed response: %s", err), rc;
    c->cfg.design = &c->design;
    rc = p->levels_choice == STUDY_LEVELS_SELECT ? acquire_select(s, p, &src, c, err, sizeof err)
                                                 : acquire_log(s, p, &src, c, err, sizeof err);
    if (rc)
        return snprintf(r->why, sizeof r->why, "acquisition: %s", err), rc;
    /* The shared forms learn their basis from at most 512 pixels: a fixed cost per calibration, so
     * the per-megapixel figure must not spread it over the few pixels of a study-sized array. Each
     * part is timed on its own interval of this very calibration: a learning timed apart and
     * subtracted from the total came out negative on small chips (issue 21). */
    double t0 = cpu_s();
    if ((rc = wdr_cal_fit_array(&c->lv, &c->cfg, &c->res, err, sizeof err)))
        return snprintf(r->why, sizeof r->why, "fit: %s", err), rc;
    double t1 = cpu_s();
    wdr_basis basis;
    if ((rc = wdr_cal_table_basis(&c->res, &basis, err, sizeof err)))
        return snprintf(r->why, sizeof r->why, "table: %s", err), rc;
    double t2 = cpu_s();
    rc = wdr_cal_build_table_with(&c->res, &basis, chip->b.sensor_id, chip->op.id, &c->table, &c->table_len, err,
                                  sizeof err);
    double t3 = cpu_s();
    wdr_cal_basis_free(&basis);
    if (rc)
        return snprintf(r->why, sizeof r->why, "table: %s", err), rc;
    r->fit_s_per_mp = ((t1 - t0) + (t3 - t2)) / ((double)chip->b.width * chip->b.height) * 1e6 + (t2 - t1);
    if ((rc = wdr_cal_parse(c->table, c->table_len, &c->tab)))
        return snprintf(r->why, sizeof r->why, "built table does not parse: %s", wdr_strerror(rc)), rc;
    if (!round_coefficients(c, p->coeff_bits))
        return snprintf(r->why, sizeof r->why, "a coefficient exceeds the half-float range"), WDR_E_NUMERIC;
    r->levels_used = c->res.model == WDR_MODEL_SIMPLE3 || c->res.model == WDR_MODEL_COMPLEX4 ? c->lv.n - 1 : c->lv.n;
    r->flagged_frac = (double)c->res.n_bad / ((double)chip->b.width * chip->b.height);
    return WDR_OK;
}

static void calib_free(calib *c)
{
    wdr_cal_levels_free(&c->lv);
    wdr_cal_result_free(&c->res);
    free(c->table);
}

/* ---- judging (the metrics of cal_metrics.h) ---- */

typedef struct judge {
    long np;
    float *frame, *acc;
    double *x_fpn, *x_tot;
    double fpn[N_EVAL], tot[N_EVAL], floor_pct[N_EVAL];
    long off1, readings;
    wdr_display_map display;
} judge;

/* Median code of the array, analog (no ADC or DAC steps, no temporal noise), at current x. */
static int median_code(study_chip *chip, double x, float *frame, long np, double *out)
{
    int rc = wdr_sim_set_uniform(chip->sim, x);
    if (!rc)
        rc = wdr_sim_render_float(chip->sim, 5, frame);
    if (rc)
        return rc;
    double lo = INFINITY, hi = -INFINITY;
    for (long i = 0; i < np; i++)
        lo = fmin(lo, frame[i]), hi = fmax(hi, frame[i]);
    for (int it = 0; it < 60; it++) { /* bisection on the value: the median without a copy */
        double mid = 0.5 * (lo + hi);
        long below = 0;
        for (long i = 0; i < np; i++)
            below += frame[i] <= mid;
        *(below >= np / 2 ? &hi : &lo) = mid;
    }
    *out = hi;
    return WDR_OK;
}

/* The quantisation floor at x (wdr_quant_floor_pct): one ADC code and one DAC step, as ADC codes
 * through the source follower, over the array's response slope |dy/d ln x| measured on the chip
 * (median pixel, analog, +-5 % in current), not taken from the model under test. */
static int quant_floor(study_chip *chip, const study_point *p, double x, float *frame, long np, double *total,
                       double *adc_only)
{
    wdr_sim_set_effect(chip->sim, WDR_FX_ADC_QUANT, WDR_FX_OFF);
    wdr_sim_set_effect(chip->sim, WDR_FX_DAC_QUANT, WDR_FX_OFF);
    double y0, y1, h = log(1.05);
    int rc = median_code(chip, x / 1.05, frame, np, &y0);
    if (!rc)
        rc = median_code(chip, x * 1.05, frame, np, &y1);
    wdr_sim_set_effect(chip->sim, WDR_FX_ADC_QUANT, WDR_FX_ON);
    wdr_sim_set_effect(chip->sim, WDR_FX_DAC_QUANT, WDR_FX_ON);
    if (rc)
        return rc;
    const wdr_board *b = &chip->b;
    double slope = fmax(fabs(y1 - y0) / (2 * h), 1e-9);
    double adc_lsb_v = (b->adc_hi_v - b->adc_lo_v) / ((1u << b->adc_bits) - 1u);
    double dac_v = (b->dac_hi_v - b->dac_lo_v) / ((1u << b->dac_bits) - 1u);
    if (p->timing == WDR_TIMING_UNIFORM) /* a clock tick moves the ramp by its mean step at least */
        dac_v = fmax(dac_v, chip->ramp_span_v / b->dac_uniform_entries);
    *total = wdr_quant_floor_pct(slope, dac_v * chip->sf_gain * b->adc_gain / adc_lsb_v);
    *adc_only = wdr_quant_floor_pct(slope, 0);
    return WDR_OK;
}

/* One frame at x without temporal noise, and the image of M noisy frames averaged. */
static int images_at(study_chip *chip, const study_point *p, double x, int k, judge *j)
{
    wdr_cal_simsrc ss = {chip->sim, 1, FRAME_SEED_EVAL + (uint64_t)k * 8192};
    set_temporal(chip->sim, 0);
    int rc = wdr_cal_sim_capture(&ss, x, 0, j->frame);
    set_temporal(chip->sim, 1);
    memset(j->acc, 0, sizeof(float) * (size_t)j->np);
    float *one = j->acc + j->np;
    for (int m = 0; !rc && m < p->frames_img; m++) {
        rc = wdr_cal_sim_capture(&ss, x, 1 + m, one);
        for (long i = 0; !rc && i < j->np; i++)
            j->acc[i] += one[i] / (float)p->frames_img;
    }
    return rc;
}

static double sd(double s1, double s2, long n)
{
    return n > 1 ? sqrt(fmax(0, (s2 - s1 * s1 / n) / (n - 1))) : 0;
}

/* The temporal part, study-specific: the simulator can show the same chip without temporal
 * noise, so the part is measured directly, 100 * sd of ln(x_tot / x_fpn), rather than inferred
 * from two noisy frames (wdr_total_error_of does that for boards). */
static double temporal_part(const judge *j)
{
    double t1 = 0, t2 = 0;
    long n = 0;
    for (long i = 0; i < j->np; i++)
        if (j->x_fpn[i] > 0 && j->x_tot[i] > 0 && isfinite(j->x_fpn[i]) && isfinite(j->x_tot[i])) {
            double t = log(j->x_tot[i] / j->x_fpn[i]);
            t1 += t, t2 += t * t, n++;
        }
    return 100 * sd(t1, t2, n);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(const double *v, int n)
{
    double s[N_EVAL];
    memcpy(s, v, sizeof(double) * (size_t)n);
    qsort(s, (size_t)n, sizeof *s, cmp_double);
    return n % 2 ? s[n / 2] : 0.5 * (s[n / 2 - 1] + s[n / 2]);
}

/* Every figure at one current x. */
static int judge_at(const study *s, const study_point *p, study_chip *chip, calib *c, judge *j, int k, study_result *r)
{
    double x = s->range_lo * pow(s->range_hi / s->range_lo, (k + 0.37) / N_EVAL), fl, fa;
    const wdr_nominal *nom = &c->res.nominal;
    wdr_contrast cf, ct;
    wdr_display_error de;
    int rc = images_at(chip, p, x, k, j);
    if (!rc)
        rc = wdr_fpn_recover(&c->res, &c->tab, WDR_PATH_TABLE, j->frame, c->res.flags, j->x_fpn);
    if (!rc)
        rc = wdr_fpn_recover(&c->res, &c->tab, WDR_PATH_TABLE, j->acc, c->res.flags, j->x_tot);
    if (!rc)
        rc = quant_floor(chip, p, x, j->frame, j->np, &fl, &fa);
    if (rc)
        return rc;
    wdr_contrast_of(j->x_fpn, j->np, x, nom->x_lo, nom->x_hi, &cf);
    wdr_contrast_of(j->x_tot, j->np, x, nom->x_lo, nom->x_hi, &ct);
    wdr_display_error_of(j->x_tot, j->np, x, &j->display, &de);
    j->fpn[k] = cf.sd_pct, j->tot[k] = ct.sd_pct, j->floor_pct[k] = fl;
    j->off1 += lround(de.frac_over_1 * de.used), j->readings += de.used;
    if (fl > r->floor_pct)
        r->floor_pct = fl, r->floor_adc_pct = fa;
    r->worst_fpn_pct = fmax(r->worst_fpn_pct, cf.sd_pct);
    r->worst_total_pct = fmax(r->worst_total_pct, ct.sd_pct);
    r->worst_temporal_pct = fmax(r->worst_temporal_pct, temporal_part(j));
    r->display_levels = fmax(r->display_levels, de.rms_levels);
    r->beyond_frac = fmax(r->beyond_frac, ct.beyond_frac);
    return WDR_OK;
}

static int judge_point(const study *s, const study_point *p, study_chip *chip, calib *c, study_result *r)
{
    judge j = {.np = (long)chip->b.width * chip->b.height,
               .display = {.op = chip->op, .lum_per_amp = chip->b.lum_per_amp, .gamma = DISPLAY_GAMMA}};
    j.frame = malloc(sizeof(float) * (size_t)j.np), j.acc = malloc(2 * sizeof(float) * (size_t)j.np);
    j.x_fpn = malloc(sizeof(double) * (size_t)j.np), j.x_tot = malloc(sizeof(double) * (size_t)j.np);
    int rc = j.frame && j.acc && j.x_fpn && j.x_tot ? WDR_OK : WDR_E_NOMEM;
    for (int k = 0; !rc && k < N_EVAL; k++)
        rc = judge_at(s, p, chip, c, &j, k, r);
    if (!rc) {
        r->median_fpn_pct = median(j.fpn, N_EVAL), r->median_total_pct = median(j.tot, N_EVAL);
        r->floor_median_pct = median(j.floor_pct, N_EVAL);
        r->display_off1_frac = j.readings ? (double)j.off1 / (double)j.readings : NAN;
    } else
        snprintf(r->why, sizeof r->why, "judging: %s", wdr_strerror(rc));
    free(j.frame), free(j.acc), free(j.x_fpn), free(j.x_tot);
    return rc;
}

/* ---- measured cost: the correction kernel here ---- */

static double correct_ns_per_pixel(const study_chip *chip, const calib *c)
{
    const wdr_board *b = &chip->b;
    long np = (long)b->width * b->height, reps = 0;
    float *in = malloc(sizeof(float) * (size_t)np), *out = malloc(sizeof(float) * (size_t)np);
    if (!in || !out)
        return free(in), free(out), NAN;
    memcpy(in, c->lv.frames, sizeof(float) * (size_t)np);
    double t0 = cpu_s(), t;
    do {
        for (int row = 0; row < b->height; row++)
            wdr_correct_row_f32(&c->tab, row, in + (long)row * b->width, out + (long)row * b->width);
        reps++;
    } while ((t = cpu_s() - t0) < 0.01);
    free(in), free(out);
    return t / ((double)reps * np) * 1e9;
}

/* ---- the point ---- */

static void table_costs(const study *s, const study_point *p, const study_chip *chip, const calib *c, study_result *r)
{
    const wdr_board *full = &chip->full;
    int n = c->tab.h.n_coeffs;
    uint32_t shared = wdr_cal_shared_bytes(&c->tab.h);
    double coeff_bytes = p->coeff_bits / 8.0;
    if (wdr_cal_form_compact(c->tab.h.form))
        coeff_bytes = 2;                /* int16 coefficients */
    r->table_bpp = n * coeff_bytes + 1; /* coefficient planes and one flag byte per pixel */
    size_t header = wdr_cal_size(1, 1, 0) - wdr_cal_row_stride(1, 0);
    r->table_bytes = (double)header + shared + (double)full->width * full->height * r->table_bpp;
    r->bandwidth_Bps = r->table_bytes * s->fps;
    r->bus_Bps = full->table_bus_mbps * 1e6;
    r->bus_feeds = !(r->bus_Bps > 0) || r->bandwidth_Bps <= r->bus_Bps;
    r->correct_ns_px = correct_ns_per_pixel(chip, c);
    study_m7_for(c->tab.h.form, n, &r->m7_instr_px, &r->m7_row_px);
}

void study_eval_point(const study *s, const study_point *p, study_result *r)
{
    double t0 = now_s();
    char err[160];
    study_chip chip;
    calib c;
    memset(r, 0, sizeof *r);
    memset(&c, 0, sizeof c);
    int rc = study_chip_open(s, p, &chip, err, sizeof err);
    if (rc)
        snprintf(r->why, sizeof r->why, "chip: %s", err);
    if (!rc)
        rc = calibrate(s, p, &chip, &c, r);
    if (!rc)
        rc = judge_point(s, p, &chip, &c, r);
    if (!rc) {
        study_frame_time(&chip.full, p->adc_bits, chip.t_ramp_s, r);
        r->image_s = p->frames_img * r->frame_s;
        r->cal_s = study_cal_time(r, c.levels_acquired, p->frames_cal);
        table_costs(s, p, &chip, &c, r);
        r->adc_lo_v = chip.b.adc_lo_v, r->adc_hi_v = chip.b.adc_hi_v;
        r->dac_lo_v = chip.b.dac_lo_v, r->dac_hi_v = chip.b.dac_hi_v;
    }
    r->ok = rc == WDR_OK;
    calib_free(&c);
    study_chip_close(&chip);
    r->eval_s = now_s() - t0;
}
