/* wdrctl fpn report: the FPN figures of every model on the simulated chip, under three
 * conditions side by side: analog (converters off, no temporal noise), the board's converters with
 * temporal noise averaged away, and the default (converters and temporal noise on, the frames the
 * calibration averages). Contrast error before and after with the quantisation floor beside it,
 * display-space error per decade, total error (FPN plus temporal), model error, DSNU/PRNU,
 * histograms and test images (the paper's Fig. 4-8). The figures come from host/cal/metrics/cal_metrics.h,
 * as `wdrctl calibrate --json` and the benchmarks. */
#include "cal_common.h"
#include "correct.h"
#include "image_io.h"
#include "operators.h"
#include "plot.h"
#include "wdr_err.h"
#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---- wdrctl fpn report ---- */

enum { COND_ANALOG, COND_CONVERTERS, COND_DEFAULT, N_COND };
#define N_DECADES 8

typedef struct cond_spec {
    const char *name;  /* JSON key */
    const char *label; /* what holds: printed beside every figure of the condition */
    int adc, dac, noise;
} cond_spec;

static const cond_spec cond_specs[N_COND] = {
    {"analog", "analog: ADC and DAC quantisation off, temporal noise off", 0, 0, 0},
    {"converters_averaged", "ADC and DAC on, temporal noise averaged away (off)", 1, 1, 0},
    {"default", "default: ADC and DAC on, temporal noise on", 1, 1, 1},
};

typedef struct model_report {
    int model;
    cal_run run;
    wdr_cal_view tab;
    wdr_eval_point pt[N_EVAL];
    double worst_model, worst_table, worst_at, worst_floor_ratio, worst_total_1;
    double err_max_mv, err_median_mv;
    wdr_display_error dec[N_DECADES];
    int n_dec;
} model_report;

typedef struct condition {
    const cond_spec *spec;
    cal_opts o; /* the report's options with this condition's converters, noise and frames */
    sim_chip chip;
    wdr_cal_source src;
    wdr_cal_levels grid;
    double lo, hi;
    model_report m[WDR_MODEL_COUNT];
} condition;

typedef struct report {
    cal_opts o;
    wdr_board b;
    double lo, hi, eval[N_EVAL], lsb_mv;
    wdr_display_map display;
    int models[WDR_MODEL_COUNT], n_models, primary;
    condition c[N_COND];
} report;

static double codes_to_mv(const wdr_board *b)
{
    return 1e3 * (b->adc_hi_v - b->adc_lo_v) / ((1u << b->adc_bits) - 1u) / (b->adc_gain > 0 ? b->adc_gain : 1);
}

static int calibrate_model(report *rp, condition *c, model_report *m)
{
    char err[512];
    cal_run *r = &m->run;
    wdr_cal_config_defaults(&r->cfg, m->model);
    cal_set_output(&c->o, &r->cfg, (unsigned)rp->b.adc_bits);
    r->cfg.range_lo = c->lo, r->cfg.range_hi = c->hi;
    r->cfg.tie_codes = c->o.adc ? r->cfg.tie_codes : 1e-3;
    r->cfg.design = &c->chip.design;
    r->lo = c->lo, r->hi = c->hi;
    if (wdr_cal_select_currents(&c->grid, &r->cfg, cal_default_currents(m->model), c->lo, c->hi, c->o.sample,
                                &r->choice, err, sizeof err))
        return wdrctl_fail(EX_DATAERR, "fpn report: %s, %s: %s", c->spec->name, cal_model_name(m->model), err);
    int rc = cal_acquire_and_fit(&c->o, &c->src, r, rp->b.sensor_id, 0);
    if (rc != EX_OK || wdr_cal_parse(r->table, r->table_len, &m->tab))
        return rc != EX_OK ? rc : wdrctl_fail(EX_SOFTWARE, "fpn report: built table does not parse");
    return EX_OK;
}

/* Model error over the grid levels in range, in mV. */
static int model_error(report *rp, condition *c, model_report *m)
{
    int idx[WDR_CAL_MAX_LEVELS], n = 0;
    for (int k = 0; k < c->grid.n; k++)
        if (c->grid.amps[k] >= c->lo && c->grid.amps[k] <= c->hi)
            idx[n++] = k;
    wdr_cal_levels in_range;
    if (wdr_cal_levels_subset(&c->grid, idx, n, &in_range))
        return wdrctl_fail(EX_OSERR, "out of memory");
    wdr_model_error(&m->run.res, in_range.frames, in_range.amps, n, m->run.res.flags, &m->err_max_mv,
                    &m->err_median_mv);
    m->err_max_mv *= rp->lsb_mv, m->err_median_mv *= rp->lsb_mv;
    wdr_cal_levels_free(&in_range);
    return EX_OK;
}

