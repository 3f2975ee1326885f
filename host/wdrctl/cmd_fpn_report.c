/* wdrctl fpn report: the FPN figures of every model on the simulated chip: contrast error
 * before and after, model error, DSNU/PRNU, histograms and test images (the paper's Fig. 4-8). */
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

typedef struct model_report {
    int model;
    cal_run run;
    wdr_cal_view tab;
    wdr_fpn_stats raw[N_EVAL], model_path[N_EVAL], table[N_EVAL];
    double worst_model, worst_table, err_max_mv, err_median_mv;
} model_report;

typedef struct report {
    cal_opts o;
    wdr_board b;
    sim_chip chip;
    wdr_cal_source src;
    wdr_cal_levels grid;
    double lo, hi, eval[N_EVAL], lsb_mv;
    model_report m[WDR_MODEL_COUNT];
    int n_models;
} report;

static double codes_to_mv(const wdr_board *b)
{
    return 1e3 * (b->adc_hi_v - b->adc_lo_v) / ((1u << b->adc_bits) - 1u) / (b->adc_gain > 0 ? b->adc_gain : 1);
}

static int report_model(report *rp, model_report *m)
{
    char err[512];
    cal_run *r = &m->run;
    wdr_cal_config_defaults(&r->cfg, m->model);
    cal_set_output(&rp->o, &r->cfg, (unsigned)rp->b.adc_bits);
    r->cfg.range_lo = rp->lo, r->cfg.range_hi = rp->hi;
    r->cfg.tie_codes = rp->o.adc ? r->cfg.tie_codes : 1e-3;
    r->lo = rp->lo, r->hi = rp->hi;
    if (wdr_cal_select_currents(&rp->grid, &r->cfg, cal_default_currents(m->model), rp->lo, rp->hi, rp->o.sample,
                                &r->choice, err, sizeof err))
        return wdrctl_fail(EX_DATAERR, "fpn report: %s: %s", cal_model_name(m->model), err);
    int rc = cal_acquire_and_fit(&rp->o, &rp->src, r, rp->b.sensor_id, 0);
    if (rc != EX_OK || wdr_cal_parse(r->table, r->table_len, &m->tab))
        return rc != EX_OK ? rc : wdrctl_fail(EX_SOFTWARE, "fpn report: built table does not parse");
    if (wdr_cal_evaluate(&r->res, &m->tab, &rp->src, rp->eval, N_EVAL, m->raw, m->model_path, m->table))
        return wdrctl_fail(EX_IOERR, "fpn report: evaluation frames failed");
    m->worst_model = m->worst_table = 0;
    for (int k = 0; k < N_EVAL; k++) {
        m->worst_model = fmax(m->worst_model, m->model_path[k].sd_pct);
        m->worst_table = fmax(m->worst_table, m->table[k].sd_pct);
    }
    int idx[WDR_CAL_MAX_LEVELS], n = 0;
    for (int k = 0; k < rp->grid.n; k++)
        if (rp->grid.amps[k] >= rp->lo && rp->grid.amps[k] <= rp->hi)
            idx[n++] = k;
    wdr_cal_levels in_range;
    if (wdr_cal_levels_subset(&rp->grid, idx, n, &in_range))
        return wdrctl_fail(EX_OSERR, "out of memory");
    wdr_model_error(&r->res, in_range.frames, in_range.amps, n, r->res.flags, &m->err_max_mv, &m->err_median_mv);
    m->err_max_mv *= rp->lsb_mv, m->err_median_mv *= rp->lsb_mv;
    wdr_cal_levels_free(&in_range);
    fprintf(stderr, "fpn report: %s: worst contrast error %.3g %% (model), %.3g %% (table)\n", cal_model_name(m->model),
            m->worst_model, m->worst_table);
    return EX_OK;
}

/* ---- plots (gnuplot) ---- */

static int write_contrast_data(const report *rp, const char *dir, char *path, size_t cap)
{
    snprintf(path, cap, "%.900s/contrast.dat", dir);
    FILE *f = fopen(path, "w");
    if (!f)
        return WDR_E_IO;
    for (int k = 0; k < N_EVAL; k++) {
        fprintf(f, "%g %g", rp->eval[k], rp->m[0].raw[k].sd_pct);
        for (int i = 0; i < rp->n_models; i++)
            fprintf(f, " %g %g", fmax(rp->m[i].model_path[k].sd_pct, 1e-4), fmax(rp->m[i].table[k].sd_pct, 1e-4));
        fputc('\n', f);
    }
    return fclose(f) ? WDR_E_IO : WDR_OK;
}

