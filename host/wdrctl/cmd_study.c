/* wdrctl study: what accuracy costs. Every combination of the knobs' lists, each point built,
 * calibrated and judged on the simulator (fixed seed), then the table, the Pareto fronts, the
 * cheapest design for a target, JSON and plots (host/study/). */
#include "study.h"
#include "wdrctl.h"
#include "cli_number.h"
#include <stddef.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

typedef struct study_opts {
    study_knobs k; /* the command line's lists; a study file fills what they leave out */
    const char *board, *file, *outdir, *range, *targets;
    double lo, hi, fps, target[STUDY_MAX_TARGETS];
    int jobs, json, no_plots, plots, n_targets;
    uint64_t seed;
} study_opts;

/* ---- options: one row each (cli_options.h); knob lists go to study_expand, which checks them ---- */

#define O(f) offsetof(study_opts, f)
#define KNOB(name, field, help) {name, 0, CLI_STRING, O(k.field), "LIST", help}
static const cli_option study_rows[] = {
    {"study", 0, CLI_STRING, O(file), "FILE.json", "a study file: its keys are these long options"},
    {"board", 0, CLI_STRING, O(board), "NAME|FILE", "board: a name or a board.json (default sim-vga)", .values = "@boards"},
    {"outdir", 0, CLI_STRING, O(outdir), "DIR", "where study.json and the plots go (default study)"},
    {"json", 0, CLI_FLAG, O(json), NULL, "print the JSON instead of the tables"},
    {"no-plots", 0, CLI_FLAG, O(no_plots), NULL, "no gnuplot plots"},
    {"range", 0, CLI_STRING, O(range), "LO:HI", "photocurrent range judged, A (default 1e-14:1e-8)"},
    {"target", 0, CLI_STRING, O(targets), "P%,..", "worst contrast errors to answer: the cheapest design for each"},
    {"fps", 0, CLI_DOUBLE, O(fps), "F", "frame rate for the table bandwidth (default 30)", .min = 1e-3, .max = 1e5},
    {"jobs", 0, CLI_INT, O(jobs), "N", "worker processes (default 2)", .min = 1, .max = 64},
    {"seed", 0, CLI_U64, O(seed), "N", "chip and frame seed (default 1)"},
    KNOB("adc-bits", adc_bits, "ADC bits (lists: a,b or A:B[:STEP|:*FACTOR])"),
    KNOB("adc-range", adc_range, "ADC input ranges LO:HI in V"),
    KNOB("dac-bits", dac_bits, "DAC bits"),
    KNOB("dac-range", dac_range, "DAC output ranges LO:HI in V"),
    KNOB("converter-ranges", ranges, "full or fit (each converter's range set to its signal, with a margin)"),
    KNOB("timing", timing, "ramp timing: stamped, uniform"),
    KNOB("entries", entries, "uniform-clock entries"),
    KNOB("dac-timer-hz", timer_hz, "DAC update rate of stamped steps, Hz"),
    KNOB("operator", op, "operators"),
    KNOB("param", params, "operator parameters KEY=V1,V2;.."),
    KNOB("model", model, "calibration models"),
    KNOB("form", form, "table forms: auto, moebius, poly, basis"),
    KNOB("coeffs", coeffs, "coefficients per pixel"),
    KNOB("coeff-bits", coeff_bits, "coefficient precision: 32, 16"),
    KNOB("levels", levels, "calibration levels"),
    KNOB("levels-choice", levels_choice, "choice of levels: log, select"),
    KNOB("frames", frames, "frames averaged per level"),
    KNOB("image-frames", image_frames, "frames averaged per image"),
    KNOB("size", size, "simulated sensor sizes WxH (default 64x48)"),
    {0}};
#undef KNOB
#undef O

const cli_command wdrctl_cmd_study = {
    "study", NULL, 0, 0, "what accuracy costs: every combination of the knobs on the simulator, and its Pareto fronts",
    "Every combination of the knob lists is built, calibrated and judged on the simulator with a fixed seed: the "
    "table of points, the Pareto front of each accuracy figure against each cost, plots, JSON, and with --target the "
    "cheapest design that meets it (or the knob that limits it).",
    study_rows, cmd_study, 0};

static int parse_range(const char *v, double *lo, double *hi)
{
    char *e;
    *lo = strtod(v, &e);
    *hi = *e == ':' ? strtod(e + 1, &e) : NAN;
    if (*e || !(*lo > 0) || !(*hi > *lo * 1.5) || !(*hi < 1))
        return wdrctl_fail(EX_USAGE, "study: --range '%s' must be LO:HI in amperes with 0 < LO < HI < 1", v);
    return EX_OK;
}