static void summarise(const report *rp, const condition *c, model_report *m)
{
    const model_report *analog = &rp->c[COND_ANALOG].m[m - c->m];
    wdr_display_error per[N_EVAL];
    m->worst_model = m->worst_table = m->worst_floor_ratio = m->worst_total_1 = 0;
    for (int k = 0; k < N_EVAL; k++) {
        const wdr_eval_point *p = &m->pt[k];
        m->worst_model = fmax(m->worst_model, p->model.sd_pct);
        if (p->table.sd_pct > m->worst_table)
            m->worst_table = p->table.sd_pct, m->worst_at = p->x;
        m->worst_total_1 = fmax(m->worst_total_1, p->total.total_1_pct);
        if (c->o.adc && !c->o.noise) /* the model's own floor: its analog error and the converters' */
            m->worst_floor_ratio =
                fmax(m->worst_floor_ratio, p->table.sd_pct / hypot(analog->pt[k].table.sd_pct, p->floor_pct));
        per[k] = p->display;
    }
    m->n_dec = wdr_display_by_decade(per, N_EVAL, m->dec, N_DECADES);
}

static double f_left_model(const wdr_eval_point *p);
static double f_left_table(const wdr_eval_point *p);

/* The most pixels any printed figure of the model left out, over the judging currents. */
static double most_left_out(const model_report *m)
{
    double most = 0;
    for (int k = 0; k < N_EVAL; k++)
        most = fmax(most, fmax(f_left_model(&m->pt[k]), f_left_table(&m->pt[k])));
    return most;
}

static int evaluate_model(report *rp, condition *c, model_report *m)
{
    wdr_eval_opts eo = {.frames = c->o.frames,
                        .temporal = c->o.noise,
                        .quantised = c->o.adc,
                        .display = &rp->display,
                        .design = &c->chip.design};
    for (int k = 0; k < N_EVAL; k++) {
        eo.first_frame_no = 1000000 + 64 * k;
        if (wdr_eval_point_measure(&m->run.res, &m->tab, &c->src, rp->eval[k], &eo, &m->pt[k]))
            return wdrctl_fail(EX_IOERR, "fpn report: evaluation frames at %.3g A failed", rp->eval[k]);
    }
    summarise(rp, c, m);
    int rc = model_error(rp, c, m);
    fprintf(stderr, "fpn report: %s, %s: worst contrast error %.3g %% (table) at %.3g A, %.3g %% (model)",
            cal_model_name(m->model), c->spec->label, m->worst_table, m->worst_at, m->worst_model);
    fprintf(stderr, " (leaving out at most %.0f of %ld pixels: %ld flagged, the rest unresolved)", most_left_out(m),
            (long)m->run.res.width * m->run.res.height, m->run.res.n_bad);
    if (c->o.noise)
        fprintf(stderr, "; one frame with temporal noise %.3g %%, %d frames averaged", m->worst_total_1, c->o.frames);
    if (c->o.adc && !c->o.noise)
        fprintf(stderr, "; %.2fx its floor", m->worst_floor_ratio);
    char kinds[160];
    fprintf(stderr, "; %ld pixels flagged (%s)\n", m->run.res.n_bad,
            wdr_cal_flag_counts_text(m->run.res.n_flag, kinds, sizeof kinds));
    return rc;
}

static int run_condition(report *rp, condition *c)
{
    int rc = EX_OK;
    for (int i = 0; rc == EX_OK && i < rp->n_models; i++) {
        c->m[i].model = rp->models[i];
        rc = calibrate_model(rp, c, &c->m[i]);
    }
    for (int i = 0; rc == EX_OK && i < rp->n_models; i++)
        rc = evaluate_model(rp, c, &c->m[i]);
    return rc;
}

/* ---- plots (gnuplot) ---- */

#define CONTRAST_FLOOR_PCT 0.01 /* the y axis's floor: smaller errors are drawn on it, marked */
#define STYLE_BEFORE 8          /* plot.h styles that no model id (firmware/wdr_cal.h) takes */
#define STYLE_QUANT_FLOOR 9

/* Columns: x, then per condition: before, beyond fraction (%), floor, then per model table and model. */
static int write_contrast_data(const report *rp, const char *dir, char *path, size_t cap)
{
    snprintf(path, cap, "%.900s/contrast.dat", dir);
    FILE *f = fopen(path, "w");
    if (!f)
        return WDR_E_IO;
    for (int k = 0; k < N_EVAL; k++) {
        fprintf(f, "%g", rp->eval[k]);
        for (int c = 0; c < N_COND; c++) {
            const wdr_eval_point *p = &rp->c[c].m[0].pt[k];
            fprintf(f, " %g %g %g", p->before.sd_pct, 100 * p->before.beyond_frac, p->floor_pct);
            for (int i = 0; i < rp->n_models; i++)
                fprintf(f, " %g %g", rp->c[c].m[i].pt[k].table.sd_pct, rp->c[c].m[i].pt[k].model.sd_pct);
        }
        fputc('\n', f);
    }
    return fclose(f) ? WDR_E_IO : WDR_OK;
}

