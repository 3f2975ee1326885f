/* The study's outputs: a table of every point, the fronts, the answer for a target (or the knob
 * that limits it), JSON for scripts, and gnuplot plots of the fronts. */
#include "plot.h"
#include "study.h"
#include "wdr_cal.h"
#include "wdr_lut.h"
#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sysexits.h>

static const char *model_name(int m)
{
    static const char *const names[] = {"none", "simple3", "complex4", "lsq", "polymap", "spline"};
    return m >= 0 && m < WDR_MODEL_COUNT ? names[m] : "?";
}

static const char *form_name(int f)
{
    return f == WDR_FORM_MOEBIUS   ? "moebius"
           : f == WDR_FORM_BASIS   ? "basis"
           : f == WDR_FORM_COMPACT ? "compact"
           : f == WDR_FORM_SHIFTED ? "shifted"
                                   : "poly";
}

static int point_coeffs(const study_point *p)
{
    if (p->form == WDR_FORM_MOEBIUS)
        return 3;
    /* the defaults of wdr_cal_config_defaults */
    return p->n_coeffs ? p->n_coeffs : p->model == WDR_MODEL_SIMPLE3 ? 3 : p->model == WDR_MODEL_SPLINE ? 8 : 5;
}

void study_point_label(const study_point *p, char *out, int outlen)
{
    char timing[32], ranges[64] = "full";
    if (p->timing == WDR_TIMING_UNIFORM)
        snprintf(timing, sizeof timing, "uniform%u", (unsigned)p->uniform_entries);
    else
        snprintf(timing, sizeof timing, "stamped");
    if (p->fit_ranges)
        snprintf(ranges, sizeof ranges, "fit");
    else if (isfinite(p->adc_lo_v) && isfinite(p->dac_lo_v))
        snprintf(ranges, sizeof ranges, "adc%g:%g,dac%g:%g", p->adc_lo_v, p->adc_hi_v, p->dac_lo_v, p->dac_hi_v);
    else if (isfinite(p->adc_lo_v))
        snprintf(ranges, sizeof ranges, "adc%g:%g", p->adc_lo_v, p->adc_hi_v);
    else if (isfinite(p->dac_lo_v))
        snprintf(ranges, sizeof ranges, "dac%g:%g", p->dac_lo_v, p->dac_hi_v);
    snprintf(out, (size_t)outlen, "adc%d dac%d %s %s %s %s/%s%d%s L%d%s M%d F%d %dx%d%s%s", p->adc_bits, p->dac_bits,
             ranges, timing, p->op, model_name(p->model), form_name(p->form), point_coeffs(p),
             p->coeff_bits < 32 ? "h" : "",
             p->n_levels,
             p->levels_choice == STUDY_LEVELS_SELECT ? "sel" : "", p->frames_cal, p->frames_img, p->width, p->height,
             p->op_params[0] ? " " : "", p->op_params);
}

/* ---- text ---- */

static void print_header(void)
{
    printf("%4s  %-52s %7s %7s %7s %7s %7s %6s %6s %6s %8s %8s %5s %7s %6s %6s\n", "#", "design", "worst%", "med%",
           "fpn%", "temp%", "floor%", "disp", "off1%", "flag%", "img_ms", "cal_s", "B/px", "tab_KiB", "ns/px", "fit_s");
}

static void print_row(const study *s, int i)
{
    char label[256];
    const study_result *r = &s->res[i];
    study_point_label(&s->pts[i], label, sizeof label);
    if (!r->ok) {
        printf("%4d  %-52s failed: %s\n", i, label, r->why);
        return;
    }
    printf("%4d  %-52s %7.3g %7.3g %7.3g %7.3g %7.3g %6.3g %6.3g %6.3g %8.4g %8.4g %5.3g %7.0f %6.3g %6.3g\n", i, label,
           r->worst_total_pct, r->median_total_pct, r->worst_fpn_pct, r->worst_temporal_pct, r->floor_pct,
           r->display_levels, 100 * r->display_off1_frac, 100 * r->flagged_frac, 1e3 * r->image_s, r->cal_s,
           r->table_bpp, r->table_bytes / 1024, r->correct_ns_px, r->fit_s_per_mp);
}

