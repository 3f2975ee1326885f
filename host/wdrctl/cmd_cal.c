/* wdrctl calibrate and wdrctl fpn report: fixed-pattern-noise calibration and its figures.
 * The frame source is the simulator itself (--sim, default) or a board (--device): a simulated
 * board sets its illuminant, a real one asks a person to set each light level. */
#include "board.h"
#include "cal_select.h"
#include "correct.h"
#include "image_io.h"
#include "operators.h"
#include "plot.h"
#include "transport_client.h"
#include "wdr_err.h"
#include "wdrctl.h"
#include <cJSON.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define GRID_LO 1e-14
#define GRID_HI 1e-8
#define GRID_PER_DECADE 6
#define N_EVAL 31
#define MIN_SLOPE_CODES 2.0

typedef struct cal_opts {
    const char *board, *op_name, *models, *currents, *levels_file, *out, *outdir, *device, *lut;
    int select_n, frames, adc, dac, upload, json, sample, out_scale;
    int form; /* enum wdr_cal_form; -1: the model's default */
    unsigned long seed;
} cal_opts;

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
        {"moebius", WDR_FORM_MOEBIUS}, {"poly", WDR_FORM_POLY}, {"basis", WDR_FORM_BASIS},
        {"compact", WDR_FORM_COMPACT}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (!strcmp(name, names[i].name))
            return *form = names[i].id, EX_OK;
    return wdrctl_fail(EX_USAGE, "option --form: unknown table form '%s' (known: moebius, poly, basis, compact)", name);
}

static const char *form_name(int form)
{
    return form == WDR_FORM_MOEBIUS   ? "moebius"
           : form == WDR_FORM_BASIS   ? "basis"
           : form == WDR_FORM_COMPACT ? "compact"
                                      : "poly";
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

static int parse_options(int argc, char **argv, const char *cmd, cal_opts *o)
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
    const char *env = getenv("WDR_DEVICE"); /* as the other board commands: a board when one is named */
    if (!o->device && env && *env)
        o->device = env;
    return EX_OK;
}

static int model_from_name(const char *name, int *model)
{
    static const struct { const char *name; int id; } names[] = {
        {"simple3", WDR_MODEL_SIMPLE3}, {"complex4", WDR_MODEL_COMPLEX4}, {"lsq", WDR_MODEL_LSQ},
        {"polymap", WDR_MODEL_POLYMAP}, {"spline", WDR_MODEL_SPLINE}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (!strcmp(name, names[i].name))
            return *model = names[i].id, EX_OK;
    return wdrctl_fail(EX_USAGE, "unknown model '%s' (known: simple3, complex4, lsq, polymap, spline)", name);
}

static const char *model_name(int model)
{
    static const char *const names[] = {"none", "simple3", "complex4", "lsq", "polymap", "spline"};
    return model >= 0 && model < WDR_MODEL_COUNT ? names[model] : "?";
}

/* Currents from "a,b,c" or a file of one current per line (# comments); rising, > 0. */
static int parse_current_list(const char *text, const char *what, double *amps, int *n)
{
    char buf[4096], *save = NULL;
    snprintf(buf, sizeof buf, "%s", text);
    *n = 0;
    for (char *tok = strtok_r(buf, ", \t\r\n", &save); tok; tok = strtok_r(NULL, ", \t\r\n", &save)) {
        char *end;
        double v = strtod(tok, &end);
        if (end == tok || *end || !isfinite(v) || v <= 0 || *n >= WDR_CAL_MAX_LEVELS)
            return wdrctl_fail(EX_DATAERR, "%s: current '%s' is not a positive finite number (A), or too many",
                               what, tok);
        if (*n > 0 && !(v > amps[*n - 1]))
            return wdrctl_fail(EX_DATAERR, "%s: currents must rise, %g A follows %g A", what, v, amps[*n - 1]);
        amps[(*n)++] = v;
    }
    return *n ? EX_OK : wdrctl_fail(EX_DATAERR, "%s: no currents", what);
}

static int read_levels_file(const char *path, double *amps, int *n)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return wdrctl_fail(EX_NOINPUT, "%s: cannot read levels file", path);
    char text[4096] = "", line[256];
    while (fgets(line, sizeof line, f)) {
        char *hash = strchr(line, '#');
        if (hash)
            *hash = 0;
        strncat(text, line, sizeof text - strlen(text) - 2);
        strcat(text, "\n");
    }
    fclose(f);
    return parse_current_list(text, path, amps, n);
}