static int condition_panel(const report *rp, int c, const char *data, char *script, size_t cap)
{
    int per = 3 + 2 * rp->n_models, base = 2 + c * per;
    const condition *cd = &rp->c[c];
    char frames[64] = "";
    if (cd->o.noise)
        snprintf(frames, sizeof frames, ", %d frames averaged", cd->o.frames);
    int n = snprintf(script, cap, "set title \"%s%s\" noenhanced\n", cd->spec->label, frames);
    n += snprintf(script + n, cap - (size_t)n, "plot 1 w l dt 2 lc rgb 'black' t '1 %% (eye)'");
    /* every series in its own fixed style (plot.h), the same in every panel; below the axis at the floor */
    n += wdr_plot_floored_series(script + n, cap - (size_t)n, data, base, STYLE_BEFORE,
                                 "before: sd of ln(x_hat/x)", CONTRAST_FLOOR_PCT);
    if (cd->o.adc)
        n += wdr_plot_floored_series(script + n, cap - (size_t)n, data, base + 2, STYLE_QUANT_FLOOR,
                                     "quantisation floor", CONTRAST_FLOOR_PCT);
    for (int i = 0; i < rp->n_models; i++) {
        char title[64];
        snprintf(title, sizeof title, "%s (table)", cal_model_name(rp->models[i]));
        n += wdr_plot_floored_series(script + n, cap - (size_t)n, data, base + 3 + 2 * i, rp->models[i], title,
                                     CONTRAST_FLOOR_PCT);
    }
    n += wdr_plot_floor_key(script + n, cap - (size_t)n, CONTRAST_FLOOR_PCT, "%");
    return n + snprintf(script + n, cap - (size_t)n, "\n");
}

static int plot_contrast(const report *rp, const char *dir)
{
    char data[1024], script[16384], err[512];
    if (write_contrast_data(rp, dir, data, sizeof data))
        return wdrctl_fail(EX_CANTCREAT, "%s: cannot write plot data", data);
    int n =
        snprintf(script, sizeof script,
                 "set terminal pngcairo size 1800,600 noenhanced\nset output '%s/fpn_contrast.png'\nset logscale xy\n"
                 "set multiplot layout 1,3 title 'FPN contrast error before and after correction (%s, %s)'\n"
                 "set xlabel 'photocurrent (A)'\nset ylabel 'contrast error (%%, sd across pixels)'\n"
                 "set yrange [%g:1000]\nset grid\nset key top center font ',9'\n",
                 rp->o.outdir, rp->o.op_name, rp->b.name, CONTRAST_FLOOR_PCT);
    for (int c = 0; c < N_COND; c++)
        n += condition_panel(rp, c, data, script + n, sizeof script - (size_t)n);
    snprintf(script + n, sizeof script - (size_t)n, "unset multiplot\n");
    int rc = wdr_gnuplot_run(script, err, sizeof err);
    return rc ? wdrctl_fail(rc == WDR_E_UNSUPPORTED ? EX_UNAVAILABLE : EX_SOFTWARE, "fpn report: %s", err) : EX_OK;
}

/* Per-pixel contrast error 100 ln(x_hat/x) at 1e-11 A before and after (the first model's table,
 * the primary condition), histogrammed. */
static int histogram_data(const report *rp, const char *path, wdr_contrast *sb, wdr_contrast *sa)
{
    const condition *pc = &rp->c[rp->primary];
    const model_report *m = &pc->m[0];
    long np = (long)rp->b.width * rp->b.height;
    float *frame = malloc(sizeof(float) * (size_t)np);
    double *eb = malloc(sizeof(double) * (size_t)np), *ea = malloc(sizeof(double) * (size_t)np);
    const double x = 1e-11, lo = m->run.res.nominal.x_lo, hi = m->run.res.nominal.x_hi;
    int rc = !frame || !eb || !ea ? WDR_E_NOMEM : pc->src.capture(pc->src.ctx, x, 2000000, frame);
    if (!rc)
        rc = wdr_fpn_recover(&m->run.res, NULL, WDR_PATH_RAW, frame, NULL, eb);
    if (!rc)
        rc = wdr_fpn_recover(&m->run.res, &m->tab, WDR_PATH_TABLE, frame, m->run.res.flags, ea);
    if (!rc) {
        wdr_contrast_of(eb, np, x, lo, hi, sb);
        wdr_contrast_of(ea, np, x, lo, hi, sa);
    }
    FILE *f = rc ? NULL : fopen(path, "w");
    for (long i = 0; f && i < np; i++)
        if (eb[i] > 0 && ea[i] > 0 && isfinite(eb[i]) && isfinite(ea[i]))
            fprintf(f, "%g %g\n", 100 * log(eb[i] / x), 100 * log(ea[i] / x));
    if (f && fclose(f))
        rc = WDR_E_IO;
    free(frame), free(eb), free(ea);
    return rc ? rc : f ? WDR_OK : WDR_E_IO;
}

static int plot_histograms(report *rp, const char *dir, double *before_sd, double *after_sd)
{
    char path[1024], script[4096], err[512];
    wdr_contrast sb, sa;
    snprintf(path, sizeof path, "%.900s/hist.dat", dir);
    if (histogram_data(rp, path, &sb, &sa))
        return wdrctl_fail(EX_SOFTWARE, "fpn report: histogram data failed");
    *before_sd = sb.sd_pct, *after_sd = sa.sd_pct;
    snprintf(
        script, sizeof script,
        "set terminal pngcairo size 1000,420\nset output '%s/fpn_histograms_1e-11.png'\nset multiplot layout 1,2 "
        "title \"%s\" noenhanced\nset style fill solid 0.6\nset xlabel '100 ln(x_hat/x) (%%)' noenhanced\nset ylabel 'pixels'\n"
        "bw=%g\nbin(x)=bw*floor(x/bw)\nset title 'before correction, 1e-11 A (sd %.3g %%)'\n"
        "plot '%s' u (bin($1)):(1) smooth freq w boxes notitle\nbw=%g\n"
        "set title 'after (%s, float32 table; sd %.3g %%)'\nplot '%s' u (bin($2)):(1) smooth freq w boxes notitle\n"
        "unset multiplot\n",
        rp->o.outdir, rp->c[rp->primary].spec->label, fmax(sb.sd_pct / 8, 1e-6), sb.sd_pct, path,
        fmax(sa.sd_pct / 8, 1e-6), cal_model_name(rp->models[0]), sa.sd_pct, path);
    int rc = wdr_gnuplot_run(script, err, sizeof err);
    return rc ? wdrctl_fail(EX_SOFTWARE, "fpn report: %s", err) : EX_OK;
}