void study_print_table(const study *s)
{
    printf("every point (worst/median: contrast error over the range, total = FPN + temporal; disp: worst rms "
           "display error in 8-bit levels; off1: readings off by > 1 level; costs at the board's geometry)\n");
    print_header();
    for (int i = 0; i < s->n; i++)
        print_row(s, i);
}

void study_print_fronts(const study *s)
{
    int *idx = malloc(sizeof(int) * (size_t)s->n);
    if (!idx)
        return;
    for (int a = 0; a < STUDY_ACC_COUNT; a++)
        for (int c = 0; c < STUDY_COST_COUNT; c++) {
            int m = study_front(s, a, c, idx);
            printf("\nPareto front: %s (%s) against %s (%s, %s):\n", study_acc_name(a), study_acc_unit(a),
                   study_cost_name(c), study_cost_unit(c), study_cost_measured(c) ? "measured here" : "modelled");
            for (int k = 0; k < m; k++) {
                char label[256];
                study_point_label(&s->pts[idx[k]], label, sizeof label);
                printf("  %10.4g %-8s %8.4g %-12s #%d %s\n", study_cost_value(&s->res[idx[k]], c), study_cost_unit(c),
                       study_acc_value(&s->res[idx[k]], a), study_acc_unit(a), idx[k], label);
            }
        }
    free(idx);
}

/* ---- the target ---- */

/* A knob's value of a point as text, for the table of what each knob buys. */
static void knob_value(const study_point *p, int k, char *out, size_t cap)
{
    switch (k) {
    case 0: snprintf(out, cap, "%d", p->adc_bits); break;
    case 1: snprintf(out, cap, "%d", p->dac_bits); break;
    case 2: snprintf(out, cap, "%s", p->fit_ranges ? "fit" : "full"); break;
    case 3: snprintf(out, cap, "%s", p->timing == WDR_TIMING_UNIFORM ? "uniform" : "stamped"); break;
    case 4: snprintf(out, cap, "%s", model_name(p->model)); break;
    case 5: snprintf(out, cap, "%s%d", form_name(p->form), point_coeffs(p)); break;
    case 6: snprintf(out, cap, "%d", p->frames_cal); break;
    case 7: snprintf(out, cap, "%d", p->frames_img); break;
    case 8:
        snprintf(out, cap, "%d", p->n_levels);
        break;
    case 9: snprintf(out, cap, "%d", p->coeff_bits); break;
    default: snprintf(out, cap, "%.31s %.30s", p->op, p->op_params); break;
    }
}

#define N_KNOBS 11
static const char *const knob_names[N_KNOBS] = {"adc-bits", "dac-bits",   "converter-ranges", "timing",
                                                "model",    "form",       "frames",           "image-frames",
                                                "levels",   "coeff-bits", "operator"};

/* For every knob with more than one value: the best worst-total error reached at each value. */
static void print_knob_table(const study *s, int a)
{
    printf("\nwhat each knob buys (best %s among the points with that value):\n", study_acc_name(a));
    for (int k = 0; k < N_KNOBS; k++) {
        char vals[32][64];
        double best[32];
        int nv = 0;
        for (int i = 0; i < s->n; i++) {
            char v[64];
            knob_value(&s->pts[i], k, v, sizeof v);
            int j = 0;
            while (j < nv && strcmp(vals[j], v))
                j++;
            if (j == nv && nv < 32)
                snprintf(vals[nv], sizeof vals[nv], "%s", v), best[nv++] = INFINITY;
            if (j < nv && s->res[i].ok)
                best[j] = fmin(best[j], study_acc_value(&s->res[i], a));
        }
        if (nv < 2)
            continue;
        printf("  %-17s", knob_names[k]);
        for (int j = 0; j < nv; j++)
            printf(" %s: %.3g %%%s", vals[j], best[j], j + 1 < nv ? "," : "\n");
    }
}

/* The limiting knob: the numeric knob whose best figure still improves most at the largest value
 * swept (more of it may help). Knobs swept over one value only are named, as not explored. */