/* ---- the board and the simulated chip ---- */

static int load_board(const char *name, wdr_board *b)
{
    char path[1024], err[512];
    wdr_board_path(name ? name : WDR_DEFAULT_BOARD, path, sizeof path);
    wdr_board_defaults(b);
    int rc = wdr_board_load(path, b, err, sizeof err);
    return rc ? wdrctl_fail(rc == WDR_E_IO ? EX_NOINPUT : EX_CONFIG, "%s", err) : EX_OK;
}

typedef struct sim_chip {
    wdr_sim *sim;
    uint8_t *lut;
    wdr_cal_simsrc ss;
} sim_chip;

static int open_sim(const cal_opts *o, const wdr_board *b, sim_chip *c)
{
    char err[512];
    if (wdr_cal_sim_setup(b, o->op_name, o->seed, o->adc, WDR_CAL_MARGIN_V, &c->sim, &c->lut, err, sizeof err))
        return wdrctl_fail(EX_CONFIG, "simulated chip for operator '%s': %s", o->op_name, err);
    if (!o->dac)
        wdr_sim_set_effect(c->sim, WDR_FX_DAC_QUANT, WDR_FX_OFF);
    c->ss = (wdr_cal_simsrc){c->sim, o->adc, 1000};
    return EX_OK;
}

static void close_sim(sim_chip *c)
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

static wdr_cal_progress_fn progress_fn(void) { return wdrctl_show_progress() ? show_progress : NULL; }

/* ---- a board as the frame source ---- */

typedef struct device_src {
    wdrctl_conn conn;
    int simulated;      /* the board takes SET_ILLUMINANT */
    double amps;        /* level the light is at */
    uint16_t *codes;
    float *frame;
    int err;
} device_src;

static int on_device_frame(void *ctx, const wdr_frame *f)
{
    device_src *d = ctx;
    for (long i = 0; i < (long)f->width * f->height; i++)
        d->frame[i] = f->codes[i];
    return WDR_OK;
}

/* A person sets the light on a real board: one prompt per level, on the terminal. */
static int prompt_level(double amps)
{
    fprintf(stderr, "Set a uniform light giving %.4g A per pixel (0: cover the sensor), then press Enter: ", amps);
    int ch;
    while ((ch = getchar()) != '\n' && ch != EOF)
        ;
    return ch == EOF ? WDR_E_IO : WDR_OK;
}

static int device_capture(void *ctx, double amps, int frame_no, float *frame)
{
    device_src *d = ctx;
    (void)frame_no;
    if (amps != d->amps) {
        int rc = d->simulated ? wdr_client_set_illuminant(d->conn.c, amps) : prompt_level(amps);
        if (rc)
            return rc;
        d->amps = amps;
    }
    d->frame = frame;
    return wdr_client_capture(d->conn.c, 1, d->codes, on_device_frame, d);
}

/* Calibration frames must be raw: store a pass-through table (polynomial v = y, output scale 1)
 * before capturing, since the board corrects every row with its active table. */