/* ---- test image: a six-decade wedge with bars, raw (with FPN) and corrected ---- */

static void test_scene(const wdr_board *b, float *amps)
{
    for (int y = 0; y < b->height; y++)
        for (int x = 0; x < b->width; x++) {
            double decades = 6.0 * x / (b->width - 1), bar = (y / (b->height / 6 + 1)) % 2 ? 1.0 : 0.5;
            amps[(long)y * b->width + x] = (float)(1e-14 * pow(10, decades) * bar);
        }
}

/* Brighter light is a lower code: draw it bright, over the codes the nominal spans. */
static void to_gray8(const float *codes, long np, double lo, double hi, uint16_t *px)
{
    for (long i = 0; i < np; i++) {
        double v = (hi - codes[i]) / (hi - lo);
        px[i] = (uint16_t)lround(255 * fmin(fmax(v, 0), 1));
    }
}

/* The frame of the photocurrent map already set, quantised as the chip's source is. */
static int render_map(sim_chip *c, const wdr_board *b, float *out)
{
    long np = (long)b->width * b->height;
    if (!c->ss.quantised)
        return wdr_sim_render_float(c->sim, 3000000, out);
    uint16_t *codes = malloc(sizeof(uint16_t) * (size_t)np);
    int rc = codes ? wdr_sim_render(c->sim, 3000000, codes) : WDR_E_NOMEM;
    for (long i = 0; !rc && i < np; i++)
        out[i] = codes[i];
    free(codes);
    return rc;
}

static int write_test_images(report *rp)
{
    const wdr_board *b = &rp->b;
    long np = (long)b->width * b->height;
    float *amps = malloc(sizeof(float) * (size_t)np), *raw = malloc(sizeof(float) * (size_t)np);
    float *corr = malloc(sizeof(float) * (size_t)np);
    uint16_t *px = malloc(sizeof(uint16_t) * (size_t)np);
    char path[1024], err[512];
    int rc = !amps || !raw || !corr || !px ? WDR_E_NOMEM : WDR_OK;
    condition *pc = &rp->c[rp->primary];
    const model_report *m = &pc->m[0];
    double lo = wdr_nominal_eval(&m->run.res.nominal, rp->hi), hi = wdr_nominal_eval(&m->run.res.nominal, rp->lo);
    if (!rc) {
        test_scene(b, amps);
        rc = wdr_sim_set_photocurrent(pc->chip.sim, amps);
    }
    if (!rc)
        rc = render_map(&pc->chip, b, raw);
    for (int r = 0; !rc && r < b->height; r++)
        rc = wdr_correct_row_f32(&m->tab, r, raw + (long)r * b->width, corr + (long)r * b->width);
    for (long i = 0; !rc && i < np; i++)
        corr[i] /= m->tab.h.out_scale;
    if (!rc) {
        to_gray8(raw, np, lo, hi, px);
        snprintf(path, sizeof path, "%.900s/test_image_fpn.png", rp->o.outdir);
        rc = wdr_png_write_gray(path, px, b->width, b->height, 8, err, sizeof err);
    }
    if (!rc) {
        to_gray8(corr, np, lo, hi, px);
        snprintf(path, sizeof path, "%.900s/test_image_corrected_%s.png", rp->o.outdir, cal_model_name(m->model));
        rc = wdr_png_write_gray(path, px, b->width, b->height, 8, err, sizeof err);
    }
    free(amps), free(raw), free(corr), free(px);
    return rc ? wdrctl_fail(EX_CANTCREAT, "fpn report: test image: %s", rc == WDR_E_IO ? err : wdr_strerror(rc))
              : EX_OK;
}

/* ---- EMVA 1288 style nonuniformity, before and after ---- */

typedef struct emva {
    double dsnu_mv, prnu_pct, dsnu_after_mv, prnu_after_pct;
} emva;

