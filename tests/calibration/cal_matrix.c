/* The calibration matrix's cells (cal_matrix.h): the library's calibration and metrics on a
 * simulated chip, nothing computed here but counts and maxima. */
#include "cal_matrix.h"
#include "cal_design.h"
#include "cal_form_measure.h"
#include "cal_metrics.h"
#include "cal_select.h"
#include "operators.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GRID_LO 1e-14 /* the probe grid of `wdrctl calibrate` (host/wdrctl/cal_common.h) */
#define GRID_HI 1e-8
#define GRID_LEVELS 37
#define GRID_PER_DECADE 6
#define MIN_SLOPE_CODES 2.0
#define SAMPLE_PIXELS 256 /* calibrate's --sample default */

static const char *const model_names[] = {"none", "simple3", "complex4", "lsq", "polymap", "spline"};

const char *cm_model_name(int model)
{
    return model > 0 && model < WDR_MODEL_COUNT ? model_names[model] : "?";
}

int cm_model_from_name(const char *name)
{
    for (int m = 1; m < WDR_MODEL_COUNT; m++)
        if (!strcmp(name, model_names[m]))
            return m;
    return -1;
}

static const struct {
    const char *name;
    int form, n;
} form_names[] = {{"moebius", WDR_FORM_MOEBIUS, 3},
                  {"poly-5", WDR_FORM_POLY, 5},
                  {"basis-8", WDR_FORM_BASIS, 8},
                  {"compact", WDR_FORM_COMPACT, WDR_CAL_COMPACT_COEFFS},
                  {"shifted", WDR_FORM_SHIFTED, WDR_CAL_COMPACT_COEFFS},
                  {"auto", CM_FORM_AUTO, 0}};

const char *cm_form_name(int form, int n_coeffs, char *buf, int cap)
{
    for (size_t i = 0; i < sizeof form_names / sizeof form_names[0]; i++)
        if (form_names[i].form == form && (form_names[i].n == n_coeffs || form == CM_FORM_AUTO ||
                                           form == WDR_FORM_COMPACT || form == WDR_FORM_SHIFTED))
            return form_names[i].name;
    snprintf(buf, (size_t)cap, "%s-%d",
             form == WDR_FORM_POLY    ? "poly"
             : form == WDR_FORM_BASIS ? "basis"
                                      : "form",
             n_coeffs);
    return buf;
}

int cm_form_from_name(const char *name, int *form, int *n_coeffs)
{
    for (size_t i = 0; i < sizeof form_names / sizeof form_names[0]; i++)
        if (!strcmp(name, form_names[i].name))
            return *form = form_names[i].form, *n_coeffs = form_names[i].n, 0;
    return -1;
}

int cm_model_forms(int model, int *forms, int *n_coeffs)
{
    int n = 0;
    if (model == WDR_MODEL_SIMPLE3)
        forms[n] = WDR_FORM_MOEBIUS, n_coeffs[n++] = 3;
    if (model == WDR_MODEL_SPLINE)
        forms[n] = WDR_FORM_BASIS, n_coeffs[n++] = 8;
    forms[n] = WDR_FORM_POLY, n_coeffs[n++] = 5;
    if (model == WDR_MODEL_SPLINE) {
        forms[n] = WDR_FORM_COMPACT, n_coeffs[n++] = WDR_CAL_COMPACT_COEFFS;
        forms[n] = WDR_FORM_SHIFTED, n_coeffs[n++] = WDR_CAL_COMPACT_COEFFS;
    }
    forms[n] = CM_FORM_AUTO, n_coeffs[n++] = 0;
    return n;
}

double cm_ppm(const cm_side *s)
{
    return s->healthy ? 1e6 * (double)s->healthy_flagged / (double)s->healthy : NAN;
}

/* ---- one chip, one converter condition ---- */

typedef struct chip {
    wdr_board b;
    wdr_sim *sim;
    uint8_t *lut, *truth;
    wdr_cal_simsrc ss;
    wdr_cal_source src;
    wdr_cal_levels grid, lv; /* the probe grid; the levels of the fit (lv.dark is the grid's) */
    wdr_cal_design design;
    wdr_cal_margin margin; /* the calibration margin sized from this chip's frames */
    int converters;
} chip;

