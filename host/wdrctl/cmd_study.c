/* wdrctl study: what accuracy costs. Every combination of the knobs' lists, each point built,
 * calibrated and judged on the simulator (fixed seed), then the table, the Pareto fronts, the
 * cheapest design for a target, JSON and plots (host/study/). */
#include "study.h"
#include "wdrctl.h"
#include "cli_number.h"
#include <errno.h>
#include <stddef.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

typedef struct study_opts {
    study_knobs k; /* the command line's lists; a study file fills what they leave out */
    const char *board, *file, *outdir, *range, *targets, *shard;
    double lo, hi, fps, target[STUDY_MAX_TARGETS];
    int target_acc[STUDY_MAX_TARGETS]; /* STUDY_ACC_TOTAL ("1%"), STUDY_ACC_DISPLAY ("0.5lev") */
    int jobs, json, no_plots, plots, n_targets, merge, shard_k, shard_n, n_args;
    char **args; /* --merge: the shard files */
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
    {"target", 0, CLI_STRING, O(targets), "P%,L lev,..",
     "targets to answer, each on its own: worst contrast error (1%) or worst display error in 8-bit levels (0.5lev)"},
    {"fps", 0, CLI_DOUBLE, O(fps), "F", "frame rate for the table bandwidth (default 30)", .min = 1e-3, .max = 1e5},
    {"jobs", 0, CLI_INT, O(jobs), "N", "worker processes (default 2)", .min = 1, .max = 64},
    {"seed", 0, CLI_U64, O(seed), "N", "chip and frame seed (default 1)"},
    {"shard", 0, CLI_STRING, O(shard), "K/N",
     "compute only every N-th point from the K-th, into OUTDIR/shard-K-of-N.wshd (no tables, plots or answers)"},
    {"merge", 0, CLI_FLAG, O(merge), NULL, "merge the shard files given as arguments: fronts, plots and answers"},
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
    KNOB("form", form, "table forms: auto, moebius, poly, basis, compact, shifted"),
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
    "study", "[SHARD.wshd...]", 0, STUDY_MAX_POINTS, "what accuracy costs: every combination of the knobs on the simulator, and its Pareto fronts",
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

/* "1%,0.5lev": up to STUDY_MAX_TARGETS targets, each answered from the same points: a worst
 * contrast error (%, or a bare number), or a worst display error in 8-bit levels (lev). */
static int parse_targets(const char *v, study_opts *o)
{
    char buf[256], *save = NULL;
    snprintf(buf, sizeof buf, "%s", v);
    o->n_targets = 0;
    for (char *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        if (o->n_targets == STUDY_MAX_TARGETS)
            return wdrctl_fail(EX_USAGE, "study: --target: at most %d targets", STUDY_MAX_TARGETS);
        size_t n = strlen(t);
        int *acc = &o->target_acc[o->n_targets];
        *acc = STUDY_ACC_TOTAL;
        if (n && t[n - 1] == '%') /* --target 1% */
            t[n - 1] = 0;
        else if (n > 3 && !strcmp(t + n - 3, "lev")) /* --target 0.5lev */
            t[n - 3] = 0, *acc = STUDY_ACC_DISPLAY;
        double *out = &o->target[o->n_targets++];
        if (cli_number_double(t, 1e-3, 1e4, out) != CLI_NUM_OK)
            return wdrctl_fail(EX_USAGE, "study: --target '%s' must be numbers in 0.001..10000, each with %% or lev",
                               v);
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
    int rc = wdrctl_parse(&wdrctl_cmd_study, argc, argv, o, &o->n_args);
    if (rc != EX_OK)
        return rc;
    o->args = argv + 1;
    if (o->n_args && !o->merge)
        return wdrctl_fail(EX_USAGE, "study: '%s': shard files are read with --merge only", o->args[0]);
    if (o->merge && o->shard)
        return wdrctl_fail(EX_USAGE, "study: --merge and --shard: a merge reads shards, it does not compute one");
    if (o->shard && (rc = study_shard_parse(o->shard, &o->shard_k, &o->shard_n)) != EX_OK)
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
            study_print_target(s, o->target[t], o->target_acc[t]);
        study_print_knobs(s);
        printf("\n%d points in %.1f s on %d jobs (%.2f s per point per job)\n", s->n, wall, s->jobs,
               wall * s->jobs / s->n);
    }
    int rc = study_write_json(s, o->outdir, o->target, o->target_acc, o->n_targets, wall, o->json);
    if (rc == EX_OK && o->plots)
        rc = study_plot(s, o->outdir, o->target, o->target_acc, o->n_targets);
    if (rc == EX_OK)
        fprintf(stderr, "wdrctl: study in %s (study.json%s)\n", o->outdir,
                o->plots ? ", study_vs_image_time.png, study_vs_cal_time.png, study_vs_table_bytes.png, "
                            "study_vs_m7_instructions.png, study_vs_table_bandwidth.png"
                          : "");
    return rc;
}

/* --merge: the shards' points as one study, then the same outputs as an unsharded run. */
static int merge(study_opts *o)
{
    study s = {0};
    static char board[256];
    double wall = 0;
    int rc = study_shard_merge(o->args, o->n_args, &s, board, sizeof board, &wall);
    s.jobs = o->jobs;
    if (rc == EX_OK && mkdir(o->outdir, 0755) && access(o->outdir, W_OK))
        rc = wdrctl_fail(EX_CANTCREAT, "%s: cannot create the output directory", o->outdir);
    if (rc == EX_OK) {
        fprintf(stderr, "study: %d points merged from %d shards\n", s.n, o->n_args);
        rc = outputs(&s, o, wall);
    }
    free(s.pts), free(s.res);
    return rc;
}

/* --shard K/N: this share of the points, into OUTDIR/shard-K-of-N.wshd. */
static int run_shard(study *s, const study_opts *o)
{
    char path[1024];
    double wall = 0;
    s->index = malloc(sizeof(int) * (size_t)s->n);
    if (!s->index)
        return wdrctl_fail(EX_OSERR, "study: out of memory");
    study_shard_select(s, o->shard_k, o->shard_n);
    fprintf(stderr, "study: shard %d/%d: %d of %d points\n", o->shard_k, o->shard_n, s->n, s->full_n);
    int rc = s->n ? study_run(s, wdrctl_show_progress(), &wall) : EX_OK;
    snprintf(path, sizeof path, "%s/shard-%d-of-%d.wshd", o->outdir, o->shard_k, o->shard_n);
    if (rc == EX_OK && (rc = study_shard_write(s, o->shard_k, o->shard_n, path, wall)) == EX_OK)
        fprintf(stderr, "wdrctl: study shard in %s\n", path);
    free(s->index);
    return rc;
}

/* Before any point is computed: the folder exists (or is made) and is a writable directory; a
 * file of that name was found only after all points were computed. */
static int check_outdir(const char *dir)
{
    struct stat st;
    if (mkdir(dir, 0755) && errno != EEXIST)
        return wdrctl_fail(EX_CANTCREAT, "study: --outdir %s: cannot create the directory: %s", dir, strerror(errno));
    if (stat(dir, &st) || !S_ISDIR(st.st_mode))
        return wdrctl_fail(EX_CANTCREAT, "study: --outdir %s: exists and is not a directory", dir);
    if (access(dir, W_OK))
        return wdrctl_fail(EX_CANTCREAT, "study: --outdir %s: not writable: %s", dir, strerror(errno));
    return EX_OK;
}

/* A study whose every point failed has no figure to give: not a success. */
static int check_some_point_ok(const study *s)
{
    for (int i = 0; i < s->n; i++)
        if (s->res[i].ok)
            return EX_OK;
    return wdrctl_fail(EX_DATAERR, "study: none of the %d points succeeded (the first: %s)", s->n,
                       s->n ? s->res[0].why : "no points");
}

int cmd_study(int argc, char **argv)
{
    study_opts o;
    void *keep;
    study s = {0};
    int skipped = 0, rc = parse_options(argc, argv, &o, &keep);
    if (rc == EX_OK && o.merge) {
        rc = merge(&o);
        study_knobs_free_file(keep);
        return rc;
    }
    if (rc == EX_OK) {
        s = (study){.board = o.board, .range_lo = o.lo, .range_hi = o.hi, .fps = o.fps, .seed = o.seed, .jobs = o.jobs};
        rc = study_expand(&o.k, &s, &skipped);
    }
    if (rc == EX_OK)
        rc = check_outdir(o.outdir);
    if (rc == EX_OK) {
        fprintf(stderr, "study: %d points (%d model/form pairs refused), %dx%d simulated pixels, %d jobs, seed %lu\n",
                s.n, skipped, s.pts[0].width, s.pts[0].height, s.jobs, (unsigned long)o.seed);
        double wall = 0;
        if (o.shard)
            rc = run_shard(&s, &o);
        else if ((rc = study_run(&s, wdrctl_show_progress(), &wall)) == EX_OK)
            rc = outputs(&s, &o, wall);
        if (rc == EX_OK)
            rc = check_some_point_ok(&s);
    }
    free(s.pts), free(s.res);
    study_knobs_free_file(keep);
    return rc;
}