/* DSNU from the dark frame and PRNU at 1e-11 A, raw and through the first model's table. */
static int nonuniformity(report *rp, emva *e)
{
    long np = (long)rp->b.width * rp->b.height;
    const condition *pc = &rp->c[rp->primary];
    const model_report *m = &pc->m[0];
    float *lit = malloc(sizeof(float) * (size_t)np), *dark_c = malloc(sizeof(float) * (size_t)np);
    float *lit_c = malloc(sizeof(float) * (size_t)np);
    int rc = !lit || !dark_c || !lit_c ? WDR_E_NOMEM : pc->src.capture(pc->src.ctx, 1e-11, 4000000, lit);
    for (int r = 0; !rc && r < rp->b.height; r++) {
        long o = (long)r * rp->b.width;
        rc = wdr_correct_row_f32(&m->tab, r, pc->grid.dark + o, dark_c + o) ||
             wdr_correct_row_f32(&m->tab, r, lit + o, lit_c + o);
    }
    for (long i = 0; !rc && i < np; i++)
        dark_c[i] /= m->tab.h.out_scale, lit_c[i] /= m->tab.h.out_scale;
    if (!rc) {
        wdr_emva_nonuniformity(pc->grid.dark, lit, np, m->run.res.flags, &e->dsnu_mv, &e->prnu_pct);
        wdr_emva_nonuniformity(dark_c, lit_c, np, m->run.res.flags, &e->dsnu_after_mv, &e->prnu_after_pct);
        e->dsnu_mv *= rp->lsb_mv, e->dsnu_after_mv *= rp->lsb_mv;
    }
    free(lit), free(dark_c), free(lit_c);
    return rc ? wdrctl_fail(EX_SOFTWARE, "fpn report: nonuniformity frames failed") : EX_OK;
}

/* ---- JSON summary ---- */

typedef double (*point_field)(const wdr_eval_point *p);
static double f_table(const wdr_eval_point *p)
{
    return p->table.sd_pct;
}
static double f_model(const wdr_eval_point *p)
{
    return p->model.sd_pct;
}
static double f_before(const wdr_eval_point *p)
{
    return p->before.sd_pct;
}
/* Pixels each figure left out: flagged (excluded) and unresolved (no x_hat within a decade). */
static double f_left_before(const wdr_eval_point *p)
{
    return (double)(p->before.excluded + p->before.unresolved);
}
static double f_left_model(const wdr_eval_point *p)
{
    return (double)(p->model.excluded + p->model.unresolved);
}
static double f_left_table(const wdr_eval_point *p)
{
    return (double)(p->table.excluded + p->table.unresolved);
}
static double f_beyond(const wdr_eval_point *p)
{
    return p->before.beyond_frac;
}
static double f_floor(const wdr_eval_point *p)
{
    return p->floor_pct;
}
static double f_total1(const wdr_eval_point *p)
{
    return p->total.total_1_pct;
}
static double f_totalm(const wdr_eval_point *p)
{
    return p->total.total_m_pct;
}
static double f_temporal(const wdr_eval_point *p)
{
    return p->total.temporal_pct;
}
static double f_fpn(const wdr_eval_point *p)
{
    return p->total.fpn_pct;
}

static cJSON *point_array(const wdr_eval_point *pt, point_field f)
{
    double v[N_EVAL];
    for (int k = 0; k < N_EVAL; k++)
        v[k] = f(&pt[k]);
    return cJSON_CreateDoubleArray(v, N_EVAL);
}

static cJSON *display_json(const model_report *m)
{
    cJSON *a = cJSON_CreateArray();
    for (int d = 0; d < m->n_dec; d++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "from_A", m->dec[d].x_lo);
        cJSON_AddNumberToObject(o, "to_A", m->dec[d].x_hi);
        cJSON_AddNumberToObject(o, "mean_levels", m->dec[d].mean_levels);
        cJSON_AddNumberToObject(o, "mean_abs_levels", m->dec[d].mean_abs_levels);
        cJSON_AddNumberToObject(o, "rms_levels", m->dec[d].rms_levels);
        cJSON_AddNumberToObject(o, "frac_off_by_more_than_1_level", m->dec[d].frac_over_1);
        cJSON_AddItemToArray(a, o);
    }
    return a;
}

static cJSON *model_json(const condition *c, const model_report *m)
{
    cJSON *j = cJSON_CreateObject();
    const cal_run *r = &m->run;
    cJSON_AddStringToObject(j, "model", cal_model_name(m->model));
    cJSON_AddStringToObject(j, "table_form", cal_form_name(r->cfg.form));
    cJSON_AddNumberToObject(j, "table_coefficients", r->cfg.form == WDR_FORM_MOEBIUS ? 3 : r->cfg.n_coeffs);
    cJSON_AddItemToObject(j, "currents_A", cJSON_CreateDoubleArray(r->choice.amps, r->choice.n));
    cJSON_AddNumberToObject(j, "selection_worst_pct", r->choice.worst_pct);
    cJSON_AddItemToObject(j, "contrast_after_model_pct", point_array(m->pt, f_model));
    cJSON_AddItemToObject(j, "contrast_after_table_pct", point_array(m->pt, f_table));
    cJSON_AddNumberToObject(j, "worst_after_model_pct", m->worst_model);
    cJSON_AddNumberToObject(j, "worst_after_table_pct", m->worst_table);
    cJSON_AddNumberToObject(j, "worst_at_A", m->worst_at);
    if (c->o.adc && !c->o.noise)
        cJSON_AddNumberToObject(j, "worst_over_floor", m->worst_floor_ratio);
    if (c->o.noise) {
        cJSON *t = cJSON_AddObjectToObject(j, "total_error");
        cJSON_AddNumberToObject(t, "frames_averaged", c->o.frames);
        cJSON_AddItemToObject(t, "fpn_pct", point_array(m->pt, f_fpn));
        cJSON_AddItemToObject(t, "temporal_one_frame_pct", point_array(m->pt, f_temporal));
        cJSON_AddItemToObject(t, "total_one_frame_pct", point_array(m->pt, f_total1));
        cJSON_AddItemToObject(t, "total_averaged_pct", point_array(m->pt, f_totalm));
        cJSON_AddNumberToObject(t, "worst_one_frame_pct", m->worst_total_1);
    }
    cJSON_AddItemToObject(j, "display_error_per_decade", display_json(m));
    cJSON_AddNumberToObject(j, "model_error_max_mV", m->err_max_mv);
    cJSON_AddNumberToObject(j, "model_error_median_mV", m->err_median_mv);
    cJSON_AddNumberToObject(j, "paper_model_error_mV",
                            m->model == WDR_MODEL_SIMPLE3    ? 15
                            : m->model == WDR_MODEL_COMPLEX4 ? 40
                                                             : 0);
    cJSON_AddNumberToObject(j, "pixels_flagged", (double)r->res.n_bad);
    cJSON *f = cJSON_AddObjectToObject(j, "flags"); /* one kind per pixel: these add up to pixels_flagged */
    for (int b = 0; b < WDR_CAL_FLAG_KINDS; b++)
        cJSON_AddNumberToObject(f, wdr_cal_flag_name(b), (double)r->res.n_flag[b]);
    cJSON_AddItemToObject(j, "pixels_left_out_after_model", point_array(m->pt, f_left_model));
    cJSON_AddItemToObject(j, "pixels_left_out_after_table", point_array(m->pt, f_left_table));
    return j;
}

