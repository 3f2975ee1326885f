/* wdrctl study: what accuracy costs. Every combination of the knobs' lists, each point built,
 * calibrated and judged on the simulator (fixed seed), then the table, the Pareto fronts, the
 * cheapest design for a target, JSON and plots (host/study/). */
#include "study.h"
#include "wdrctl.h"
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

typedef struct study_opts {
    study_knobs k;
    const char *board, *file, *outdir;
    double lo, hi, fps, target[STUDY_MAX_TARGETS];
    int jobs, json, plots, n_targets;
    unsigned long seed;
} study_opts;

static int parse_range(const char *v, double *lo, double *hi)
{
    char *e;
    *lo = strtod(v, &e);
    *hi = *e == ':' ? strtod(e + 1, &e) : NAN;
    if (*e || !(*lo > 0) || !(*hi > *lo * 1.5) || !(*hi < 1))
        return wdrctl_fail(EX_USAGE, "study: --range '%s' must be LO:HI in amperes with 0 < LO < HI < 1", v);
    return EX_OK;
}

static int parse_number(const char *opt, const char *v, double lo, double hi, double *out);

/* "1%,3%": up to STUDY_MAX_TARGETS worst contrast errors, each answered from the same points. */
static int parse_targets(const char *v, study_opts *o)
{
    char buf[256], *save = NULL;
    snprintf(buf, sizeof buf, "%s", v);
    o->n_targets = 0;
    for (char *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        if (o->n_targets == STUDY_MAX_TARGETS)
            return wdrctl_fail(EX_USAGE, "study: --target: at most %d targets", STUDY_MAX_TARGETS);
        int rc = parse_number("--target", t, 1e-3, 1e4, &o->target[o->n_targets++]);
        if (rc != EX_OK)
            return rc;
    }
    return EX_OK;
}

static int parse_number(const char *opt, const char *v, double lo, double hi, double *out)
{
    char *e;
    *out = strtod(v, &e);
    if (*e == '%') /* --target 1% */
        e++;
    if (e == v || *e || !(*out >= lo && *out <= hi))
        return wdrctl_fail(EX_USAGE, "study: %s '%s' must be a number in %g..%g", opt, v, lo, hi);
    return EX_OK;
}

/* Knob lists go straight into the knob table: study_expand checks them. */
static int set_option(int c, const char *a, study_opts *o)
{
    study_knobs *k = &o->k;
    double v;
    switch (c) {
    case 'b': o->board = a; return EX_OK;
    case 'f': o->file = a; return EX_OK;
    case 'O': o->outdir = a; return EX_OK;
    case 'j': o->json = 1; return EX_OK;
    case 'N': o->plots = 0; return EX_OK;
    case 'r': return parse_range(a, &o->lo, &o->hi);
    case 't': return parse_targets(a, o);
    case 'R': return parse_number("--fps", a, 1e-3, 1e5, &o->fps);
    case 'J': {
        int rc = parse_number("--jobs", a, 1, 64, &v);
        o->jobs = (int)v;
        return rc;
    }
    case 's': o->seed = strtoul(a, NULL, 0); return EX_OK;
    case 1: k->adc_bits = a; return EX_OK;
    case 2: k->adc_range = a; return EX_OK;
    case 3: k->dac_bits = a; return EX_OK;
    case 4: k->dac_range = a; return EX_OK;
    case 5: k->ranges = a; return EX_OK;
    case 6: k->timing = a; return EX_OK;
    case 7: k->entries = a; return EX_OK;
    case 8: k->timer_hz = a; return EX_OK;
    case 9: k->op = a; return EX_OK;
    case 10: k->params = a; return EX_OK;
    case 11: k->model = a; return EX_OK;
    case 12: k->form = a; return EX_OK;
    case 13: k->coeffs = a; return EX_OK;
    case 14: k->coeff_bits = a; return EX_OK;
    case 15: k->levels = a; return EX_OK;
    case 16: k->levels_choice = a; return EX_OK;
    case 17: k->frames = a; return EX_OK;
    case 18: k->image_frames = a; return EX_OK;
    case 19: k->size = a; return EX_OK;
    default: return wdrctl_fail(EX_USAGE, "study: bad option (see 'wdrctl --help')");
    }
}

static const struct option longopts[] = {{"board", required_argument, NULL, 'b'},
                                         {"study", required_argument, NULL, 'f'},
                                         {"outdir", required_argument, NULL, 'O'},
                                         {"json", no_argument, NULL, 'j'},
                                         {"no-plots", no_argument, NULL, 'N'},
                                         {"range", required_argument, NULL, 'r'},
                                         {"target", required_argument, NULL, 't'},
                                         {"fps", required_argument, NULL, 'R'},
                                         {"jobs", required_argument, NULL, 'J'},
                                         {"seed", required_argument, NULL, 's'},
                                         {"adc-bits", required_argument, NULL, 1},
                                         {"adc-range", required_argument, NULL, 2},
                                         {"dac-bits", required_argument, NULL, 3},
                                         {"dac-range", required_argument, NULL, 4},
                                         {"converter-ranges", required_argument, NULL, 5},
                                         {"timing", required_argument, NULL, 6},
                                         {"entries", required_argument, NULL, 7},
                                         {"dac-timer-hz", required_argument, NULL, 8},
                                         {"operator", required_argument, NULL, 9},
                                         {"param", required_argument, NULL, 10},
                                         {"model", required_argument, NULL, 11},
                                         {"form", required_argument, NULL, 12},
                                         {"coeffs", required_argument, NULL, 13},
                                         {"coeff-bits", required_argument, NULL, 14},
                                         {"levels", required_argument, NULL, 15},
                                         {"levels-choice", required_argument, NULL, 16},
                                         {"frames", required_argument, NULL, 17},
                                         {"image-frames", required_argument, NULL, 18},
                                         {"size", required_argument, NULL, 19},
                                         {NULL, 0, NULL, 0}};

/* The study file first, so the command line's lists override its fields. */
static int parse_options(int argc, char **argv, study_opts *o, void **keep)
{
    *o = (study_opts){
        .board = "sim-vga", .outdir = "study", .lo = 1e-14, .hi = 1e-8, .fps = 30, .jobs = 2, .plots = 1, .seed = 1};
    *keep = NULL;
    int c, rc;
    for (optind = 1; (c = getopt_long(argc, argv, "", longopts, NULL)) != -1;)
        if (c == 'f')
            o->file = optarg;
        else if (c == '?')
            return wdrctl_fail(EX_USAGE, "study: bad option (see 'wdrctl --help')");
    if (o->file && (rc = study_knobs_from_file(o->file, &o->k, keep)) != EX_OK)
        return rc;
    for (optind = 1; (c = getopt_long(argc, argv, "", longopts, NULL)) != -1;)
        if ((rc = set_option(c, optarg, o)) != EX_OK)
            return rc;
    if (optind < argc)
        return wdrctl_fail(EX_USAGE, "study: unexpected argument '%s'", argv[optind]);
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
                s.n, skipped, s.pts[0].width, s.pts[0].height, s.jobs, o.seed);
        double wall = 0;
        rc = study_run(&s, wdrctl_show_progress(), &wall);
        if (rc == EX_OK)
            rc = outputs(&s, &o, wall);
    }
    free(s.pts), free(s.res);
    study_knobs_free_file(keep);
    return rc;
}