static void print_edge_knob(const study *s, int a)
{
    static const int numeric[] = {0, 1, 6, 7, 8, 9};
    int best_k = -1, single[6], n_single = 0;
    double best_gain = 1.1, last_v = 0, prev_v = 0, last_f = 0, prev_f = 0; /* a 10 % step counts */
    for (size_t q = 0; q < sizeof numeric / sizeof numeric[0]; q++) {
        double vals[32], best[32];
        int nv = 0;
        for (int i = 0; i < s->n; i++) {
            char t[64];
            knob_value(&s->pts[i], numeric[q], t, sizeof t);
            double v = atof(t);
            int j = 0;
            while (j < nv && vals[j] != v)
                j++;
            if (j == nv && nv < 32)
                vals[nv] = v, best[nv++] = INFINITY;
            if (j < nv && s->res[i].ok)
                best[j] = fmin(best[j], study_acc_value(&s->res[i], a));
        }
        if (nv < 2) {
            single[n_single++] = numeric[q];
            continue;
        }
        int hi = 0, nx = -1; /* the largest value and the one below it */
        for (int j = 1; j < nv; j++)
            hi = vals[j] > vals[hi] ? j : hi;
        for (int j = 0; j < nv; j++)
            if (j != hi && (nx < 0 || vals[j] > vals[nx]))
                nx = j;
        double gain = best[nx] / best[hi];
        if (gain > best_gain)
            best_gain = gain, best_k = numeric[q], last_v = vals[hi], prev_v = vals[nx], last_f = best[hi],
            prev_f = best[nx];
    }
    if (best_k >= 0)
        printf("  limiting knob: %s: still improving at its largest value (best %.3g at %g, %.3g at %g): more of it "
               "may help\n",
               knob_names[best_k], prev_f, prev_v, last_f, last_v);
    else
        printf("  limiting knob: none swept still improves by 10 %% at its largest value: the model and table form "
               "set the limit here\n");
    for (int k = 0; k < n_single; k++)
        if (single[k] == 6 || single[k] == 7) /* frames: the knobs that buy noise down */
            printf("  not swept: %s (one value)\n", knob_names[single[k]]);
}

/* The most accurate point by figure a, and the part of its error that keeps it above the target. */
static void print_limit(const study *s, int a, double target)
{
    int b = -1;
    for (int i = 0; i < s->n; i++)
        if (s->res[i].ok && (b < 0 || study_acc_value(&s->res[i], a) < study_acc_value(&s->res[b], a)))
            b = i;
    if (b < 0) {
        printf("  no point could be evaluated\n");
        return;
    }
    const study_result *r = &s->res[b];
    const study_point *p = &s->pts[b];
    char label[256];
    study_point_label(p, label, sizeof label);
    printf("  none does; the most accurate is #%d %s at %.3g %s (total %.3g %%, FPN alone %.3g %%, temporal %.3g %%, "
           "quantisation floor %.3g %%, of which the ADC %.3g %%)\n",
           b, label, study_acc_value(r, a), study_acc_unit(a), r->worst_total_pct, r->worst_fpn_pct, r->worst_temporal_pct, r->floor_pct,
           r->floor_adc_pct);
    if (a == STUDY_ACC_TOTAL && r->worst_temporal_pct > target)
        printf("  limiting knob: image-frames (%d): the image's temporal noise alone is %.3g %%, and it falls only "
               "as 1/sqrt(frames)\n",
               p->frames_img, r->worst_temporal_pct);
    print_edge_knob(s, a); /* averaging also dithers the converters: the knob that still pays, too */
}

static void print_cheapest(const study *s, int a, double target)
{
    int unfed = 0;
    for (int i = 0; i < s->n; i++)
        unfed += s->res[i].ok && !s->res[i].bus_feeds;
    printf("\ncheapest designs with %s <= %.3g %s over %.3g..%.3g A", study_acc_name(a), target, study_acc_unit(a),
           s->range_lo, s->range_hi);
    if (unfed)
        printf(" (%d points skipped: the board's table bus, %.4g MB/s, cannot feed them at %g frames/s)", unfed,
               s->res[0].bus_Bps / 1e6, s->fps);
    printf(":\n");
    int found = 0;
    for (int c = 0; c < STUDY_COST_COUNT; c++) {
        int i = study_cheapest(s, a, c, target);
        if (i < 0)
            continue;
        char label[256];
        study_point_label(&s->pts[i], label, sizeof label);
        printf("  by %-22s %10.4g %-9s (%s): #%d %s, total %.3g %%, FPN alone %.3g %%\n", study_cost_name(c),
               study_cost_value(&s->res[i], c), study_cost_unit(c), study_cost_measured(c) ? "measured" : "modelled", i,
               label, s->res[i].worst_total_pct, s->res[i].worst_fpn_pct);
        found = 1;
    }
    if (!found)
        print_limit(s, a, target);
}