static void chip_close(chip *c)
{
    c->lv.dark = NULL;
    wdr_cal_levels_free(&c->lv);
    wdr_cal_levels_free(&c->grid);
    wdr_sim_destroy(c->sim);
    free(c->lut);
    free(c->truth);
    memset(c, 0, sizeof *c);
}

static int plant(chip *c)
{
    long np = (long)c->b.width * c->b.height;
    long corner[4] = {0, np - 1, (long)(c->b.height - 1) * c->b.width, c->b.width - 1};
    uint8_t kind[4] = {WDR_DEFECT_DEAD, WDR_DEFECT_HOT, WDR_DEFECT_STUCK, WDR_DEFECT_SATURATED};
    wdr_sim_defects d = {.ppm = {0, CM_DEFECT_PPM, CM_DEFECT_PPM, CM_DEFECT_PPM, CM_DEFECT_PPM},
                         .seed = 99,
                         .n_listed = 4,
                         .listed_index = corner,
                         .listed_kind = kind};
    return wdr_sim_set_defects(c->sim, &d);
}

static int design_for(chip *c, const char *op, char *err, int errlen)
{
    const int middle_row = c->b.height / 2; /* the row whose hold time the design assumes */
    return wdr_cal_design_init(&c->design, &c->b, op, wdr_sim_integration_time(c->sim), middle_row * c->b.row_time_s, 1,
                               err, errlen);
}

static int size_margin(chip *c, const char *op, char *err, int errlen)
{
    wdr_cal_margin_req req;
    wdr_cal_margin_req_for(&c->design, GRID_LO, GRID_HI, 2, &req);
    wdr_cal_sim_margin m = {c->sim, &c->b, op, c->lut};
    int rc = wdr_cal_margin_size(&c->src, &req, wdr_cal_sim_set_margin, &m, &c->margin, err, errlen);
    c->lut = m.lut;
    return rc;
}

static int chip_open(chip *c, const cm_setup *s, const char *op, uint64_t seed, double mismatch, int converters)
{
    char err[512];
    memset(c, 0, sizeof *c);
    wdr_board_defaults(&c->b);
    if (wdr_board_load_named(s->board ? s->board : "sim-qvga", &c->b, err, sizeof err))
        return fprintf(stderr, "cal_matrix: %s\n", err), 1;
    if (s->width > 0)
        c->b.width = (uint16_t)s->width, c->b.height = (uint16_t)s->height;
    c->b.avt_mv_um *= mismatch, c->b.abeta_pct_um *= mismatch; /* "every mismatch figure doubled" at 2 */
    c->b.c_pd_sigma_pct *= mismatch, c->b.dark_sigma_ln *= mismatch;
    c->converters = converters;
    if (wdr_cal_sim_setup(&c->b, op, seed, converters, WDR_CAL_MARGIN_START_V, &c->sim, &c->lut, err, sizeof err))
        return fprintf(stderr, "cal_matrix: %s: %s\n", op, err), 1;
    if (!converters)
        wdr_sim_set_effect(c->sim, WDR_FX_DAC_QUANT, WDR_FX_OFF);
    long np = (long)c->b.width * c->b.height;
    c->truth = calloc((size_t)np, 1);
    if (!c->truth || (s->plant_defects && plant(c)))
        return fprintf(stderr, "cal_matrix: planting defects failed\n"), 1;
    wdr_sim_defect_map(c->sim, c->truth);
    c->ss = (wdr_cal_simsrc){c->sim, converters, 500};
    c->src = (wdr_cal_source){c->b.width, c->b.height, wdr_cal_sim_capture, &c->ss};
    double amps[GRID_LEVELS];
    for (int k = 0; k < GRID_LEVELS; k++)
        amps[k] = GRID_LO * pow(10, (double)k / GRID_PER_DECADE);
    /* The margin as calibrate sizes it (cal_common.c, cal_open_sim): from the chip's frames, then
     * the design again for the ramp it made. Temporal noise off: one frame per level is the
     * average of any number. */
    if (design_for(c, op, err, sizeof err) || size_margin(c, op, err, sizeof err) ||
        design_for(c, op, err, sizeof err) ||
        wdr_cal_acquire(&c->src, amps, GRID_LEVELS, 1, 1, NULL, NULL, &c->grid, err, sizeof err))
        return fprintf(stderr, "cal_matrix: %s: %s\n", op, err), 1;
    return 0;
}