static int plot_contrast(const report *rp, const char *dir)
{
    char data[1024], script[8192], err[512];
    if (write_contrast_data(rp, dir, data, sizeof data))
        return wdrctl_fail(EX_CANTCREAT, "%s: cannot write plot data", data);
    int n = snprintf(script, sizeof script,
                     "set terminal pngcairo size 1000,640\nset output '%s/fpn_contrast.png'\nset logscale xy\n"
                     "set xlabel 'photocurrent (A)'\nset ylabel 'FPN contrast error (%%, sd across pixels)'\n"
                     "set title 'FPN contrast error before and after correction (%s)'\nset grid\nset key outside\n"
                     "plot '%s' u 1:2 w lp t 'before', 1 w l dt 2 lc rgb 'black' t '1 %% (eye)'",
                     rp->o.outdir, rp->o.op_name, data);
    for (int i = 0; i < rp->n_models; i++)
        n += snprintf(script + n, sizeof script - (size_t)n, ", '%s' u 1:%d w lp t '%s (double)', '%s' u 1:%d w lp t '%s (float32 table)'",
                      data, 3 + 2 * i, cal_model_name(rp->m[i].model), data, 4 + 2 * i, cal_model_name(rp->m[i].model));
    snprintf(script + n, sizeof script - (size_t)n, "\n");
    int rc = wdr_gnuplot_run(script, err, sizeof err);
    return rc ? wdrctl_fail(rc == WDR_E_UNSUPPORTED ? EX_UNAVAILABLE : EX_SOFTWARE, "fpn report: %s", err) : EX_OK;
}

/* Per-pixel relative error at 1e-11 A before and after (the first model's table), histogrammed. */
static int plot_histograms(report *rp, const char *dir, double *before_sd, double *after_sd)
{
    long np = (long)rp->b.width * rp->b.height;
    float *frame = malloc(sizeof(float) * (size_t)np);
    double *eb = malloc(sizeof(double) * (size_t)np), *ea = malloc(sizeof(double) * (size_t)np);
    char path[1024], script[4096], err[512];
    wdr_fpn_stats sb, sa;
    const model_report *m = &rp->m[0];
    int rc = !frame || !eb || !ea ? WDR_E_NOMEM : rp->src.capture(rp->src.ctx, 1e-11, 2000000, frame);
    if (!rc)
        rc = wdr_fpn_frame(&m->run.res, NULL, WDR_PATH_RAW, frame, 1e-11, NULL, eb, &sb);
    if (!rc)
        rc = wdr_fpn_frame(&m->run.res, &m->tab, WDR_PATH_TABLE, frame, 1e-11, m->run.res.flags, ea, &sa);
    snprintf(path, sizeof path, "%.900s/hist.dat", dir);
    FILE *f = rc ? NULL : fopen(path, "w");
    for (long i = 0; f && i < np; i++)
        if (isfinite(eb[i]) && isfinite(ea[i]))
            fprintf(f, "%g %g\n", eb[i], ea[i]);
    if (f)
        fclose(f);
    free(frame), free(eb), free(ea);
    if (rc || !f)
        return wdrctl_fail(EX_SOFTWARE, "fpn report: histogram data failed");
    *before_sd = sb.sd_pct, *after_sd = sa.sd_pct;
    snprintf(script, sizeof script,
             "set terminal pngcairo size 1000,420\nset output '%s/fpn_histograms_1e-11.png'\nset multiplot layout 1,2\n"
             "set style fill solid 0.6\nset xlabel '(x_hat - x)/x (%%)'\nset ylabel 'pixels'\n"
             "bw=%g\nbin(x)=bw*floor(x/bw)\nset title 'before correction, 1e-11 A (sd %.3g %%)'\n"
             "plot '%s' u (bin($1)):(1) smooth freq w boxes notitle\nbw=%g\n"
             "set title 'after (%s, float32 table; sd %.3g %%)'\nplot '%s' u (bin($2)):(1) smooth freq w boxes notitle\n"
             "unset multiplot\n",
             rp->o.outdir, fmax(sb.sd_pct / 8, 1e-6), sb.sd_pct, path, fmax(sa.sd_pct / 8, 1e-6),
             cal_model_name(m->model), sa.sd_pct, path);
    rc = wdr_gnuplot_run(script, err, sizeof err);
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
    const model_report *m = &rp->m[0];
    double lo = wdr_nominal_eval(&m->run.res.nominal, rp->hi), hi = wdr_nominal_eval(&m->run.res.nominal, rp->lo);
    if (!rc) {
        test_scene(b, amps);
        rc = wdr_sim_set_photocurrent(rp->chip.sim, amps);
    }
    if (!rc)
        rc = render_map(&rp->chip, b, raw);
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
    const model_report *m = &rp->m[0];
    float *lit = malloc(sizeof(float) * (size_t)np), *dark_c = malloc(sizeof(float) * (size_t)np);
    float *lit_c = malloc(sizeof(float) * (size_t)np);
    int rc = !lit || !dark_c || !lit_c ? WDR_E_NOMEM : rp->src.capture(rp->src.ctx, 1e-11, 4000000, lit);
    for (int r = 0; !rc && r < rp->b.height; r++) {
        long o = (long)r * rp->b.width;
        rc = wdr_correct_row_f32(&m->tab, r, rp->grid.dark + o, dark_c + o) ||
             wdr_correct_row_f32(&m->tab, r, lit + o, lit_c + o);
    }
    for (long i = 0; !rc && i < np; i++)
        dark_c[i] /= m->tab.h.out_scale, lit_c[i] /= m->tab.h.out_scale;
    if (!rc) {
        wdr_emva_nonuniformity(rp->grid.dark, lit, np, m->run.res.flags, &e->dsnu_mv, &e->prnu_pct);
        wdr_emva_nonuniformity(dark_c, lit_c, np, m->run.res.flags, &e->dsnu_after_mv, &e->prnu_after_pct);
        e->dsnu_mv *= rp->lsb_mv, e->dsnu_after_mv *= rp->lsb_mv;
    }
    free(lit), free(dark_c), free(lit_c);
    return rc ? wdrctl_fail(EX_SOFTWARE, "fpn report: nonuniformity frames failed") : EX_OK;
}