static int upload_passthrough(device_src *d)
{
    const wdr_info *in = &d->conn.c->info;
    long np = (long)in->width * in->height;
    uint16_t raw_max = (uint16_t)((1u << in->adc_bits) - 1u);
    float *coeffs = malloc(sizeof(float) * 2 * (size_t)np);
    uint8_t *flags = calloc((size_t)np, 1);
    size_t len = wdr_cal_size(in->width, in->height, 2);
    uint8_t *buf = malloc(len);
    if (!coeffs || !flags || !buf) {
        free(coeffs), free(flags), free(buf);
        return WDR_E_NOMEM;
    }
    for (long i = 0; i < 2 * np; i++)
        coeffs[i] = raw_max / 2.0f;
    wdr_cal_header h = {.sensor_id = in->sensor_id, .width = in->width, .height = in->height,
                        .form = WDR_FORM_POLY, .n_coeffs = 2, .in_scale = 2.0f / raw_max, .in_offset = -1,
                        .out_scale = 1, .out_max = raw_max, .raw_max = raw_max};
    wdr_cal_encode(&h, coeffs, flags, buf);
    wdr_commit_reply reply;
    int rc = wdr_client_upload(d->conn.c, WDR_KIND_CAL, buf, len, NULL, NULL, &reply);
    free(coeffs), free(flags), free(buf);
    return rc;
}

/* The LUT the board will image with, continued past its last code by the calibration margin
 * (so that pixels with high thresholds cross at the dimmest currents), stored on the board. */
static int upload_lut_with_margin(device_src *d, const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return wdrctl_fail(EX_NOINPUT, "%s: cannot read LUT", path);
    uint8_t *buf = malloc(WDR_LUT_HEADER_SIZE + (size_t)WDR_LUT_MAX_ENTRIES * WDR_LUT_ENTRY_SIZE), *ext = NULL;
    size_t len = buf ? fread(buf, 1, WDR_LUT_HEADER_SIZE + (size_t)WDR_LUT_MAX_ENTRIES * WDR_LUT_ENTRY_SIZE, f) : 0,
           ext_len;
    fclose(f);
    char err[512];
    double added_s, done_v;
    int rc = buf ? wdr_cal_lut_extend(buf, len, WDR_CAL_MARGIN_V, WDR_CAL_MARGIN_MAX_TIME_FRAC, &ext, &ext_len, &added_s, &done_v, err, sizeof err)
                 : WDR_E_NOMEM;
    free(buf);
    if (rc)
        return wdrctl_fail(EX_DATAERR, "%s: %s", path, rc == WDR_E_NOMEM ? "out of memory" : err);
    wdr_commit_reply reply;
    rc = wdr_client_upload(d->conn.c, WDR_KIND_LUT, ext, ext_len, NULL, NULL, &reply);
    free(ext);
    if (rc)
        return wdrctl_conn_fail(&d->conn, rc);
    fprintf(stderr, "wdrctl: %s stored with a %.0f mV calibration margin (+%.3g s of integration)\n", path,
            done_v * 1e3, added_s);
    return EX_OK;
}

static int open_device(const cal_opts *o, device_src *d, wdr_cal_source *src)
{
    memset(d, 0, sizeof *d);
    d->amps = -1;
    int rc = wdrctl_connect(o->device, WDR_CLIENT_TIMEOUT_MS, WDR_CLIENT_RETRIES, &d->conn);
    if (rc != EX_OK)
        return rc;
    const wdr_info *in = &d->conn.c->info;
    d->codes = malloc(sizeof(uint16_t) * (size_t)in->width * in->height);
    if (!d->codes)
        return wdrctl_fail(EX_OSERR, "out of memory for a %ux%u frame", in->width, in->height);
    d->simulated = (in->caps & WDR_INFO_CAP_ILLUMINANT) != 0;
    if (!d->simulated && !o->currents && !o->levels_file)
        return wdrctl_fail(EX_USAGE, "calibrate: %s sets no light itself: give the levels you will set with "
                           "--currents A,B,.. or --levels-file FILE (you are asked for each)", o->device);
    if (o->lut && (rc = upload_lut_with_margin(d, o->lut)) != EX_OK)
        return rc;
    int r = upload_passthrough(d);
    if (r)
        return wdrctl_conn_fail(&d->conn, r);
    *src = (wdr_cal_source){in->width, in->height, device_capture, d};
    return EX_OK;
}