/* calibrate's configuration for model on this chip (cmd_calibrate.c: output, DAC step, ties). */
static void config_for(const chip *c, int model, double lo, double hi, wdr_cal_config *cfg)
{
    wdr_cal_config_defaults(cfg, model);
    cfg->raw_max = (1u << c->b.adc_bits) - 1u;
    cfg->out_scale = 1.0f;
    cfg->out_max = (uint16_t)cfg->raw_max;
    if (c->converters)
        cfg->step_codes = (c->b.dac_hi_v - c->b.dac_lo_v) / ((1u << c->b.dac_bits) - 1u) * c->b.adc_gain *
                          ((1u << c->b.adc_bits) - 1u) / (c->b.adc_hi_v - c->b.adc_lo_v);
    else
        cfg->tie_codes = 1e-3; /* unquantised codes: only a clipped pixel ties */
    cfg->range_lo = lo, cfg->range_hi = hi;
    cfg->design = &c->design;
}

/* Levels calibrate takes by default (cal_common.c cal_default_currents). */
static int default_currents(int model)
{
    return model == WDR_MODEL_SIMPLE3 || model == WDR_MODEL_COMPLEX4 ? 5 : 19;
}

static int fit(chip *c, int model, double lo, double hi, wdr_cal_result *res, char *reason)
{
    char err[512];
    wdr_cal_config cfg;
    wdr_cal_choice ch;
    config_for(c, model, lo, hi, &cfg);
    if (wdr_cal_select_currents(&c->grid, &cfg, default_currents(model), lo, hi, SAMPLE_PIXELS, &ch, err, sizeof err))
        return snprintf(reason, CM_REASON, "selection: %.180s", err), 1;
    if (wdr_cal_levels_from_choice(&c->grid, &ch, &c->lv))
        return snprintf(reason, CM_REASON, "levels: out of memory"), 1;
    int rc = wdr_cal_fit_array(&c->lv, &cfg, res, err, sizeof err);
    if (rc)
        snprintf(reason, CM_REASON, "fit: %.180s", err);
    return rc != 0;
}

/* --form auto (host/wdrctl/cal_form_choice.c): the spline's form chosen on this chip's 12-bit
 * frames (the converters a user's chip has), at the judging currents calibrate takes, one frame
 * each (temporal noise off); the nearest when no form meets the target. The other models keep their
 * own form. */
static void auto_form(chip *q, const wdr_cal_result *res, double lo, double hi, cm_cell *cell)
{
    int model = cell->model, *form = &cell->form, *n = &cell->n_coeffs;
    wdr_cal_config d;
    wdr_cal_config_defaults(&d, model);
    *form = d.form, *n = d.n_coeffs;
    if (model != WDR_MODEL_SPLINE || !res)
        return;
    char err[512];
    wdr_form_trial tr[WDR_FORM_CANDIDATES];
    int nt;
    wdr_form_judging j = {WDR_FORM_JUDGING_CURRENTS, 1, 0, 7000000};
    int k = wdr_form_choose_on_source(res, &q->src, lo, hi, &j, WDR_FORM_TARGET_DEFAULT, 1, 1, tr, &nt, NULL, err,
                                      sizeof err);
    if (k == -2) {
        fprintf(stderr, "cal_matrix: form auto: %s (basis-8 kept)\n", err);
        return;
    }
    for (int t = 0; getenv("CM_TRIALS") && t < nt; t++) /* CM_TRIALS=1: every form's figures, on stderr */
        fprintf(stderr,
                "cal_matrix: form auto: %s seed %llu %gx: %d/%d %s: worst %.3g %% at %.3g A; at %.3g A %.3g %% "
                "against %.3g %% (fit %.3g %%)\n",
                cell->op, (unsigned long long)cell->seed, cell->mismatch, tr[t].form, tr[t].n_coeffs,
                tr[t].meets ? "meets" : "misses", tr[t].worst_pct, tr[t].worst_at, tr[t].excess_at, tr[t].table_pct,
                tr[t].allowed_pct, tr[t].model_pct);
    if (k < 0) /* none met: the nearest, as calibrate keeps it */
        k = wdr_form_nearest(tr, nt);
    *form = tr[k].form, *n = tr[k].n_coeffs;
}

/* Build the form's table from res and judge it at x[]: flags counted against the truth, the
 * worst contrast error, per-current errors into pct and floors into floor. */