/* ---- JSON summary ---- */

static cJSON *stats_array(const wdr_fpn_stats *s, int n)
{
    double v[N_EVAL];
    for (int k = 0; k < n; k++)
        v[k] = s[k].sd_pct;
    return cJSON_CreateDoubleArray(v, n);
}

static cJSON *model_json(const model_report *m)
{
    cJSON *j = cJSON_CreateObject();
    const cal_run *r = &m->run;
    cJSON_AddStringToObject(j, "model", cal_model_name(m->model));
    cJSON_AddStringToObject(j, "table_form", cal_form_name(r->cfg.form));
    cJSON_AddNumberToObject(j, "table_coefficients", r->cfg.form == WDR_FORM_MOEBIUS ? 3 : r->cfg.n_coeffs);
    cJSON_AddItemToObject(j, "currents_A", cJSON_CreateDoubleArray(r->choice.amps, r->choice.n));
    cJSON_AddNumberToObject(j, "selection_worst_pct", r->choice.worst_pct);
    cJSON_AddItemToObject(j, "contrast_after_model_pct", stats_array(m->model_path, N_EVAL));
    cJSON_AddItemToObject(j, "contrast_after_table_pct", stats_array(m->table, N_EVAL));
    cJSON_AddNumberToObject(j, "worst_after_model_pct", m->worst_model);
    cJSON_AddNumberToObject(j, "worst_after_table_pct", m->worst_table);
    cJSON_AddNumberToObject(j, "model_error_max_mV", m->err_max_mv);
    cJSON_AddNumberToObject(j, "model_error_median_mV", m->err_median_mv);
    cJSON_AddNumberToObject(j, "paper_model_error_mV", m->model == WDR_MODEL_SIMPLE3 ? 15 : m->model == WDR_MODEL_COMPLEX4 ? 40 : 0);
    cJSON_AddNumberToObject(j, "pixels_flagged", (double)r->res.n_bad);
    return j;
}

static int write_json(const report *rp, const emva *e, double hist_before, double hist_after)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "board", rp->b.name);
    cJSON_AddStringToObject(j, "operator", rp->o.op_name);
    cJSON_AddBoolToObject(j, "adc_quantisation", rp->o.adc);
    cJSON_AddBoolToObject(j, "dac_quantisation", rp->o.dac);
    cJSON_AddStringToObject(j, "temporal_noise", "off");
    cJSON_AddNumberToObject(j, "range_lo_A", rp->lo);
    cJSON_AddNumberToObject(j, "range_hi_A", rp->hi);
    cJSON_AddItemToObject(j, "photocurrents_A", cJSON_CreateDoubleArray(rp->eval, N_EVAL));
    cJSON_AddItemToObject(j, "contrast_before_pct", stats_array(rp->m[0].raw, N_EVAL));
    cJSON_AddStringToObject(j, "contrast_note", "sd across pixels of (x_hat - x)/x in %, x_hat from the nominal "
                            "curve's inverse (before) or the model and its table (after); before correction, pixels "
                            "whose raw code lies beyond a flat end of the curve have no sensible inverse, hence "
                            "huge values there");
    cJSON *models = cJSON_AddArrayToObject(j, "models");
    for (int i = 0; i < rp->n_models; i++)
        cJSON_AddItemToArray(models, model_json(&rp->m[i]));
    cJSON *em = cJSON_AddObjectToObject(j, "emva1288");
    cJSON_AddNumberToObject(em, "dsnu_mV_before", e->dsnu_mv);
    cJSON_AddNumberToObject(em, "dsnu_mV_after", e->dsnu_after_mv);
    cJSON_AddNumberToObject(em, "prnu_pct_before_at_1e-11A", e->prnu_pct);
    cJSON_AddNumberToObject(em, "prnu_pct_after_at_1e-11A", e->prnu_after_pct);
    cJSON_AddStringToObject(em, "note", "nonlinear pixel: DSNU in mV at the ADC input, PRNU as the spread of the "
                                        "signal above dark at 1e-11 A; temporal noise off, so no averaging needed");
    cJSON *h = cJSON_AddObjectToObject(j, "histogram_1e-11A");
    cJSON_AddNumberToObject(h, "sd_before_pct", hist_before);
    cJSON_AddNumberToObject(h, "sd_after_pct", hist_after);
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
        int rc = cal_model_from_name(t, &rp->m[rp->n_models].model);
        if (rc != EX_OK)
            return rc;
        rp->n_models++;
    }
    return EX_OK;
}

