/* What `wdrctl calibrate` and `wdrctl fpn report` share (see cal_common.h). */
#include "cal_common.h"
#include "cli_number.h"
#include "wdr_err.h"
#include "file_io.h"
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- options ---- */

const cli_choice cal_on_off[] = {{"on", 1}, {"off", 0}, {"1", 1}, {"0", 0}, {NULL, 0}};
const cli_choice cal_forms[] = {
    {"moebius", WDR_FORM_MOEBIUS}, {"poly", WDR_FORM_POLY}, {"basis", WDR_FORM_BASIS},
    {"compact", WDR_FORM_COMPACT}, {"shifted", WDR_FORM_SHIFTED}, {"auto", CAL_FORM_AUTO}, {NULL, 0}};

const char *cal_form_name(int form)
{
    return form == WDR_FORM_MOEBIUS   ? "moebius"
           : form == WDR_FORM_BASIS   ? "basis"
           : form == WDR_FORM_COMPACT ? "compact"
           : form == WDR_FORM_SHIFTED ? "shifted"
                                      : "poly";
}

int cal_parse_flag_limit(const char *text, cal_flag_limit *out)
{
    size_t n = strlen(text);
    int ppm = n > 3 && !strcmp(text + n - 3, "ppm");
    char num[64];
    snprintf(num, sizeof num, "%.*s", (int)(ppm ? n - 3 : n), text);
    long long whole = 0;
    double v = 0;
    int bad = n >= sizeof num ||
              (ppm ? cli_number_double(num, 0, 1e6, &v) : cli_number_long(num, 0, 1LL << 40, &whole)) != CLI_NUM_OK;
    if (bad)
        return wdrctl_fail(EX_USAGE,
                           "option --max-flagged: '%s' must be a whole number of pixels (N, 0 or more) or parts per "
                           "million of the chip's pixels (Nppm, 0..1e6ppm)",
                           text);
    *out = (cal_flag_limit){ppm ? v : (double)whole, ppm, text};
    return EX_OK;
}

double cal_flag_limit_pixels(const cal_flag_limit *l, long n_pixels)
{
    return l->ppm ? l->value * (double)n_pixels / 1e6 : l->value;
}