void study_print_target(const study *s, double target, int acc)
{
    if (acc == STUDY_ACC_DISPLAY) {
        print_cheapest(s, STUDY_ACC_DISPLAY, target);
        return;
    }
    print_cheapest(s, STUDY_ACC_TOTAL, target);
    print_cheapest(s, STUDY_ACC_FPN, target);
}

void study_print_knobs(const study *s)
{
    print_knob_table(s, STUDY_ACC_TOTAL);
    print_knob_table(s, STUDY_ACC_FPN);
}

/* ---- JSON ---- */

static cJSON *point_json(const study *s, int i)
{
    const study_point *p = &s->pts[i];
    const study_result *r = &s->res[i];
    char label[256];
    study_point_label(p, label, sizeof label);
    cJSON *j = cJSON_CreateObject(), *k = cJSON_AddObjectToObject(j, "knobs");
    cJSON_AddNumberToObject(j, "index", i);
    cJSON_AddStringToObject(j, "label", label);
    cJSON_AddNumberToObject(k, "adc_bits", p->adc_bits);
    cJSON_AddNumberToObject(k, "dac_bits", p->dac_bits);
    cJSON_AddStringToObject(k, "converter_ranges", p->fit_ranges ? "fit" : "full");
    cJSON_AddStringToObject(k, "timing", p->timing == WDR_TIMING_UNIFORM ? "uniform" : "stamped");
    cJSON_AddNumberToObject(k, "uniform_entries", p->uniform_entries);
    cJSON_AddNumberToObject(k, "dac_timer_hz", p->dac_timer_hz);
    cJSON_AddStringToObject(k, "operator", p->op);
    cJSON_AddStringToObject(k, "params", p->op_params);
    cJSON_AddStringToObject(k, "model", model_name(p->model));
    cJSON_AddStringToObject(k, "form", form_name(p->form));
    cJSON_AddNumberToObject(k, "coeffs", point_coeffs(p));
    cJSON_AddNumberToObject(k, "coeff_bits", p->coeff_bits);
    cJSON_AddNumberToObject(k, "levels", r->levels_used);
    cJSON_AddStringToObject(k, "levels_choice", p->levels_choice == STUDY_LEVELS_SELECT ? "select" : "log");
    cJSON_AddNumberToObject(k, "frames", p->frames_cal);
    cJSON_AddNumberToObject(k, "image_frames", p->frames_img);
    cJSON_AddNumberToObject(k, "width", p->width);
    cJSON_AddNumberToObject(k, "height", p->height);
    cJSON_AddBoolToObject(j, "ok", r->ok);
    if (!r->ok) {
        cJSON_AddStringToObject(j, "why", r->why);
        return j;
    }
    cJSON *a = cJSON_AddObjectToObject(j, "accuracy");
    cJSON_AddNumberToObject(a, "worst_total_pct", r->worst_total_pct);
    cJSON_AddNumberToObject(a, "median_total_pct", r->median_total_pct);
    cJSON_AddNumberToObject(a, "worst_fpn_pct", r->worst_fpn_pct);
    cJSON_AddNumberToObject(a, "median_fpn_pct", r->median_fpn_pct);
    cJSON_AddNumberToObject(a, "worst_temporal_pct", r->worst_temporal_pct);
    cJSON_AddNumberToObject(a, "floor_pct", r->floor_pct);
    cJSON_AddNumberToObject(a, "floor_median_pct", r->floor_median_pct);
    cJSON_AddNumberToObject(a, "floor_adc_pct", r->floor_adc_pct);
    cJSON_AddNumberToObject(a, "display_levels", r->display_levels);
    cJSON_AddNumberToObject(a, "display_off1_frac", r->display_off1_frac);
    cJSON_AddNumberToObject(a, "flagged_frac", r->flagged_frac);
    cJSON_AddNumberToObject(a, "beyond_curve_frac", r->beyond_frac);
    cJSON *c = cJSON_AddObjectToObject(j, "cost");
    cJSON_AddNumberToObject(c, "reset_s", r->t_reset_s);
    cJSON_AddNumberToObject(c, "ramp_s", r->t_ramp_s);
    cJSON_AddNumberToObject(c, "readout_s", r->t_readout_s);
    cJSON_AddNumberToObject(c, "frame_time_s", r->frame_s);
    for (int q = 0; q < STUDY_COST_COUNT; q++)
        if (isfinite(study_cost_value(r, q)))
            cJSON_AddNumberToObject(c, study_cost_name(q), study_cost_value(r, q));
        else
            cJSON_AddNullToObject(c, study_cost_name(q));
    cJSON_AddNumberToObject(c, "table_bytes", r->table_bytes);
    cJSON_AddNumberToObject(c, "table_bus_Bps", r->bus_Bps);
    cJSON_AddBoolToObject(c, "bus_feeds", r->bus_feeds);
    if (isfinite(r->m7_row_px))
        cJSON_AddNumberToObject(c, "m7_row_instructions_per_pixel", r->m7_row_px);
    else
        cJSON_AddNullToObject(c, "m7_row_instructions_per_pixel");
    cJSON *u = cJSON_AddObjectToObject(j, "used");
    cJSON_AddNumberToObject(u, "adc_lo_V", r->adc_lo_v);
    cJSON_AddNumberToObject(u, "adc_hi_V", r->adc_hi_v);
    cJSON_AddNumberToObject(u, "dac_lo_V", r->dac_lo_v);
    cJSON_AddNumberToObject(u, "dac_hi_V", r->dac_hi_v);
    cJSON_AddNumberToObject(u, "eval_s", r->eval_s);
    return j;
}