static cJSON *condition_json(const report *rp, const condition *c)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "condition", c->spec->name);
    cJSON_AddStringToObject(j, "holds_with", c->spec->label);
    cJSON_AddBoolToObject(j, "adc_quantisation", c->o.adc);
    cJSON_AddBoolToObject(j, "dac_quantisation", c->o.dac);
    cJSON_AddBoolToObject(j, "temporal_noise", c->o.noise);
    cJSON_AddNumberToObject(j, "frames_averaged", c->o.frames);
    cJSON_AddNumberToObject(j, "range_lo_A", c->lo);
    cJSON_AddNumberToObject(j, "range_hi_A", c->hi);
    cJSON_AddItemToObject(j, "contrast_before_pct", point_array(c->m[0].pt, f_before));
    cJSON_AddItemToObject(j, "pixels_left_out_before", point_array(c->m[0].pt, f_left_before));
    cJSON_AddItemToObject(j, "before_beyond_curve_frac", point_array(c->m[0].pt, f_beyond));
    cJSON_AddItemToObject(j, "quantisation_floor_pct", point_array(c->m[0].pt, f_floor));
    cJSON *models = cJSON_AddArrayToObject(j, "models");
    for (int i = 0; i < rp->n_models; i++)
        cJSON_AddItemToArray(models, model_json(c, &c->m[i]));
    return j;
}

static void add_notes(cJSON *j)
{
    cJSON_AddStringToObject(j, "contrast_note",
                            "contrast error: 100 * sd across pixels of ln(x_hat / x); x_hat from the nominal curve's "
                            "inverse of the raw code (before) or the model and its float32 table (after). Pixels "
                            "whose x_hat lies outside the calibrated range are counted in before_beyond_curve_frac "
                            "(with those more than a decade out, whose inverse is a clamp, left out of the spread). "
                            "Flagged pixels are left out of every figure after correction (and of the before figures "
                            "too): pixels_left_out_* count, per current, the flagged and unresolved pixels a figure "
                            "left out of the pixels");
    cJSON_AddStringToObject(j, "floor_note",
                            "quantisation floor: 100 * sqrt(2 (1 + s^2) / 12) / |dy/d ln x|, the ADC's rounding and a "
                            "DAC step of s ADC codes in the frame and in the calibration levels, the slope from the "
                            "designed response; worst_over_floor divides by sqrt(analog^2 + floor^2), the model's "
                            "own analog error with the converters' floor");
    cJSON_AddStringToObject(j, "display_note",
                            "display error: 8-bit display levels 255 T(k x)^(1/2.2) of x_hat against x through the "
                            "operator T, per decade of current, table path");
}