static int judge(chip *c, const wdr_cal_result *res, int form, int n, const double *x, cm_side *s, double *pct,
                 double *model_pct, double *floor)
{
    char err[512];
    uint8_t *tb;
    size_t tl;
    wdr_cal_view tab;
    wdr_cal_result alt = *res;
    alt.cfg.form = form, alt.cfg.n_coeffs = n;
    if (wdr_cal_build_table(&alt, 1, 1, &tb, &tl, err, sizeof err))
        return s->refused = 1, snprintf(s->reason, CM_REASON, "table: %.180s", err), 1;
    if (wdr_cal_parse(tb, tl, &tab))
        return free(tb), s->refused = 1, snprintf(s->reason, CM_REASON, "table does not parse"), 1;
    for (int r = 0; r < c->b.height; r++) {
        const uint8_t *fl = wdr_cal_row_flags(&tab, r);
        for (int i = 0; i < c->b.width; i++) {
            int flagged = wdr_cal_pixel_flags(tab.h.form, fl[i]) != 0,
                planted = c->truth[(long)r * c->b.width + i] != 0;
            s->planted += planted, s->planted_found += planted && flagged;
            s->healthy += !planted, s->healthy_flagged += !planted && flagged;
        }
    }
    wdr_eval_opts eo = {.frames = 1, .quantised = c->converters, .design = &c->design};
    s->worst_pct = 0;
    for (int k = 0; k < CM_N_TEST; k++) {
        wdr_eval_point p;
        eo.first_frame_no = 9000 + k;
        if (wdr_eval_point_measure(res, &tab, &c->src, x[k], &eo, &p))
            return free(tb), s->refused = 1, snprintf(s->reason, CM_REASON, "evaluation capture failed"), 1;
        pct[k] = p.table.sd_pct, model_pct[k] = p.model.sd_pct, floor[k] = p.floor_pct;
        if (getenv("CM_PER_X")) /* CM_PER_X=1: the table's and the fit's error at every judged current */
            fprintf(stderr, "cal_matrix: form %d/%d, %s: at %.3g A table %.3f %%, fit %.3f %%\n", form, n,
                    c->converters ? "12-bit" : "analog", x[k], pct[k], model_pct[k]);
        if (!(pct[k] <= s->worst_pct)) /* a NaN is the worst */
            s->worst_pct = pct[k], s->worst_at = x[k];
    }
    free(tb);
    return 0;
}

static double ratio_of(const double *a, const double *e, const double *qf)
{
    double worst = 0;
    for (int k = 0; k < CM_N_TEST; k++)
        if (!(e[k] / hypot(a[k], qf[k]) <= worst))
            worst = e[k] / hypot(a[k], qf[k]);
    return worst;
}

static void floor_ratio(cm_cell *cell, const double *x, const double *a, const double *e, const double *qf)
{
    cell->floor_ratio = cell->side[0].refused || cell->side[1].refused ? NAN : 0;
    for (int k = 0; isfinite(cell->floor_ratio) && k < CM_N_TEST; k++) {
        double r = e[k] / hypot(a[k], qf[k]);
        if (!(r <= cell->floor_ratio))
            cell->floor_ratio = r, cell->ratio_at = x[k], cell->ratio_err = e[k],
            cell->ratio_floor = hypot(a[k], qf[k]);
    }
}