static cJSON *fronts_json(const study *s)
{
    cJSON *f = cJSON_CreateArray();
    int *idx = malloc(sizeof(int) * (size_t)s->n);
    for (int a = 0; idx && a < STUDY_ACC_COUNT; a++)
        for (int c = 0; c < STUDY_COST_COUNT; c++) {
            int m = study_front(s, a, c, idx);
            cJSON *o = cJSON_CreateObject();
            cJSON_AddStringToObject(o, "accuracy", study_acc_name(a));
            cJSON_AddStringToObject(o, "cost", study_cost_name(c));
            cJSON_AddItemToObject(o, "points", cJSON_CreateIntArray(idx, m));
            cJSON_AddItemToArray(f, o);
        }
    free(idx);
    return f;
}

static cJSON *costs_json(void)
{
    cJSON *c = cJSON_CreateObject();
    for (int q = 0; q < STUDY_COST_M7; q++)
        cJSON_AddStringToObject(c, study_cost_name(q),
                                study_cost_measured(q) ? "measured here" : "modelled from the board");
    cJSON_AddStringToObject(c, "table_bus_Bps", "the board file's controller.table_bus_MBps (0: not given); "
                                                "bus_feeds false: --target skips the point");
    cJSON_AddStringToObject(c, "m7_instructions_per_pixel",
                            "measured, not modelled: bench_target's count of the correction on the Cortex-M7 (QEMU "
                            "mps2-an500, -icount shift=0), per form (host/study/study_m7.c); null where it does not "
                            "run that coefficient count");
    cJSON_AddStringToObject(c, "m7_row_instructions_per_pixel",
                            "measured, not modelled: the same for the row path (correction, ROW framing, CRC)");
    return c;
}

static cJSON *target_json(const study *s, double target, int acc)
{
    cJSON *t = cJSON_CreateObject();
    cJSON_AddNumberToObject(t, acc == STUDY_ACC_DISPLAY ? "levels" : "pct", target);
    for (int a = STUDY_ACC_TOTAL; a <= STUDY_ACC_DISPLAY; a++) {
        if ((acc == STUDY_ACC_DISPLAY) != (a == STUDY_ACC_DISPLAY) || a == STUDY_ACC_FLOOR)
            continue;
        cJSON *by = cJSON_AddObjectToObject(t, study_acc_name(a)); /* cheapest point index per cost, or null */
        for (int c = 0; c < STUDY_COST_COUNT; c++) {
            int i = study_cheapest(s, a, c, target);
            if (i >= 0)
                cJSON_AddNumberToObject(by, study_cost_name(c), i);
            else
                cJSON_AddNullToObject(by, study_cost_name(c));
        }
    }
    return t;
}