static void close_device(device_src *d)
{
    free(d->codes);
    wdrctl_disconnect(&d->conn);
}

/* ---- choosing currents ---- */

static int default_currents(int model) { return model == WDR_MODEL_SIMPLE3 ? 3 : model == WDR_MODEL_COMPLEX4 ? 4 : 19; }

static void grid_amps(double *amps, int *n)
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
    grid_amps(amps, &n);
    int rc = wdr_cal_acquire(src, amps, n, 1, 1, progress_fn(), "probe", grid, err, sizeof err);
    if (rc)
        return wdrctl_fail(EX_IOERR, "probe: %s", err);
    if (wdr_cal_informative_range(grid, MIN_SLOPE_CODES, lo, hi))
        return wdrctl_fail(EX_DATAERR, "the response is flat everywhere: no current range carries contrast");
    cfg->range_lo = *lo, cfg->range_hi = *hi;
    if ((rc = wdr_cal_select_currents(grid, cfg, n_cur, *lo, *hi, o->sample, ch, err, sizeof err)))
        return wdrctl_fail(EX_DATAERR, "current selection: %s", err);
    return EX_OK;
}

/* ---- wdrctl calibrate ---- */

typedef struct cal_run {
    wdr_cal_config cfg;
    wdr_cal_choice choice;
    wdr_cal_levels levels;
    wdr_cal_result res;
    uint8_t *table;
    size_t table_len;
    double lo, hi;
} cal_run;

/* Currents as given (--currents, --levels-file), or chosen from a probe of the source. */
static int plan_currents(const cal_opts *o, const wdr_cal_source *src, cal_run *r, int n_cur)
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

static int acquire_and_fit(const cal_opts *o, const wdr_cal_source *src, cal_run *r, uint32_t sensor_id, int op_id)
{
    char err[512];
    int ref = r->choice.n > 0 && r->choice.amps[0] == 0, n = r->choice.n - ref;
    int rc = wdr_cal_acquire(src, r->choice.amps + ref, n, o->frames, 1, progress_fn(), "calibrate", &r->levels, err,
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

static int write_file(const char *path, const uint8_t *buf, size_t len)
{
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(buf, 1, len, f) != len) {
        if (f)
            fclose(f);
        return wdrctl_fail(EX_CANTCREAT, "%s: cannot write calibration table", path);
    }
    return fclose(f) ? wdrctl_fail(EX_IOERR, "%s: write failed", path) : EX_OK;
}

static void print_summary(const cal_opts *o, const cal_run *r)
{
    const wdr_cal_result *res = &r->res;
    if (!o->json) {
        printf("model %s, table form %s (%d coefficients), %ld of %ld pixels flagged\ncurrents:", model_name(res->model),
               form_name(r->cfg.form), r->cfg.form == WDR_FORM_MOEBIUS ? 3 : r->cfg.n_coeffs,
               res->n_bad, (long)res->width * res->height);
        for (int k = 0; k < r->choice.n; k++)
            printf(" %.4g", r->choice.amps[k]);
        printf(" A (0: dark reference)\nworst contrast error at selection: %.4g %%\n", r->choice.worst_pct);
        return;
    }
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "model", model_name(res->model));
    cJSON_AddStringToObject(j, "form", form_name(r->cfg.form));
    cJSON_AddNumberToObject(j, "coefficients", r->cfg.form == WDR_FORM_MOEBIUS ? 3 : r->cfg.n_coeffs);
    cJSON_AddItemToObject(j, "currents_A", cJSON_CreateDoubleArray(r->choice.amps, r->choice.n));
    cJSON_AddNumberToObject(j, "range_lo_A", r->lo);
    cJSON_AddNumberToObject(j, "range_hi_A", r->hi);
    if (isfinite(r->choice.worst_pct))
        cJSON_AddNumberToObject(j, "selection_worst_pct", r->choice.worst_pct);
    cJSON_AddNumberToObject(j, "pixels_flagged", (double)res->n_bad);
    static const char *flag_names[] = {"dead", "stuck", "hot", "saturated", "unfit"};
    cJSON *f = cJSON_AddObjectToObject(j, "flags");
    for (int b = 0; b < 5; b++)
        cJSON_AddNumberToObject(f, flag_names[b], (double)res->n_flag[b]);
    cJSON *why = cJSON_AddObjectToObject(j, "unfit_reasons");
    for (int st = 1; st < WDR_FIT_COUNT; st++)
        if (res->n_status[st])
            cJSON_AddNumberToObject(why, wdr_fit_status_name(st), (double)res->n_status[st]);
    cJSON_AddNumberToObject(j, "table_bytes", (double)r->table_len);
    char *text = cJSON_Print(j);
    printf("%s\n", text);
    free(text);
    cJSON_Delete(j);
}