int cal_parse_options(int argc, char **argv, const cli_command *cmd, cal_opts *o)
{
    int n_args;
    *o = (cal_opts){.op_name = NULL, .frames = 4, .frames_auto = 1, .adc = 1, .dac = 1, .noise = -1,
                    .sample = 256, .seed = 1, .out_scale = 1,
                    .form = -1};
    int rc = wdrctl_parse(cmd, argc, argv, o, &n_args);
    if (rc != EX_OK)
        return rc;
    o->op_asked = o->op_name != NULL;
    o->op_name = o->op_asked ? o->op_name : "reinhard";
    o->noise_asked = o->noise >= 0;
    if (!o->noise_asked)
        o->noise = CAL_NOISE_DEFAULT;
    if (o->frames_text && (o->frames_auto = !strcmp(o->frames_text, "auto")) == 0) {
        long long n = 0;
        if (cli_number_long(o->frames_text, 1, 4096, &n) != CLI_NUM_OK)
            return wdrctl_fail(EX_USAGE, "option --frames: '%s' must be auto or a whole number in 1..4096",
                               o->frames_text);
        o->frames = (int)n;
    }
    rc = cal_parse_flag_limit(o->max_flagged_text ? o->max_flagged_text : CAL_MAX_FLAGGED_DEFAULT, &o->max_flagged);
    if (rc != EX_OK)
        return rc;
    /* --device or $WDR_DEVICE: a board when one is named. But --board names the simulator to
     * calibrate: then only an explicit --device sends the run (and its uploads) to a board. */
    const char *env = wdrctl_global.device, *from_env = getenv("WDR_DEVICE");
    int only_env = env && from_env && env == from_env;
    if ((cmd->flags & CLI_CMD_BOARD) && env && *env && !(o->board && only_env))
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
        double v = 0;
        if (cli_number_double(tok, 0, HUGE_VAL, &v) != CLI_NUM_OK || v <= 0 || *n >= WDR_CAL_MAX_LEVELS) {
            rc = wdrctl_fail(EX_DATAERR, "%s: current '%s' is not a positive finite number (A), or too many", what,
                             tok);
            break;
        }
        if (v < GRID_LO || v > GRID_HI) {
            rc = wdrctl_fail(EX_DATAERR, "%s: level %g A is outside the board's calibration range %g..%g A (the "
                             "photocurrents a pixel's response carries contrast in, which calibrate probes)", what, v,
                             GRID_LO, GRID_HI);
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
    char err[512];
    wdr_board_defaults(b);
    int rc = wdr_board_load_named(name ? name : WDR_DEFAULT_BOARD, b, err, sizeof err);
    return rc ? wdrctl_fail(rc == WDR_E_IO ? EX_NOINPUT : EX_CONFIG, "%s", err) : EX_OK;
}

int cal_design_for(const wdr_board *b, const char *op_name, double t_int_s, wdr_cal_design *d)
{
    char err[512];
    if (wdr_cal_design_init(d, b, op_name, t_int_s, b->height / 2 * b->row_time_s, 1, err, sizeof err))
        return wdrctl_fail(EX_CONFIG, "designed response for operator '%s': %s", op_name, err);
    return EX_OK;
}

int cal_size_margin(const wdr_cal_source *src, const wdr_cal_design *d, wdr_cal_margin_set_fn set, void *ctx,
                    wdr_cal_margin *m)
{
    char err[512];
    wdr_cal_margin_req req;
    wdr_cal_margin_req_for(d, GRID_LO, GRID_HI, PROBE_FRAMES, &req);
    int rc = wdr_cal_margin_size(src, &req, set, ctx, m, err, sizeof err);
    if (rc)
        return wdrctl_fail(rc == WDR_E_INVAL ? EX_DATAERR : EX_IOERR, "calibrate: %s", err);
    fprintf(stderr,
            "wdrctl: calibration margin %.1f mV (+%.1f us of integration): the latest-crossing pixel at %.3g A "
            "crosses %.1f mV above the median one (crossing-level spread %.1f mV sd, guard %.1f mV; %d probe "
            "round%s of %.3g and %.3g A)\n",
            m->margin_v * 1e3, m->added_s * 1e6, m->dim_a, m->latest_v * 1e3, m->spread_v * 1e3, m->guard_v * 1e3,
            m->rounds, m->rounds > 1 ? "s" : "", m->dim_a, m->bright_a);
    return EX_OK;
}

int cal_open_sim(const cal_opts *o, const wdr_board *b, sim_chip *c)
{
    char err[512];
    if (wdr_cal_sim_setup(b, o->op_name, o->seed, o->adc, WDR_CAL_MARGIN_START_V, &c->sim, &c->lut, err, sizeof err))
        return wdrctl_fail(EX_CONFIG, "simulated chip for operator '%s': %s", o->op_name, err);
    if (!o->dac)
        wdr_sim_set_effect(c->sim, WDR_FX_DAC_QUANT, WDR_FX_OFF);
    static const int temporal[] = {WDR_FX_SHOT, WDR_FX_KTC, WDR_FX_READ};
    for (int k = 0; o->noise && k < 3; k++)
        wdr_sim_set_effect(c->sim, temporal[k], WDR_FX_ON);
    c->ss = (wdr_cal_simsrc){c->sim, o->adc, 1000};
    int rc = cal_design_for(b, o->op_name, wdr_sim_integration_time(c->sim), &c->design);
    if (rc == EX_OK) { /* the margin from the chip's frames, then the design for the ramp it made */
        wdr_cal_sim_margin m = {c->sim, b, o->op_name, c->lut};
        wdr_cal_source src = {b->width, b->height, wdr_cal_sim_capture, &c->ss};
        rc = cal_size_margin(&src, &c->design, wdr_cal_sim_set_margin, &m, &c->margin);
        c->lut = m.lut;
    }
    if (rc == EX_OK)
        rc = cal_design_for(b, o->op_name, wdr_sim_integration_time(c->sim), &c->design);
    if (rc != EX_OK)
        cal_close_sim(c);
    return rc;
}

void cal_close_sim(sim_chip *c)
{
    wdr_sim_destroy(c->sim);
    free(c->lut);
    c->sim = NULL, c->lut = NULL;
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

/* The paper's models take 5 light levels (their least-squares fit; --select 3 or 4 is the paper's
 * exact fit): at 12 bits an exact fit through 3 or 4 rounded codes is 1.6-1.8x the quantisation
 * floor, 5 levels 0.8-0.95x (simple3 with 4: 1.31x), at 2 (simple3) or 1 (complex4) more levels'
 * frames (tests/calibration/test_cal_endslope.c). The spline: 19. */
int cal_default_currents(int model) { return model == WDR_MODEL_SIMPLE3 || model == WDR_MODEL_COMPLEX4 ? 5 : 19; }

void cal_grid_amps(double *amps, int *n)
{
    *n = (int)lround(log10(GRID_HI / GRID_LO) * GRID_PER_DECADE) + 1;
    for (int k = 0; k < *n; k++)
        amps[k] = GRID_LO * pow(10, (double)k / GRID_PER_DECADE);
}

int cal_min_select(int model, int n_coeffs)
{
    switch (model) {
    case WDR_MODEL_SIMPLE3: return 3;
    case WDR_MODEL_LSQ: return WDR_LSQ_PARAMS + 2;
    case WDR_MODEL_POLYMAP: return n_coeffs + 2;
    default: return 4; /* complex4, spline */
    }
}

const char *cal_pct_text(double pct, const char *why, char *buf, size_t cap)
{
    if (isfinite(pct))
        snprintf(buf, cap, "%.3g %%", pct);
    else
        snprintf(buf, cap, "n/a (%s)", why);
    return buf;
}

/* --frames auto: from the probe's measured noise (see wdr_cal_frames_for), printed with the reason. */
static int choose_frames(const cal_opts *o, const wdr_cal_levels *probe, cal_run *r)
{
    double med[WDR_CAL_MAX_LEVELS];
    if (wdr_cal_level_medians(probe, NULL, med))
        return wdrctl_fail(EX_OSERR, "out of memory");
    wdr_cal_frames_for(probe, med, r->lo, r->hi, o->adc ? 1.0 : 0.0, AUTO_FRAMES_TARGET_PCT, AUTO_FRAMES_MAX,
                       &r->why);
    r->frames = r->why.frames;
    const char *why = r->why.want_codes > AUTO_FRAMES_TARGET_PCT / 100 * r->why.slope + 1e-12
                          ? "half the ADC quantisation floor"
                          : "a 0.5 % contrast error, half the eye's 1 % threshold";
    if (!(r->why.sigma_codes > 0)) { /* a noiseless source: every frame the same, more buy nothing */
        fprintf(stderr, "wdrctl: --frames auto: %d frames per level: the probe's frames agree exactly (no temporal "
                        "noise measured), so more frames would average nothing\n", r->frames);
        return EX_OK;
    }
    fprintf(stderr,
            "wdrctl: --frames auto: %d frames per level: the measured temporal noise is %.3g codes per frame at "
            "%.3g A, where the response has %.3g codes per unit ln I; %d frames bring it below %.3g codes (%s)",
            r->frames, r->why.sigma_codes, r->why.at_amps, r->why.slope, r->why.needed, r->why.want_codes, why);
    if (r->why.capped) { /* what the cap costs, in the contrast error it leaves at the level that decided */
        double left = r->why.sigma_codes / sqrt((double)r->frames);
        char now[48], then[48];
        const char *flat = "the response is flat there";
        fprintf(stderr,
                "; capped at %d frames, which leave %.3g codes: a %s contrast error from temporal noise "
                "there, where %d frames would leave %s",
                AUTO_FRAMES_MAX, left, cal_pct_text(100 * left / r->why.slope, flat, now, sizeof now), r->why.needed,
                cal_pct_text(100 * r->why.want_codes / r->why.slope, flat, then, sizeof then));
    }
    fputc('\n', stderr);
    return EX_OK;
}

/* Probe a grid of levels and pick the currents that minimise the worst contrast error. */
static int select_from_probe(const cal_opts *o, const wdr_cal_source *src, cal_run *r, int n_cur, wdr_cal_levels *grid)
{
    char err[512];
    double amps[WDR_CAL_MAX_LEVELS];
    int n;
    cal_grid_amps(amps, &n);
    int rc = wdr_cal_acquire(src, amps, n, PROBE_FRAMES, 1, cal_progress_fn(), "probe", grid, err, sizeof err);
    if (rc)
        return wdrctl_fail(EX_IOERR, "probe: %s", err);
    if (wdr_cal_informative_range(grid, MIN_SLOPE_CODES, &r->lo, &r->hi))
        return wdrctl_fail(EX_DATAERR, "the response is flat everywhere: no current range carries contrast");
    r->cfg.range_lo = r->lo, r->cfg.range_hi = r->hi;
    if (wdr_cal_select_currents(grid, &r->cfg, n_cur, r->lo, r->hi, o->sample, &r->choice, err, sizeof err))
        return wdrctl_fail(EX_DATAERR, "current selection: %s", err);
    return o->frames_auto ? choose_frames(o, grid, r) : EX_OK;
}

/* --frames auto with the currents given: two frames at each measure the noise. */
static int probe_given(const cal_opts *o, const wdr_cal_source *src, cal_run *r, const double *amps, int n)
{
    char err[512];
    wdr_cal_levels lv;
    int rc = wdr_cal_acquire(src, amps, n, PROBE_FRAMES, 0, cal_progress_fn(), "noise probe", &lv, err, sizeof err);
    if (rc) /* currents the fits cannot use are a data error, as in the calibration itself */
        return wdrctl_fail(rc == WDR_E_INVAL ? EX_DATAERR : EX_IOERR, "calibrate: %s", err);
    rc = choose_frames(o, &lv, r);
    wdr_cal_levels_free(&lv);
    return rc;
}

/* Currents as given (--currents, --levels-file), or chosen from a probe of the source. */
int cal_plan_currents(const cal_opts *o, const wdr_cal_source *src, cal_run *r, int n_cur)
{
    double amps[WDR_CAL_MAX_LEVELS] = {0};
    int n = 0, rc = EX_OK;
    if (o->currents)
        rc = parse_current_list(o->currents, "--currents", amps, &n);
    else if (o->levels_file)
        rc = read_levels_file(o->levels_file, amps, &n);
    if (rc != EX_OK)
        return rc;
    /* a paper model that cannot serve the operator's designed response is refused before any
     * frame is taken (issue 19): the user spends neither the probe nor the calibration on it */
    char why[1024];
    if (wdr_cal_design_check(r->cfg.design, &r->cfg, n_cur, amps, n, MIN_SLOPE_CODES, why, sizeof why))
        return wdrctl_fail(EX_DATAERR, "calibrate: %s", why);
    if (n) {
        r->choice.n = 0;
        if (r->cfg.use_dark_ref)
            r->choice.amps[r->choice.n++] = 0;
        for (int k = 0; k < n; k++)
            r->choice.amps[r->choice.n++] = amps[k];
        r->lo = amps[0], r->hi = amps[n - 1];
        r->cfg.range_lo = r->lo, r->cfg.range_hi = r->hi;
        r->choice.worst_pct = NAN;
        return o->frames_auto && n >= 2 ? probe_given(o, src, r, amps, n) : EX_OK;
    }
    wdr_cal_levels grid;
    rc = select_from_probe(o, src, r, n_cur, &grid);
    wdr_cal_levels_free(&grid);
    return rc;
}

int cal_acquire_and_fit(const cal_opts *o, const wdr_cal_source *src, cal_run *r, uint32_t sensor_id, int op_id)
{
    char err[512];
    int ref = r->choice.n > 0 && r->choice.amps[0] == 0, n = r->choice.n - ref;
    if (!r->frames)
        r->frames = o->frames;
    int rc = wdr_cal_acquire(src, r->choice.amps + ref, n, r->frames, 1, cal_progress_fn(), "calibrate", &r->levels,
                             err, sizeof err);
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
    if (wdr_cal_fit_array(&r->levels, &r->cfg, &r->res, err, sizeof err))
        return wdrctl_fail(EX_DATAERR, "calibrate: %s", err);
    if (!r->table_later && wdr_cal_build_table(&r->res, sensor_id, op_id, &r->table, &r->table_len, err, sizeof err))
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


void cal_set_step(const wdr_board *b, wdr_cal_config *cfg)
{
    double dac_lsb = (b->dac_hi_v - b->dac_lo_v) / ((1u << b->dac_bits) - 1u);
    double codes_per_v = b->adc_gain * ((1u << b->adc_bits) - 1u) / (b->adc_hi_v - b->adc_lo_v);
    cfg->step_codes = dac_lsb * codes_per_v;
}