int study_write_json(const study *s, const char *outdir, const double *targets, const int *accs, int n_targets,
                     double wall_s, int to_stdout)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "board", s->board);
    cJSON_AddNumberToObject(j, "range_lo_A", s->range_lo);
    cJSON_AddNumberToObject(j, "range_hi_A", s->range_hi);
    cJSON_AddNumberToObject(j, "fps", s->fps);
    cJSON_AddNumberToObject(j, "seed", (double)s->seed);
    cJSON_AddNumberToObject(j, "jobs", s->jobs);
    cJSON_AddNumberToObject(j, "wall_s", wall_s);
    cJSON_AddItemToObject(j, "cost_kinds", costs_json());
    cJSON *tj = cJSON_AddArrayToObject(j, "targets");
    for (int t = 0; t < n_targets; t++)
        cJSON_AddItemToArray(tj, target_json(s, targets[t], accs[t]));
    cJSON *pts = cJSON_AddArrayToObject(j, "points");
    for (int i = 0; i < s->n; i++)
        cJSON_AddItemToArray(pts, point_json(s, i));
    cJSON_AddItemToObject(j, "fronts", fronts_json(s));
    char path[1024], *text = cJSON_Print(j);
    cJSON_Delete(j);
    snprintf(path, sizeof path, "%.1000s/study.json", outdir);
    FILE *f = text ? fopen(path, "w") : NULL;
    int ok = f && fputs(text, f) >= 0;
    if (f)
        ok &= fclose(f) == 0;
    if (to_stdout && text)
        printf("%s\n", text);
    free(text);
    return ok ? EX_OK : study_fail(EX_CANTCREAT, "%s: cannot write the JSON", path);
}

/* ---- plots ---- */

static int write_data(const study *s, int c, const char *dir, char *all, char *front, size_t cap)
{
    snprintf(all, cap, "%.900s/all_%d.dat", dir, c);
    snprintf(front, cap, "%.900s/front_%d.dat", dir, c);
    FILE *fa = fopen(all, "w"), *ff = fopen(front, "w");
    int *idx = malloc(sizeof(int) * (size_t)s->n), ok = fa && ff && idx;
    for (int i = 0; ok && i < s->n; i++)
        if (s->res[i].ok)
            fprintf(fa, "%g %g %g %g\n", study_cost_value(&s->res[i], c), s->res[i].worst_total_pct,
                    s->res[i].floor_pct, s->res[i].worst_fpn_pct);
    for (int a = 0; ok && a < 3; a++) { /* total, FPN alone and floor fronts, one block each */
        int m = study_front(s, a == 0 ? STUDY_ACC_TOTAL : a == 1 ? STUDY_ACC_FPN : STUDY_ACC_FLOOR, c, idx);
        for (int k = 0; k < m; k++)
            fprintf(ff, "%g %g\n", study_cost_value(&s->res[idx[k]], c),
                    study_acc_value(&s->res[idx[k]], a == 0   ? STUDY_ACC_TOTAL
                                                     : a == 1 ? STUDY_ACC_FPN
                                                              : STUDY_ACC_FLOOR));
        fprintf(ff, "\n\n");
    }
    free(idx);
    if (fa)
        ok &= fclose(fa) == 0;
    if (ff)
        ok &= fclose(ff) == 0;
    return ok;
}