static int report_setup(report *rp)
{
    char err[512];
    double amps[WDR_CAL_MAX_LEVELS];
    int n, rc;
    if (!rp->o.outdir)
        return wdrctl_fail(EX_USAGE, "fpn report: --outdir DIR is required");
    if (mkdir(rp->o.outdir, 0755) && access(rp->o.outdir, W_OK))
        return wdrctl_fail(EX_CANTCREAT, "%s: cannot create the output directory", rp->o.outdir);
    if ((rc = cal_load_board(rp->o.board, &rp->b)) != EX_OK || (rc = cal_open_sim(&rp->o, &rp->b, &rp->chip)) != EX_OK)
        return rc;
    rp->src = (wdr_cal_source){rp->b.width, rp->b.height, wdr_cal_sim_capture, &rp->chip.ss};
    rp->lsb_mv = codes_to_mv(&rp->b);
    cal_grid_amps(amps, &n);
    if (wdr_cal_acquire(&rp->src, amps, n, rp->o.frames, 1, cal_progress_fn(), "fpn report", &rp->grid, err, sizeof err))
        return wdrctl_fail(EX_IOERR, "fpn report: %s", err);
    if (wdr_cal_informative_range(&rp->grid, MIN_SLOPE_CODES, &rp->lo, &rp->hi))
        return wdrctl_fail(EX_DATAERR, "fpn report: the response is flat everywhere");
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
    {"models", 0, CLI_STRING, CAL_O(models), "A,B,..", "models to compare (default spline,simple3,complex4)"},
    CAL_ROW_BOARD, CAL_ROW_OPERATOR, CAL_ROW_ADC, CAL_ROW_DAC, CAL_ROW_SAMPLE, CAL_ROW_SEED, CAL_ROW_OUT_SCALE,
    CAL_ROW_JSON, {0}};

const cli_command wdrctl_cmd_fpn_report = {
    "fpn report", NULL, 0, 0,
    "FPN contrast error before and after, model error, DSNU/PRNU, histograms and test images",
    "Calibrates the simulated chip with every model and reports (the paper's Fig. 4-8).", fpn_report_rows,
    cmd_fpn_report, 0};

int cmd_fpn_report(int argc, char **argv)
{
    report *rp = calloc(1, sizeof *rp);
    if (!rp)
        return wdrctl_fail(EX_OSERR, "out of memory");
    int rc = cal_parse_options(argc, argv, &wdrctl_cmd_fpn_report, &rp->o);
    if (rc == EX_OK && !wdr_operator_info_by_name(rp->o.op_name))
        rc = wdrctl_fail(EX_USAGE, "fpn report: unknown operator '%s' (see 'wdrctl operators')", rp->o.op_name);
    if (rc == EX_OK)
        rp->o.frames = 1; /* temporal noise is off in the simulator: one frame per level is exact */
    if (rc == EX_OK && (rc = parse_models(rp->o.models, rp)) == EX_OK && (rc = report_setup(rp)) == EX_OK) {
        for (int i = 0; rc == EX_OK && i < rp->n_models; i++)
            rc = report_model(rp, &rp->m[i]);
        if (rc == EX_OK)
            rc = report_outputs(rp);
    }
    if (rc == EX_OK)
        fprintf(stderr, "wdrctl: FPN report in %s (fpn.json, fpn_contrast.png, fpn_histograms_1e-11.png, "
                        "test_image_*.png)\n", rp->o.outdir);
    for (int i = 0; i < rp->n_models; i++)
        cal_free_run(&rp->m[i].run);
    wdr_cal_levels_free(&rp->grid);
    if (rp->chip.sim)
        cal_close_sim(&rp->chip);
    free(rp);
    return rc;
}