static int upload_table(device_src *d, const cal_run *r)
{
    wdr_commit_reply reply;
    int rc = wdr_client_upload(d->conn.c, WDR_KIND_CAL, r->table, r->table_len, NULL, NULL, &reply);
    if (rc)
        return wdrctl_conn_fail(&d->conn, rc);
    fprintf(stderr, "wdrctl: calibration table uploaded and active\n");
    return EX_OK;
}

static void free_run(cal_run *r)
{
    wdr_cal_levels_free(&r->levels);
    wdr_cal_result_free(&r->res);
    free(r->table);
}

/* Output codes: raw_max * out_scale, at most 16 bits. */
static void set_output(const cal_opts *o, wdr_cal_config *cfg, unsigned adc_bits)
{
    cfg->raw_max = (1u << adc_bits) - 1u;
    cfg->out_scale = (float)o->out_scale;
    double top = cfg->raw_max * o->out_scale;
    cfg->out_max = (uint16_t)(top < 65535 ? top : 65535);
}

static int calibrate_with(const cal_opts *o, const wdr_cal_source *src, cal_run *r, uint32_t sensor_id, int op_id,
                          int model)
{
    int rc = plan_currents(o, src, r, o->select_n ? o->select_n : default_currents(model));
    if (rc == EX_OK)
        rc = acquire_and_fit(o, src, r, sensor_id, op_id);
    if (rc == EX_OK && o->out)
        rc = write_file(o->out, r->table, r->table_len);
    if (rc == EX_OK)
        print_summary(o, r);
    return rc;
}