/* "1%,3%": up to STUDY_MAX_TARGETS worst contrast errors, each answered from the same points. */
static int parse_targets(const char *v, study_opts *o)
{
    char buf[256], *save = NULL;
    snprintf(buf, sizeof buf, "%s", v);
    o->n_targets = 0;
    for (char *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        if (o->n_targets == STUDY_MAX_TARGETS)
            return wdrctl_fail(EX_USAGE, "study: --target: at most %d targets", STUDY_MAX_TARGETS);
        size_t n = strlen(t);
        if (n && t[n - 1] == '%') /* --target 1% */
            t[n - 1] = 0;
        double *out = &o->target[o->n_targets++];
        if (cli_number_double(t, 1e-3, 1e4, out) != CLI_NUM_OK)
            return wdrctl_fail(EX_USAGE, "study: --target '%s' must be a number in 0.001..10000 (%%)", v);
    }
    return EX_OK;
}

/* Each knob the command line gives replaces the study file's. */
static void overlay(study_knobs *base, const study_knobs *given)
{
    const char *const *g = (const char *const *)given;
    const char **b = (const char **)base;
    for (size_t i = 0; i < sizeof *given / sizeof *g; i++)
        if (g[i])
            b[i] = g[i];
}

static int parse_options(int argc, char **argv, study_opts *o, void **keep)
{
    *o = (study_opts){.board = "sim-vga", .outdir = "study", .fps = 30, .jobs = 2, .seed = 1};
    *keep = NULL;
    int n_args, rc = wdrctl_parse(&wdrctl_cmd_study, argc, argv, o, &n_args);
    if (rc != EX_OK)
        return rc;
    o->plots = !o->no_plots;
    o->lo = 1e-14, o->hi = 1e-8;
    if (o->range && (rc = parse_range(o->range, &o->lo, &o->hi)) != EX_OK)
        return rc;
    if (o->targets && (rc = parse_targets(o->targets, o)) != EX_OK)
        return rc;
    if (o->file) { /* the file first, so the command line's lists override its fields */
        study_knobs given = o->k;
        o->k = (study_knobs){0};
        if ((rc = study_knobs_from_file(o->file, &o->k, keep)) != EX_OK)
            return rc;
        overlay(&o->k, &given);
    }
    return EX_OK;
}

static int outputs(const study *s, const study_opts *o, double wall)
{
    if (!o->json) {
        study_print_table(s);
        study_print_fronts(s);
        for (int t = 0; t < o->n_targets; t++)
            study_print_target(s, o->target[t]);
        study_print_knobs(s);
        printf("\n%d points in %.1f s on %d jobs (%.2f s per point per job)\n", s->n, wall, s->jobs,
               wall * s->jobs / s->n);
    }
    int rc = study_write_json(s, o->outdir, o->target, o->n_targets, wall, o->json);
    if (rc == EX_OK && o->plots)
        rc = study_plot(s, o->outdir, o->target, o->n_targets);
    if (rc == EX_OK)
        fprintf(stderr, "wdrctl: study in %s (study.json%s)\n", o->outdir,
                o->plots ? ", study_vs_image_time.png, study_vs_cal_time.png, study_vs_table_bytes.png" : "");
    return rc;
}

int cmd_study(int argc, char **argv)
{
    study_opts o;
    void *keep;
    study s = {0};
    int skipped = 0, rc = parse_options(argc, argv, &o, &keep);
    if (rc == EX_OK) {
        s = (study){.board = o.board, .range_lo = o.lo, .range_hi = o.hi, .fps = o.fps, .seed = o.seed, .jobs = o.jobs};
        rc = study_expand(&o.k, &s, &skipped);
    }
    if (rc == EX_OK && mkdir(o.outdir, 0755) && access(o.outdir, W_OK))
        rc = wdrctl_fail(EX_CANTCREAT, "%s: cannot create the output directory", o.outdir);
    if (rc == EX_OK) {
        fprintf(stderr, "study: %d points (%d model/form pairs refused), %dx%d simulated pixels, %d jobs, seed %lu\n",
                s.n, skipped, s.pts[0].width, s.pts[0].height, s.jobs, (unsigned long)o.seed);
        double wall = 0;
        rc = study_run(&s, wdrctl_show_progress(), &wall);
        if (rc == EX_OK)
            rc = outputs(&s, &o, wall);
    }
    free(s.pts), free(s.res);
    study_knobs_free_file(keep);
    return rc;
}