static int plot_one(const study *s, int c, const char *file, const char *xlabel, double xscale, const char *outdir,
                    const char *dir, const double *targets, const int *accs, int n_targets)
{
    char all[1024], front[1024], script[8192], err[512];
    int known = 0;
    for (int i = 0; i < s->n; i++)
        known += s->res[i].ok && isfinite(study_cost_value(&s->res[i], c));
    if (!known) { /* M7 counts exist only for the forms bench_target runs */
        fprintf(stderr, "wdrctl: study: %s not drawn: no point has a %s\n", file, study_cost_name(c));
        return EX_OK;
    }
    if (!write_data(s, c, dir, all, front, sizeof all))
        return study_fail(EX_CANTCREAT, "%s: cannot write plot data", dir);
    int len =
        snprintf(script, sizeof script,
                 "set terminal pngcairo size 1000,640\nset output '%s/%s'\nset logscale xy\nset grid\nset key outside\n"
                 "set xlabel '%s'\nset ylabel 'worst contrast error over %.3g..%.3g A (%%)'\n"
                 "set title 'What accuracy costs: %s (%d points, %s)'\n"
                 "plot '%s' u ($1*%g):2 w p pt 7 ps 0.6 lc rgb '#b0b0b0' t 'every point (total)', "
                 "'%s' u ($1*%g):4 w p pt 6 ps 0.6 lc rgb '#a0c0f0' t 'every point (FPN alone)', "
                 "'%s' index 0 u ($1*%g):2 w steps lw 2 lc rgb '#c00000' t 'front: total (FPN + temporal)', "
                 "'%s' index 0 u ($1*%g):2 w p pt 7 ps 1 lc rgb '#c00000' notitle, "
                 "'%s' index 1 u ($1*%g):2 w steps lw 1.5 dt 2 lc rgb '#0050c0' t 'front: FPN alone', "
                 "'%s' index 1 u ($1*%g):2 w p pt 5 ps 0.8 lc rgb '#0050c0' notitle, "
                 "'%s' index 2 u ($1*%g):2 w steps lw 1.5 dt 3 lc rgb '#208020' t 'front: quantisation floor', "
                 "'%s' index 2 u ($1*%g):2 w p pt 9 ps 0.8 lc rgb '#208020' notitle",
                 outdir, file, xlabel, s->range_lo, s->range_hi, s->pts[0].op, s->n,
                 study_cost_measured(c) ? "measured here" : "modelled from the board", all, xscale, all, xscale, front,
                 xscale, front, xscale, front, xscale, front, xscale, front, xscale, front, xscale);
    for (int t = 0; t < n_targets && len < (int)sizeof script - 64; t++)
        if (accs[t] != STUDY_ACC_DISPLAY) /* the plots' axis is contrast */
            len += snprintf(script + len, sizeof script - (size_t)len, ", %g w l lc rgb 'black' dt 4 t 'target %.3g %%'",
                        targets[t], targets[t]);
    snprintf(script + len, sizeof script - (size_t)len, "\n");
    int rc = wdr_gnuplot_run(script, err, sizeof err);
    return rc ? study_fail(rc < 0 && strstr(err, "gnuplot") ? EX_UNAVAILABLE : EX_SOFTWARE, "plot: %s", err) : EX_OK;
}

int study_plot(const study *s, const char *outdir, const double *targets, const int *accs, int n_targets)
{
    char dir[1024];
    if (wdr_plot_tmpdir(dir, sizeof dir))
        return study_fail(EX_CANTCREAT, "no temporary directory for plot data");
    int rc = plot_one(s, STUDY_COST_FRAME, "study_vs_image_time.png",
                      "time per image (ms; modelled: image frames x (reset + ramp + readout))", 1e3, outdir, dir,
                      targets, accs, n_targets);
    if (rc == EX_OK)
        rc = plot_one(s, STUDY_COST_CAL, "study_vs_cal_time.png",
                      "calibration time on the board (s; modelled: (levels + dark) x frames x frame time)", 1, outdir,
                      dir, targets, accs, n_targets);
    if (rc == EX_OK)
        rc = plot_one(s, STUDY_COST_TABLE, "study_vs_table_bytes.png", "table bytes per pixel (firmware format)", 1,
                      outdir, dir, targets, accs, n_targets);
    if (rc == EX_OK)
        rc = plot_one(s, STUDY_COST_M7, "study_vs_m7_instructions.png",
                      "Cortex-M7 instructions per pixel, correction (measured by bench_target; forms it runs)", 1,
                      outdir, dir, targets, accs, n_targets);
    if (rc == EX_OK)
        rc = plot_one(s, STUDY_COST_BANDWIDTH, "study_vs_table_bandwidth.png",
                      "table bandwidth at --fps (MB/s; modelled: table bytes x frame rate)", 1e-6, outdir, dir, targets,
                      accs, n_targets);
    wdr_plot_tmpdir_remove(dir);
    return rc;
}