static int write_json(const report *rp, const emva *e, double hist_before, double hist_after)
{
    const condition *pc = &rp->c[rp->primary];
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "board", rp->b.name);
    cJSON_AddStringToObject(j, "operator", rp->o.op_name);
    cJSON_AddStringToObject(j, "primary_condition", pc->spec->name);
    cJSON_AddBoolToObject(j, "adc_quantisation", pc->o.adc);
    cJSON_AddBoolToObject(j, "dac_quantisation", pc->o.dac);
    cJSON_AddStringToObject(j, "temporal_noise", pc->o.noise ? "on" : "off");
    cJSON_AddNumberToObject(j, "range_lo_A", rp->lo);
    cJSON_AddNumberToObject(j, "range_hi_A", rp->hi);
    cJSON_AddItemToObject(j, "photocurrents_A", cJSON_CreateDoubleArray(rp->eval, N_EVAL));
    cJSON_AddItemToObject(j, "contrast_before_pct", point_array(pc->m[0].pt, f_before));
    cJSON_AddNumberToObject(j, "pixels", (double)rp->b.width * rp->b.height);
    cJSON_AddItemToObject(j, "pixels_left_out_before", point_array(pc->m[0].pt, f_left_before));
    add_notes(j);
    cJSON *models = cJSON_AddArrayToObject(j, "models");
    for (int i = 0; i < rp->n_models; i++)
        cJSON_AddItemToArray(models, model_json(pc, &pc->m[i]));
    cJSON *conds = cJSON_AddArrayToObject(j, "conditions");
    for (int c = 0; c < N_COND; c++)
        cJSON_AddItemToArray(conds, condition_json(rp, &rp->c[c]));
    cJSON *em = cJSON_AddObjectToObject(j, "emva1288");
    cJSON_AddNumberToObject(em, "dsnu_mV_before", e->dsnu_mv);
    cJSON_AddNumberToObject(em, "dsnu_mV_after", e->dsnu_after_mv);
    cJSON_AddNumberToObject(em, "prnu_pct_before_at_1e-11A", e->prnu_pct);
    cJSON_AddNumberToObject(em, "prnu_pct_after_at_1e-11A", e->prnu_after_pct);
    cJSON_AddNumberToObject(em, "pixels_left_out", (double)pc->m[0].run.res.n_bad); /* the first model's flags */
    cJSON_AddStringToObject(em, "note",
                            "nonlinear pixel: DSNU in mV at the ADC input, PRNU as the spread of the "
                            "signal above dark at 1e-11 A; primary condition (temporal noise off, so "
                            "no averaging needed)");
    cJSON *h = cJSON_AddObjectToObject(j, "histogram_1e-11A");
    cJSON_AddNumberToObject(h, "sd_before_pct", hist_before);
    cJSON_AddNumberToObject(h, "sd_after_pct", hist_after);
    cJSON_AddNumberToObject(h, "pixels_flagged_left_out_after", (double)pc->m[0].run.res.n_bad);
    char path[1024], *text = cJSON_Print(j);
    snprintf(path, sizeof path, "%.900s/fpn.json", rp->o.outdir);
    FILE *f = fopen(path, "w");
    int ok = f && text && fputs(text, f) >= 0;
    if (f)
        ok &= fclose(f) == 0;
    if (rp->o.json && text)
        printf("%s\n", text);
    free(text);
    cJSON_Delete(j);
    return ok ? EX_OK : wdrctl_fail(EX_CANTCREAT, "%s: cannot write the JSON summary", path);
}

/* ---- the command ---- */

static int parse_models(const char *list, report *rp)
{
    char buf[256], *save = NULL;
    snprintf(buf, sizeof buf, "%s", list ? list : "spline,simple3,complex4");
    rp->n_models = 0;
    for (char *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        if (rp->n_models >= WDR_MODEL_COUNT)
            return wdrctl_fail(EX_USAGE, "fpn report: too many models");
        int rc = cal_model_from_name(t, &rp->models[rp->n_models]);
        if (rc != EX_OK)
            return rc;
        rp->n_models++;
    }
    return EX_OK;
}

/* Frames per level of the default condition, as `wdrctl calibrate --frames auto` chooses them from a
 * probe that measured the noise (PROBE_FRAMES per level). */
static int auto_frames(condition *c)
{
    double med[WDR_CAL_MAX_LEVELS];
    wdr_cal_frames_choice why;
    if (wdr_cal_level_medians(&c->grid, NULL, med))
        return wdrctl_fail(EX_OSERR, "out of memory");
    wdr_cal_frames_for(&c->grid, med, c->lo, c->hi, c->o.adc ? 1.0 : 0.0, AUTO_FRAMES_TARGET_PCT, AUTO_FRAMES_MAX,
                       &why);
    c->o.frames = why.frames;
    fprintf(stderr, "fpn report: %s: %d frames per level (--frames auto: temporal noise %.3g codes at %.3g A)\n",
            c->spec->name, why.frames, why.sigma_codes, why.at_amps);
    return EX_OK;
}

/* A chip for condition c: the report's options with the condition's converters and noise; its probe
 * grid (one frame without noise, exact; with noise the frames asked for, or two to measure it). */
static int open_condition(report *rp, condition *c, int which)
{
    char err[512];
    double amps[WDR_CAL_MAX_LEVELS];
    int n, rc;
    c->spec = &cond_specs[which];
    c->o = rp->o;
    c->o.adc = c->spec->adc, c->o.dac = c->spec->dac, c->o.noise = c->spec->noise;
    int chosen = c->spec->noise && rp->o.frames_auto;
    c->o.frames = !c->spec->noise ? 1 : chosen ? PROBE_FRAMES : rp->o.frames;
    c->o.frames_auto = 0;
    if ((rc = cal_open_sim(&c->o, &rp->b, &c->chip)) != EX_OK)
        return rc;
    c->src = (wdr_cal_source){rp->b.width, rp->b.height, wdr_cal_sim_capture, &c->chip.ss};
    cal_grid_amps(amps, &n);
    if (wdr_cal_acquire(&c->src, amps, n, c->o.frames, 1, cal_progress_fn(), "fpn report", &c->grid, err, sizeof err))
        return wdrctl_fail(EX_IOERR, "fpn report: %s: %s", c->spec->name, err);
    if (wdr_cal_informative_range(&c->grid, MIN_SLOPE_CODES, &c->lo, &c->hi))
        return wdrctl_fail(EX_DATAERR, "fpn report: %s: the response is flat everywhere", c->spec->name);
    return chosen ? auto_frames(c) : EX_OK;
}