int cmd_calibrate(int argc, char **argv)
{
    cal_opts o;
    wdr_board b;
    int model = WDR_MODEL_SPLINE, rc = parse_options(argc, argv, "calibrate", &o);
    if (rc != EX_OK || (o.models && (rc = model_from_name(o.models, &model)) != EX_OK))
        return rc;
    if (!o.out && !o.upload)
        return wdrctl_fail(EX_USAGE, "calibrate: give -o CAL.bin and/or --upload");
    if ((o.upload || o.lut) && !o.device)
        return wdrctl_fail(EX_USAGE, "calibrate: --upload and --lut need --device");
    cal_run r = {0};
    wdr_cal_config_defaults(&r.cfg, model);
    if (o.form == WDR_FORM_MOEBIUS && model != WDR_MODEL_SIMPLE3)
        return wdrctl_fail(EX_USAGE, "calibrate: --form moebius is exact only for --model simple3");
    if (o.form >= 0)
        r.cfg.form = o.form;
    if (o.form == WDR_FORM_COMPACT)
        r.cfg.n_coeffs = WDR_CAL_COMPACT_COEFFS;
    if (o.device) {
        device_src d;
        wdr_cal_source src;
        if ((rc = open_device(&o, &d, &src)) == EX_OK) {
            set_output(&o, &r.cfg, d.conn.c->info.adc_bits); /* the board's operator is unknown here: basis-8 */
            rc = calibrate_with(&o, &src, &r, d.conn.c->info.sensor_id, WDR_OP_REINHARD, model);
            if (rc == EX_OK && o.upload)
                rc = upload_table(&d, &r);
        }
        close_device(&d);
        free_run(&r);
        return rc;
    }
    sim_chip c;
    const wdr_operator_info *op = wdr_operator_info_by_name(o.op_name);
    if (!op)
        return wdrctl_fail(EX_USAGE, "calibrate: unknown operator '%s' (see 'wdrctl operators')", o.op_name);
    if ((rc = load_board(o.board, &b)) != EX_OK || (rc = open_sim(&o, &b, &c)) != EX_OK)
        return rc;
    set_output(&o, &r.cfg, (unsigned)b.adc_bits);
    if (o.form < 0)
        wdr_cal_default_form(&r.cfg, op->id);
    r.cfg.tie_codes = o.adc ? r.cfg.tie_codes : 1e-3; /* unquantised codes: only a clipped pixel ties */
    wdr_cal_source src = {b.width, b.height, wdr_cal_sim_capture, &c.ss};
    rc = calibrate_with(&o, &src, &r, b.sensor_id, op->id, model);
    free_run(&r);
    close_sim(&c);
    return rc;
}

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
    set_output(&rp->o, &r->cfg, (unsigned)rp->b.adc_bits);
    r->cfg.range_lo = rp->lo, r->cfg.range_hi = rp->hi;
    r->cfg.tie_codes = rp->o.adc ? r->cfg.tie_codes : 1e-3;
    r->lo = rp->lo, r->hi = rp->hi;
    if (wdr_cal_select_currents(&rp->grid, &r->cfg, default_currents(m->model), rp->lo, rp->hi, rp->o.sample,
                                &r->choice, err, sizeof err))
        return wdrctl_fail(EX_DATAERR, "fpn report: %s: %s", model_name(m->model), err);
    int rc = acquire_and_fit(&rp->o, &rp->src, r, rp->b.sensor_id, 0);
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
    fprintf(stderr, "fpn report: %s: worst contrast error %.3g %% (model), %.3g %% (table)\n", model_name(m->model),
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
                      data, 3 + 2 * i, model_name(rp->m[i].model), data, 4 + 2 * i, model_name(rp->m[i].model));
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
             model_name(m->model), sa.sd_pct, path);
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
        snprintf(path, sizeof path, "%.900s/test_image_corrected_%s.png", rp->o.outdir, model_name(m->model));
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
    cJSON_AddStringToObject(j, "model", model_name(m->model));
    cJSON_AddStringToObject(j, "table_form", form_name(r->cfg.form));
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
        int rc = model_from_name(t, &rp->m[rp->n_models].model);
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
    if ((rc = load_board(rp->o.board, &rp->b)) != EX_OK || (rc = open_sim(&rp->o, &rp->b, &rp->chip)) != EX_OK)
        return rc;
    rp->src = (wdr_cal_source){rp->b.width, rp->b.height, wdr_cal_sim_capture, &rp->chip.ss};
    rp->lsb_mv = codes_to_mv(&rp->b);
    grid_amps(amps, &n);
    if (wdr_cal_acquire(&rp->src, amps, n, rp->o.frames, 1, progress_fn(), "fpn report", &rp->grid, err, sizeof err))
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

int cmd_fpn_report(int argc, char **argv)
{
    report *rp = calloc(1, sizeof *rp);
    if (!rp)
        return wdrctl_fail(EX_OSERR, "out of memory");
    int rc = parse_options(argc, argv, "fpn report", &rp->o);
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
        free_run(&rp->m[i].run);
    wdr_cal_levels_free(&rp->grid);
    if (rp->chip.sim)
        close_sim(&rp->chip);
    free(rp);
    return rc;
}