int cm_run_chip(const cm_setup *s, int model, const char *op, uint64_t seed, double mismatch, const int *forms,
                const int *n_coeffs, int nf, cm_cell *cells)
{
    chip c[2];
    wdr_cal_result res[2];
    int fitted[2] = {0, 0}, sides = s->analog_only ? 1 : 2;
    char reason[2][CM_REASON] = {"", "not run (analog only)"};
    double lo = 0, hi = 0, x[CM_N_TEST];
    for (int v = 0; v < sides; v++)
        if (chip_open(&c[v], s, op, seed, mismatch, v)) {
            for (int w = 0; w <= v; w++)
                chip_close(&c[w]);
            return 1;
        }
    /* both sides judged at the same currents: the analog chip's informative range */
    if (wdr_cal_informative_range(&c[0].grid, MIN_SLOPE_CODES, &lo, &hi) &&
        (sides < 2 || wdr_cal_informative_range(&c[1].grid, MIN_SLOPE_CODES, &lo, &hi)))
        for (int v = 0; v < sides; v++)
            snprintf(reason[v], CM_REASON, "the response is flat everywhere");
    else
        for (int v = 0; v < sides; v++)
            fitted[v] = !fit(&c[v], model, lo, hi, &res[v], reason[v]);
    for (int k = 0; k < CM_N_TEST; k++)
        x[k] = lo * pow(hi / lo, (k + 0.37) / CM_N_TEST);
    for (int f = 0; f < nf; f++) {
        cm_cell *cell = &cells[f];
        memset(cell, 0, sizeof *cell);
        cell->model = model, cell->op = op, cell->seed = seed, cell->mismatch = mismatch;
        cell->form = forms[f], cell->n_coeffs = n_coeffs[f], cell->asked_auto = forms[f] == CM_FORM_AUTO;
        if (cell->asked_auto && sides < 2) { /* auto judges on the 12-bit chip */
            snprintf(cell->side[0].reason, CM_REASON, "auto needs the 12-bit chip (analog only)");
            cell->side[0].refused = cell->side[1].refused = 1, cell->floor_ratio = NAN;
            continue;
        }
        if (cell->asked_auto)
            auto_form(&c[1], fitted[1] ? &res[1] : NULL, lo, hi, cell);
        int same = -1; /* auto's choice already built: the same cell */
        for (int g = 0; g < f && cell->asked_auto; g++)
            if (!cells[g].asked_auto && cells[g].form == cell->form && cells[g].n_coeffs == cell->n_coeffs)
                same = g;
        if (same >= 0) {
            *cell = cells[same];
            cell->asked_auto = 1;
            continue;
        }
        double pct[2][CM_N_TEST], mpct[2][CM_N_TEST], qf[2][CM_N_TEST];
        for (int v = 0; v < 2; v++) {
            cm_side *sd = &cell->side[v];
            sd->lo = lo, sd->hi = hi, sd->worst_pct = NAN;
            if (!fitted[v])
                sd->refused = 1, snprintf(sd->reason, CM_REASON, "%s", reason[v]);
            else
                judge(&c[v], &res[v], cell->form, cell->n_coeffs, x, sd, pct[v], mpct[v], qf[v]);
        }
        floor_ratio(cell, x, pct[0], pct[1], qf[1]);
        cell->model_ratio = isfinite(cell->floor_ratio) ? ratio_of(mpct[0], mpct[1], qf[1]) : NAN;
    }
    for (int v = 0; v < sides; v++) {
        if (fitted[v])
            wdr_cal_result_free(&res[v]);
        chip_close(&c[v]);
    }
    return 0;
}

/* ---- the table ---- */

void cm_print_header(FILE *f)
{
    fprintf(f, "| model | operator | form | seed | mismatch | analog: ppm flagged | found | worst %% | "
               "12-bit: ppm flagged | found | worst %% | 12-bit / floor (at A) | model / floor | refused |\n"
               "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
}

static void side_text(FILE *f, const cm_side *s)
{
    if (s->refused) {
        fprintf(f, " - | - | - |");
        return;
    }
    fprintf(f, " %.0f | %ld/%ld | %.3f |", cm_ppm(s), s->planted_found, s->planted, s->worst_pct);
}

void cm_print_row(FILE *f, const cm_cell *c)
{
    char buf[32], form[48];
    const char *fn = cm_form_name(c->form, c->n_coeffs, buf, sizeof buf);
    if (c->asked_auto)
        snprintf(form, sizeof form, "auto (%s)", fn);
    else
        snprintf(form, sizeof form, "%s", fn);
    fprintf(f, "| %s | %s | %s | %llu | %gx |", cm_model_name(c->model), c->op, form, (unsigned long long)c->seed,
            c->mismatch);
    side_text(f, &c->side[0]);
    side_text(f, &c->side[1]);
    if (isfinite(c->floor_ratio))
        fprintf(f, " %.2fx (%.3g) | %.2fx |", c->floor_ratio, c->ratio_at, c->model_ratio);
    else
        fprintf(f, " - | - |");
    const cm_side *a = &c->side[0], *q = &c->side[1];
    if (!a->refused && !q->refused)
        fprintf(f, " no |\n");
    else if (a->refused && q->refused && !strcmp(a->reason, q->reason))
        fprintf(f, " yes: %s |\n", a->reason);
    else
        fprintf(f, " yes: %s%s%s%s |\n", a->refused ? "analog: " : "", a->refused ? a->reason : "",
                q->refused ? (a->refused ? "; 12-bit: " : "12-bit: ") : "", q->refused ? q->reason : "");
}