static int report_setup(report *rp)
{
    char err[512];
    int rc;
    if (!rp->o.outdir)
        return wdrctl_fail(EX_USAGE, "fpn report: --outdir DIR is required");
    if (mkdir(rp->o.outdir, 0755) && access(rp->o.outdir, W_OK))
        return wdrctl_fail(EX_CANTCREAT, "%s: cannot create the output directory", rp->o.outdir);
    if ((rc = cal_load_board(rp->o.board, &rp->b)) != EX_OK)
        return rc;
    if (wdr_display_map_init(&rp->display, &rp->b, rp->o.op_name, err, sizeof err))
        return wdrctl_fail(EX_USAGE, "fpn report: operator '%s': %s", rp->o.op_name, err);
    rp->lsb_mv = codes_to_mv(&rp->b);
    rp->primary = rp->o.adc || rp->o.dac ? COND_CONVERTERS : COND_ANALOG;
    rp->lo = 0, rp->hi = INFINITY;
    for (int c = 0; c < N_COND; c++) { /* one set of judging currents for all: where every condition calibrated */
        if ((rc = open_condition(rp, &rp->c[c], c)) != EX_OK)
            return rc;
        rp->lo = fmax(rp->lo, rp->c[c].lo), rp->hi = fmin(rp->hi, rp->c[c].hi);
    }
    for (int k = 0; k < N_EVAL; k++)
        rp->eval[k] = rp->lo * pow(rp->hi / rp->lo, (k + 0.37) / N_EVAL);
    return EX_OK;
}

static int report_outputs(report *rp)
{
    char dir[1024];
    emva e = {0};
    double hb = 0, ha = 0;
    int rc = wdr_plot_tmpdir(dir, sizeof dir) ? wdrctl_fail(EX_CANTCREAT, "fpn report: no temporary directory") : EX_OK;
    if (rc != EX_OK)
        return rc;
    rc = plot_contrast(rp, dir);
    if (rc == EX_OK)
        rc = plot_histograms(rp, dir, &hb, &ha);
    wdr_plot_tmpdir_remove(dir);
    if (rc == EX_OK)
        rc = nonuniformity(rp, &e);
    if (rc == EX_OK)
        rc = write_test_images(rp);
    if (rc == EX_OK)
        rc = write_json(rp, &e, hb, ha);
    return rc;
}

static const cli_option fpn_report_rows[] = {
    {"outdir", 0, CLI_STRING, CAL_O(outdir), "DIR", "where the report goes (fpn.json, plots, test images)",
     .flags = CLI_REQUIRED},
    {"models", 0, CLI_STRING, CAL_O(models), "A,B,..", "models to compare (default spline,simple3,complex4)",
     .values = "spline simple3 complex4 lsq polymap"},
    CAL_ROW_FRAMES, CAL_ROW_BOARD, CAL_ROW_OPERATOR, CAL_ROW_ADC, CAL_ROW_DAC, CAL_ROW_SAMPLE, CAL_ROW_SEED, CAL_ROW_OUT_SCALE,
    CAL_ROW_JSON, {0}};

const cli_command wdrctl_cmd_fpn_report = {
    "fpn report", NULL, 0, 0,
    "FPN contrast error before and after, model error, DSNU/PRNU, histograms and test images",
    "Calibrates the simulated chip with every model and reports (the paper's Fig. 4-8).", fpn_report_rows,
    cmd_fpn_report, 0};

static void report_free(report *rp)
{
    for (int c = 0; c < N_COND; c++) {
        for (int i = 0; i < rp->n_models; i++)
            cal_free_run(&rp->c[c].m[i].run);
        wdr_cal_levels_free(&rp->c[c].grid);
        if (rp->c[c].chip.sim)
            cal_close_sim(&rp->c[c].chip);
    }
    free(rp);
}

int cmd_fpn_report(int argc, char **argv)
{
    report *rp = calloc(1, sizeof *rp);
    if (!rp)
        return wdrctl_fail(EX_OSERR, "out of memory");
    int rc = cal_parse_options(argc, argv, &wdrctl_cmd_fpn_report, &rp->o);
    if (rc == EX_OK && !wdr_operator_info_by_name(rp->o.op_name))
        rc = wdrctl_fail(EX_USAGE, "fpn report: unknown operator '%s' (see 'wdrctl operators')", rp->o.op_name);
    if (rc == EX_OK && (rc = parse_models(rp->o.models, rp)) == EX_OK && (rc = report_setup(rp)) == EX_OK) {
        for (int c = 0; rc == EX_OK && c < N_COND; c++)
            rc = run_condition(rp, &rp->c[c]);
        if (rc == EX_OK)
            rc = report_outputs(rp);
    }
    if (rc == EX_OK)
        fprintf(stderr,
                "wdrctl: FPN report in %s (fpn.json, fpn_contrast.png, fpn_histograms_1e-11.png, "
                "test_image_*.png)\n",
                rp->o.outdir);
    report_free(rp);
    return rc;
}
