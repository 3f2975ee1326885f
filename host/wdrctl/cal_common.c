/* What `wdrctl calibrate` and `wdrctl fpn report` share (see cal_common.h). */
#include "cal_common.h"
#include "wdr_err.h"
#include "file_io.h"
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- options ---- */

static int parse_on_off(const char *opt, const char *v, int *out)
{
    if (!strcmp(v, "on") || !strcmp(v, "1"))
        return *out = 1, EX_OK;
    if (!strcmp(v, "off") || !strcmp(v, "0"))
        return *out = 0, EX_OK;
    return wdrctl_fail(EX_USAGE, "option %s: '%s' must be on or off", opt, v);
}

static int parse_count(const char *opt, const char *v, int lo, int hi, int *out)
{
    char *end;
    long n = strtol(v, &end, 10);
    if (end == v || *end || n < lo || n > hi)
        return wdrctl_fail(EX_USAGE, "option %s: '%s' must be a whole number in %d..%d", opt, v, lo, hi);
    *out = (int)n;
    return EX_OK;
}

static int form_from_name(const char *name, int *form)
{
    static const struct { const char *name; int id; } names[] = {
        {"moebius", WDR_FORM_MOEBIUS}, {"poly", WDR_FORM_POLY}, {"basis", WDR_FORM_BASIS}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (!strcmp(name, names[i].name))
            return *form = names[i].id, EX_OK;
    return wdrctl_fail(EX_USAGE, "option --form: unknown table form '%s' (known: moebius, poly, basis)", name);
}

const char *cal_form_name(int form)
{
    return form == WDR_FORM_MOEBIUS ? "moebius" : form == WDR_FORM_BASIS ? "basis" : "poly";
}

static int set_option(int c, const char *arg, cal_opts *o)
{
    switch (c) {
    case 'b': o->board = arg; return EX_OK;
    case 'p': o->op_name = arg; return EX_OK;
    case 'm': o->models = arg; return EX_OK;
    case 'c': o->currents = arg; return EX_OK;
    case 'L': o->levels_file = arg; return EX_OK;
    case 'o': o->out = arg; return EX_OK;
    case 'O': o->outdir = arg; return EX_OK;
    case 'd': o->device = arg; return EX_OK;
    case 'l': o->lut = arg; return EX_OK;
    case 'u': o->upload = 1; return EX_OK;
    case 'j': o->json = 1; return EX_OK;
    case 'n': return parse_count("--select", arg, 2, WDR_CAL_MAX_LEVELS - 1, &o->select_n);
    case 'M': return parse_count("--frames", arg, 1, 4096, &o->frames);
    case 'P': return parse_count("--sample", arg, 16, 1 << 20, &o->sample);
    case 'S': return parse_count("--out-scale", arg, 1, 16, &o->out_scale);
    case 'a': return parse_on_off("--adc", arg, &o->adc);
    case 'D': return parse_on_off("--dac", arg, &o->dac);
    case 's': o->seed = strtoul(arg, NULL, 0); return EX_OK;
    case 'F': return form_from_name(arg, &o->form);
    default: return EX_USAGE;
    }
}

int cal_parse_options(int argc, char **argv, const char *cmd, cal_opts *o)
{
    static const struct option longopts[] = {
        {"board", required_argument, NULL, 'b'},    {"operator", required_argument, NULL, 'p'},
        {"model", required_argument, NULL, 'm'},    {"models", required_argument, NULL, 'm'},
        {"currents", required_argument, NULL, 'c'}, {"levels-file", required_argument, NULL, 'L'},
        {"outdir", required_argument, NULL, 'O'},   {"device", required_argument, NULL, 'd'},
        {"upload", no_argument, NULL, 'u'},         {"json", no_argument, NULL, 'j'},
        {"select", required_argument, NULL, 'n'},   {"frames", required_argument, NULL, 'M'},
        {"sample", required_argument, NULL, 'P'},   {"adc", required_argument, NULL, 'a'},
        {"dac", required_argument, NULL, 'D'},      {"seed", required_argument, NULL, 's'},
        {"lut", required_argument, NULL, 'l'},      {"out-scale", required_argument, NULL, 'S'},
        {"form", required_argument, NULL, 'F'},     {NULL, 0, NULL, 0}};
    *o = (cal_opts){.op_name = "reinhard", .frames = 4, .adc = 1, .dac = 1, .sample = 256, .seed = 1, .out_scale = 1,
                    .form = -1};
    optind = 1;
    int c;
    while ((c = getopt_long(argc, argv, "o:", longopts, NULL)) != -1) {
        if (c == '?')
            return wdrctl_fail(EX_USAGE, "%s: bad option (see 'wdrctl --help')", cmd);
        if (set_option(c, optarg, o) != EX_OK)
            return EX_USAGE; /* set_option named the option and the value */
    }
    if (optind < argc)
        return wdrctl_fail(EX_USAGE, "%s: unexpected argument '%s'", cmd, argv[optind]);
    /* As the other board commands: a board when one is named; but --board names the simulator
     * to calibrate, and then $WDR_DEVICE must not send the run (and its uploads) to a board. */
    const char *env = getenv("WDR_DEVICE");
    if (!o->device && !o->board && env && *env)
        o->device = env;
    return EX_OK;
}

int cal_model_from_name(const char *name, int *model)
{
    static const struct { const char *name; int id; } names[] = {
        {"simple3", WDR_MODEL_SIMPLE3}, {"complex4", WDR_MODEL_COMPLEX4}, {"lsq", WDR_MODEL_LSQ},
        {"polymap", WDR_MODEL_POLYMAP}, {"spline", WDR_MODEL_SPLINE}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (!strcmp(name, names[i].name))
            return *model = names[i].id, EX_OK;
    return wdrctl_fail(EX_USAGE, "unknown model '%s' (known: simple3, complex4, lsq, polymap, spline)", name);
}

const char *cal_model_name(int model)
{
    static const char *const names[] = {"none", "simple3", "complex4", "lsq", "polymap", "spline"};
    return model >= 0 && model < WDR_MODEL_COUNT ? names[model] : "?";
}

/* Currents from "a,b,c" or a file of one current per line (# comments); rising, > 0. */
static int parse_current_list(const char *text, const char *what, double *amps, int *n)
{
    char *buf = strdup(text), *save = NULL; /* any length: a fixed copy cut long files silently */
    if (!buf)
        return wdrctl_fail(EX_OSERR, "%s: out of memory", what);
    int rc = EX_OK;
    *n = 0;
    for (char *tok = strtok_r(buf, ", \t\r\n", &save); tok; tok = strtok_r(NULL, ", \t\r\n", &save)) {
        char *end;
        double v = strtod(tok, &end);
        if (end == tok || *end || !isfinite(v) || v <= 0 || *n >= WDR_CAL_MAX_LEVELS) {
            rc = wdrctl_fail(EX_DATAERR, "%s: current '%s' is not a positive finite number (A), or too many", what,
                             tok);
            break;
        }
        if (*n > 0 && !(v > amps[*n - 1])) {
            rc = wdrctl_fail(EX_DATAERR, "%s: currents must rise, %g A follows %g A", what, v, amps[*n - 1]);
            break;
        }
        amps[(*n)++] = v;
    }
    free(buf);
    if (rc != EX_OK)
        return rc;
    return *n ? EX_OK : wdrctl_fail(EX_DATAERR, "%s: no currents", what);
}

/* The whole file, comments blanked: no fixed buffer (a 4 KiB one overflowed on a longer file). */
static int read_levels_file(const char *path, double *amps, int *n)
{
    char *text = wdr_read_text(path);
    if (!text)
        return wdrctl_fail(EX_NOINPUT, "%s: cannot read levels file: %s", path, strerror(errno));
    for (char *p = text; (p = strchr(p, '#')) != NULL;)
        while (*p && *p != '\n')
            *p++ = ' ';
    int rc = parse_current_list(text, path, amps, n);
    free(text);
    return rc;
}

/* ---- the board and the simulated chip ---- */

int cal_load_board(const char *name, wdr_board *b)
{
    char path[1024], err[512];
    wdr_board_path(name ? name : WDR_DEFAULT_BOARD, path, sizeof path);
    wdr_board_defaults(b);
    int rc = wdr_board_load(path, b, err, sizeof err);
    return rc ? wdrctl_fail(rc == WDR_E_IO ? EX_NOINPUT : EX_CONFIG, "%s", err) : EX_OK;
}

int cal_open_sim(const cal_opts *o, const wdr_board *b, sim_chip *c)
{
    char err[512];
    if (wdr_cal_sim_setup(b, o->op_name, o->seed, o->adc, WDR_CAL_MARGIN_V, &c->sim, &c->lut, err, sizeof err))
        return wdrctl_fail(EX_CONFIG, "simulated chip for operator '%s': %s", o->op_name, err);
    if (!o->dac)
        wdr_sim_set_effect(c->sim, WDR_FX_DAC_QUANT, WDR_FX_OFF);
    c->ss = (wdr_cal_simsrc){c->sim, o->adc, 1000};
    return EX_OK;
}

void cal_close_sim(sim_chip *c)
{
    wdr_sim_destroy(c->sim);
    free(c->lut);
}

/* ---- progress ---- */

static void show_progress(void *ctx, int done, int total, double amps)
{
    const char *what = ctx;
    fprintf(stderr, "\r%s: frame %d/%d at %.3g A   ", what, done, total, amps);
    if (done == total)
        fputc('\n', stderr);
}

wdr_cal_progress_fn cal_progress_fn(void) { return wdrctl_show_progress() ? show_progress : NULL; }

/* ---- choosing currents ---- */

int cal_default_currents(int model) { return model == WDR_MODEL_SIMPLE3 ? 3 : model == WDR_MODEL_COMPLEX4 ? 4 : 19; }

void cal_grid_amps(double *amps, int *n)
{
    *n = (int)lround(log10(GRID_HI / GRID_LO) * GRID_PER_DECADE) + 1;
    for (int k = 0; k < *n; k++)
        amps[k] = GRID_LO * pow(10, (double)k / GRID_PER_DECADE);
}

/* Probe a grid of levels and pick the currents that minimise the worst contrast error. */
static int select_from_probe(const cal_opts *o, const wdr_cal_source *src, wdr_cal_config *cfg, int n_cur,
                             wdr_cal_choice *ch, double *lo, double *hi, wdr_cal_levels *grid)
{
    char err[512];
    double amps[WDR_CAL_MAX_LEVELS];
    int n;
    cal_grid_amps(amps, &n);
    int rc = wdr_cal_acquire(src, amps, n, 1, 1, cal_progress_fn(), "probe", grid, err, sizeof err);
    if (rc)
        return wdrctl_fail(EX_IOERR, "probe: %s", err);
    if (wdr_cal_informative_range(grid, MIN_SLOPE_CODES, lo, hi))
        return wdrctl_fail(EX_DATAERR, "the response is flat everywhere: no current range carries contrast");
    cfg->range_lo = *lo, cfg->range_hi = *hi;
    if ((rc = wdr_cal_select_currents(grid, cfg, n_cur, *lo, *hi, o->sample, ch, err, sizeof err)))
        return wdrctl_fail(EX_DATAERR, "current selection: %s", err);
    return EX_OK;
}

/* Currents as given (--currents, --levels-file), or chosen from a probe of the source. */
int cal_plan_currents(const cal_opts *o, const wdr_cal_source *src, cal_run *r, int n_cur)
{
    double amps[WDR_CAL_MAX_LEVELS];
    int n = 0, rc = EX_OK;
    if (o->currents)
        rc = parse_current_list(o->currents, "--currents", amps, &n);
    else if (o->levels_file)
        rc = read_levels_file(o->levels_file, amps, &n);
    if (rc != EX_OK)
        return rc;
    if (n) {
        r->choice.n = 0;
        if (r->cfg.use_dark_ref)
            r->choice.amps[r->choice.n++] = 0;
        for (int k = 0; k < n; k++)
            r->choice.amps[r->choice.n++] = amps[k];
        r->lo = amps[0], r->hi = amps[n - 1];
        r->cfg.range_lo = r->lo, r->cfg.range_hi = r->hi;
        r->choice.worst_pct = NAN;
        return EX_OK;
    }
    wdr_cal_levels grid;
    rc = select_from_probe(o, src, &r->cfg, n_cur, &r->choice, &r->lo, &r->hi, &grid);
    wdr_cal_levels_free(&grid);
    return rc;
}

int cal_acquire_and_fit(const cal_opts *o, const wdr_cal_source *src, cal_run *r, uint32_t sensor_id, int op_id)
{
    char err[512];
    int ref = r->choice.n > 0 && r->choice.amps[0] == 0, n = r->choice.n - ref;
    int rc = wdr_cal_acquire(src, r->choice.amps + ref, n, o->frames, 1, cal_progress_fn(), "calibrate", &r->levels, err,
                             sizeof err);
    if (rc)
        return wdrctl_fail(rc == WDR_E_INVAL ? EX_DATAERR : EX_IOERR, "calibrate: %s", err);
    if (ref) { /* the dark frame is the paper models' dark reference, as level 0 */
        wdr_cal_levels with_dark;
        int idx[WDR_CAL_MAX_LEVELS];
        idx[0] = -1;
        for (int k = 0; k < n; k++)
            idx[k + 1] = k;
        if (wdr_cal_levels_subset(&r->levels, idx, n + 1, &with_dark))
            return wdrctl_fail(EX_OSERR, "out of memory");
        with_dark.dark = r->levels.dark;
        r->levels.dark = NULL;
        wdr_cal_levels_free(&r->levels);
        r->levels = with_dark;
    }
    if ((rc = wdr_cal_fit_array(&r->levels, &r->cfg, &r->res, err, sizeof err)))
        return wdrctl_fail(EX_DATAERR, "calibrate: %s", err);
    if ((rc = wdr_cal_build_table(&r->res, sensor_id, op_id, &r->table, &r->table_len, err, sizeof err)))
        return wdrctl_fail(EX_SOFTWARE, "calibrate: %s", err);
    return EX_OK;
}

void cal_free_run(cal_run *r)
{
    wdr_cal_levels_free(&r->levels);
    wdr_cal_result_free(&r->res);
    free(r->table);
}

/* Output codes: raw_max * out_scale, at most 16 bits. */
void cal_set_output(const cal_opts *o, wdr_cal_config *cfg, unsigned adc_bits)
{
    cfg->raw_max = (1u << adc_bits) - 1u;
    cfg->out_scale = (float)o->out_scale;
    double top = cfg->raw_max * o->out_scale;
    cfg->out_max = (uint16_t)(top < 65535 ? top : 65535);
}

