/* wdrctl operators, wdrctl lut build, wdrctl lut plots: operator tables and their plots. */
#include "board.h"
#include "hdr_image.h"
#include "image_io.h"
#include "operators.h"
#include "plot.h"
#include "ramp.h"
#include "wdr_err.h"
#include "wdr_scene.h"
#include "wdrctl.h"
#include <cJSON.h>
#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define RAMP_SAMPLES 8192
#define CHECK_CURRENTS 2001

typedef struct lut_opts {
    const char *op_name, *board, *out, *csv, *plot, *curve, *scene_image, *scene, *exposure_text;
    wdr_exposure exposure;
    const char *params[16];
    int n_params, json, repair, timing, entries, dac_bits;
    double l_avg, l_max, l_min;
} lut_opts;

typedef struct lut_plots_opts {
    const char *board, *outdir;
} lut_plots_opts;

/* ---- wdrctl operators ---- */

static void print_param(const wdr_param_info *p)
{
    if (isnan(p->def))
        printf("    %-8s default: from scene   range [%g, %g]  %s\n", p->name, p->min, p->max, p->doc);
    else
        printf("    %-8s default: %-12g range [%g, %g]  %s\n", p->name, p->def, p->min, p->max, p->doc);
}

int cmd_operators(int argc, char **argv)
{
    int n_args = 0, rc = wdrctl_parse(&wdrctl_cmd_operators, argc, argv, &(char){0}, &n_args);
    if (rc != EX_OK)
        return rc;
    for (int id = 0; id < WDR_OP_COUNT; id++) {
        const wdr_operator_info *info = wdr_operator_info_by_id(id);
        printf("%-18s %s\n", info->name, info->doc);
        for (int i = 0; i < info->n_params; i++)
            print_param(&info->params[i]);
    }
    printf("\nScene statistics (all operators): L_avg, L_max, L_min in cd/m2; by default L = lum_per_A * I\n"
           "over the board's photocurrent range, with L_avg = 0.18 * lum_per_A * i_center_A.\n");
    return EX_OK;
}

/* ---- options: one row each (cli_options.h) ---- */

#define O(f) offsetof(lut_opts, f)
static const cli_choice timings[] = {{"uniform", WDR_TIMING_UNIFORM}, {"stamped", WDR_TIMING_STAMPED}, {NULL, 0}};
static const cli_option lut_build_rows[] = {
    {"operator", 0, CLI_STRING, O(op_name), "NAME", "tone-mapping operator (see 'wdrctl operators')", .values = "@operators",
     .flags = CLI_REQUIRED},
    {"output", 'o', CLI_STRING, O(out), "LUT.bin", "where the table goes", .flags = CLI_REQUIRED},
    {"param", 0, CLI_LIST, O(params), "KEY=VALUE", "an operator parameter", .max = 16, .count = O(n_params)},
    {"board", 0, CLI_STRING, O(board), "NAME|FILE", "a board name or a board.json (default: the build's -DWDR_BOARD)",
     .values = "@boards"},
    {"csv", 0, CLI_STRING, O(csv), "FILE", "the table as t_s,code,v_ref_V"},
    {"plot", 0, CLI_STRING, O(plot), "FILE.png", "V_ref(t) and the pixel's response (gnuplot)"},
    {"json", 0, CLI_FLAG, O(json), NULL, "print the operator, scene, sensor and worst error as JSON"},
    {"repair", 0, CLI_FLAG, O(repair), NULL, "make an unrealisable operator realisable, and report the change"},
    {"timing", 0, CLI_CHOICE, O(timing), NULL, "DAC clock: uniform ticks or time stamps (default: the board's)",
     .choices = timings, .what = "timing"},
    {"entries", 0, CLI_INT, O(entries), "N", "entries of a uniform-clock table (default: the board's)", .min = 1,
     .max = 65536},
    {"dac-bits", 0, CLI_INT, O(dac_bits), "N", "DAC resolution (default: the board's)", .min = 4, .max = 16},
    {"curve", 0, CLI_STRING, O(curve), "FILE.csv", "the user curve of operator user_curve"},
    {"l-avg", 0, CLI_DOUBLE, O(l_avg), "X", "scene average luminance, cd/m2"},
    {"l-max", 0, CLI_DOUBLE, O(l_max), "X", "scene maximum luminance, cd/m2"},
    {"l-min", 0, CLI_DOUBLE, O(l_min), "X", "scene minimum luminance, cd/m2"},
    {"scene-image", 0, CLI_STRING, O(scene_image), "HDR", "take L_avg, L_max, L_min from an HDR image"},
    {"scene", 0, CLI_STRING, O(scene), "NAME|FILE", "take the statistics from a scene (a name or a file), as the sensor sees it",
     .values = "@scenes"},
    {"exposure", 0, CLI_STRING, O(exposure_text), "auto|A", "with --scene: auto (log-average to the ramp's key) or A per cd/m2"},
    {0}};
#undef O

const cli_command wdrctl_cmd_lut_build = {
    "lut build", NULL, 0, 0, "build the DAC ramp table of an operator, checked against the ideal pixel",
    "Refuses an operator that cannot be realised as a rising ramp over the board's photocurrent range and names "
    "the failing range; --repair makes it realisable instead.",
    lut_build_rows, cmd_lut_build, 0};

static const cli_option lut_plots_rows[] = {
    {"board", 0, CLI_STRING, offsetof(lut_plots_opts, board), "NAME|FILE",
     "a board name or a board.json (default: the build's -DWDR_BOARD)", .values = "@boards"},
    {"outdir", 0, CLI_STRING, offsetof(lut_plots_opts, outdir), "DIR", "where vref_all.png and response_all.png go (default .)"},
    {0}};

const cli_command wdrctl_cmd_lut_plots = {"lut plots", NULL, 0, 0,
                                          "V_ref(t) and the response of every operator on two charts (paper Fig. 2, 3)",
                                          NULL, lut_plots_rows, cmd_lut_plots, 0};

static const cli_option no_rows[] = {{0}};
const cli_command wdrctl_cmd_operators = {"operators", NULL, 0, 0, "list tone-mapping operators, parameters and defaults",
                                          NULL, no_rows, cmd_operators, 0};

static int parse_lut_opts(int argc, char **argv, lut_opts *o)
{
    int n_args;
    memset(o, 0, sizeof *o);
    o->timing = -1;
    o->l_avg = o->l_max = o->l_min = NAN;
    int rc = wdrctl_parse(&wdrctl_cmd_lut_build, argc, argv, o, &n_args);
    if (rc == EX_OK && o->exposure_text && wdr_exposure_parse(o->exposure_text, &o->exposure))
        return wdrctl_fail(EX_USAGE, "option --exposure: '%s' must be auto or A per cd/m2 in (0, 1]", o->exposure_text);
    return rc;
}

/* ---- building ---- */

static int load_board(const char *name, wdr_board *b)
{
    char err[512];
    wdr_board_defaults(b);
    int rc = wdr_board_load_named(name ? name : WDR_DEFAULT_BOARD, b, err, sizeof err);
    if (rc)
        return wdrctl_fail(rc == WDR_E_IO ? EX_NOINPUT : EX_CONFIG, "%s", err);
    return EX_OK;
}

/* Scene statistics measured from an HDR image (luminance in cd/m2). */
int wdrctl_stats_from_image(const char *path, wdr_lum_stats *st)
{
    char err[512];
    float *lum;
    if (access(path, R_OK) != 0)
        return wdrctl_fail(EX_NOINPUT, "%s: cannot read scene image", path);
    long negatives;
    int w, h, rc = wdr_hdr_load_checked(path, &lum, &w, &h, &negatives, err, sizeof err);
    if (rc)
        return wdrctl_fail(rc == WDR_E_IO ? EX_NOINPUT : EX_DATAERR, "%s", err);
    if (negatives)
        fprintf(stderr, "wdrctl: warning: %s: %ld negative pixels clamped to 0\n", path, negatives);
    rc = wdr_lum_stats_measure(lum, (long)w * h, st);
    free(lum);
    if (rc < 0)
        return wdrctl_fail(EX_DATAERR, "%s: field 'pixels': no finite positive luminance", path);
    fprintf(stderr, "wdrctl: scene %s: L_avg %.4g, L_max %.4g, L_min %.4g cd/m2 (%d pixels)\n", path, st->l_avg,
            st->l_max, st->l_min, rc);
    return EX_OK;
}

int wdrctl_stats_from_scene(const wdr_scene *sc, const wdr_board *b, wdr_lum_stats *st)
{
    long n = (long)sc->width * sc->height;
    float *lum = malloc(sizeof *lum * (size_t)n);
    if (!lum)
        return wdrctl_fail(EX_OSERR, "out of memory");
    for (long i = 0; i < n; i++)
        lum[i] = (float)(sc->amps[i] * b->lum_per_amp);
    int rc = wdr_lum_stats_measure(lum, n, st);
    free(lum);
    if (rc < 0)
        return wdrctl_fail(EX_DATAERR, "scene %s: no positive luminance to take statistics from", sc->illumination);
    fprintf(stderr, "wdrctl: scene statistics (%s, as the sensor sees it): L_avg %.4g, L_max %.4g, L_min %.4g cd/m2\n",
            sc->illumination, st->l_avg, st->l_max, st->l_min);
    return EX_OK;
}

/* --scene FILE: statistics of the scene as the sensor sees it, if it names an image. */
static int stats_from_scene_file(const lut_opts *o, const wdr_board *b, wdr_lum_stats *st)
{
    char err[1024];
    wdr_scene sc;
    int rc = wdr_scene_load_exposed(o->scene, b, &o->exposure, &sc, err, sizeof err);
    if (rc)
        return wdrctl_fail(rc == WDR_E_IO ? EX_NOINPUT : EX_DATAERR, "%s", err);
    wdr_scene_print_range(stderr, "wdrctl", &sc, b);
    rc = sc.from_image ? wdrctl_stats_from_scene(&sc, b, st) : EX_OK;
    wdr_scene_free(&sc);
    return rc;
}

static int setup_operator(const lut_opts *o, const wdr_board *b, wdr_operator *op)
{
    char err[512];
    wdr_lum_stats st;
    wdr_lum_stats_default(b->i_min_a, b->i_center_a, b->i_max_a, b->lum_per_amp, 0.18, &st);
    int ex = o->scene_image ? wdrctl_stats_from_image(o->scene_image, &st)
             : o->scene     ? stats_from_scene_file(o, b, &st)
                            : EX_OK;
    if (ex != EX_OK)
        return ex;
    st.l_avg = isnan(o->l_avg) ? st.l_avg : o->l_avg;
    st.l_max = isnan(o->l_max) ? st.l_max : o->l_max;
    st.l_min = isnan(o->l_min) ? st.l_min : o->l_min;
    int rc = wdr_operator_init(op, o->op_name, &st, err, sizeof err);
    if (!rc && op->id == WDR_OP_USER_CURVE && o->curve)
        rc = wdr_operator_load_curve(op, o->curve, err, sizeof err);
    for (int i = 0; !rc && i < o->n_params; i++)
        rc = wdr_operator_set_param(op, o->params[i], err, sizeof err);
    if (!rc)
        rc = wdr_operator_validate(op, err, sizeof err);
    if (rc)
        return wdrctl_fail(rc == WDR_E_IO ? EX_NOINPUT : EX_USAGE, "%s", err);
    return EX_OK;
}

typedef struct lut_result {
    wdr_ideal_pixel px;
    wdr_ramp ramp;
    uint8_t *bytes;
    size_t len;
    wdr_lut_view view;
    double worst_lsb, worst_i;
} lut_result;

static int build_lut(const lut_opts *o, const wdr_board *b, const wdr_operator *op, lut_result *r)
{
    char err[512];
    wdr_ideal_pixel_init(b, &r->px);
    int rc = wdr_ramp_build(&r->px, op, b->i_min_a, b->i_max_a, RAMP_SAMPLES, o->repair, &r->ramp, err, sizeof err);
    if (rc)
        return wdrctl_fail(EX_DATAERR, "%s", err);
    int timing = o->timing >= 0 ? o->timing : b->dac_timing;
    uint32_t entries = o->entries ? (uint32_t)o->entries : b->dac_uniform_entries;
    rc = wdr_ramp_quantise(&r->ramp, b, op, timing, entries, &r->bytes, &r->len, err, sizeof err);
    if (rc)
        return wdrctl_fail(EX_DATAERR, "%s", err);
    rc = wdr_lut_parse(r->bytes, r->len, &r->view);
    if (rc) /* our own encoder produced it: a failure here is a bug, but say so rather than abort */
        return wdrctl_fail(EX_SOFTWARE, "internal: built LUT does not parse (%s)", wdr_strerror(rc));
    r->worst_lsb =
        wdr_ramp_lut_worst_error_lsb(&r->px, op, &r->view, b->i_min_a, b->i_max_a, CHECK_CURRENTS, &r->worst_i);
    /* LUT 1.1: the exposure table for the board's auto exposure, keyed on the ramp's L_avg */
    rc = wdr_ramp_lut_append_exposure(&r->bytes, &r->len, b, op->stats.l_avg / b->lum_per_amp);
    if (!rc)
        rc = wdr_lut_parse(r->bytes, r->len, &r->view);
    if (rc)
        return wdrctl_fail(EX_SOFTWARE, "internal: exposure table: %s", wdr_strerror(rc));
    return EX_OK;
}

/* ---- outputs ---- */

static int write_bytes(const char *path, const void *p, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return wdrctl_fail(EX_CANTCREAT, "%s: cannot create file", path);
    size_t w = fwrite(p, 1, n, f);
    if (fclose(f) || w != n)
        return wdrctl_fail(EX_IOERR, "%s: write failed", path);
    return EX_OK;
}

static int write_csv(const char *path, const wdr_lut_view *lut)
{
    FILE *f = fopen(path, "w");
    if (!f)
        return wdrctl_fail(EX_CANTCREAT, "%s: cannot create file", path);
    double tick = lut->h.tick_ps * 1e-12, lsb = (lut->h.dac_hi_v - lut->h.dac_lo_v) / ((1 << lut->h.dac_bits) - 1);
    fprintf(f, "t_s,code,v_ref_V\n");
    for (uint32_t k = 0; k < lut->h.entry_count; k++) {
        uint32_t t;
        uint16_t code;
        wdr_lut_entry(lut, k, &t, &code);
        fprintf(f, "%.12g,%u,%.9g\n", t * tick, code, lut->h.dac_lo_v + code * lsb);
    }
    return fclose(f) ? wdrctl_fail(EX_IOERR, "%s: write failed", path) : EX_OK;
}

static cJSON *json_params(const wdr_operator *op)
{
    const wdr_operator_info *info = wdr_operator_info_by_id(op->id);
    cJSON *p = cJSON_CreateObject();
    for (int i = 0; i < info->n_params; i++)
        if (isnan(op->p[i]))
            cJSON_AddStringToObject(p, info->params[i].name, "scene");
        else
            cJSON_AddNumberToObject(p, info->params[i].name, op->p[i]);
    return p;
}

static void print_json(const wdr_board *b, const wdr_operator *op, const lut_result *r)
{
    cJSON *root = cJSON_CreateObject(), *sensor = cJSON_CreateObject(), *scene = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "operator", wdr_operator_info_by_id(op->id)->name);
    cJSON_AddItemToObject(root, "params", json_params(op));
    cJSON_AddNumberToObject(scene, "l_avg", op->stats.l_avg);
    cJSON_AddNumberToObject(scene, "l_max", op->stats.l_max);
    cJSON_AddNumberToObject(scene, "l_min", op->stats.l_min);
    cJSON_AddItemToObject(root, "scene", scene);
    cJSON_AddStringToObject(sensor, "board", b->name);
    cJSON_AddNumberToObject(sensor, "c_pd_F", b->c_pd_f);
    cJSON_AddNumberToObject(sensor, "v_n0_V", r->px.v_n0);
    cJSON_AddNumberToObject(sensor, "v_n0_prime_V", r->px.v_dark + b->dark_offset_v);
    cJSON_AddNumberToObject(sensor, "v_dark_V", r->px.v_dark);
    cJSON_AddNumberToObject(sensor, "swing_V", b->swing_v);
    cJSON_AddNumberToObject(sensor, "i_min_A", b->i_min_a);
    cJSON_AddNumberToObject(sensor, "i_max_A", b->i_max_a);
    cJSON_AddItemToObject(root, "sensor", sensor);
    cJSON_AddNumberToObject(root, "dac_bits", r->view.h.dac_bits);
    cJSON_AddStringToObject(root, "timing", r->view.h.timing == WDR_TIMING_UNIFORM ? "uniform" : "stamped");
    cJSON_AddNumberToObject(root, "entries", r->view.h.entry_count);
    cJSON_AddNumberToObject(root, "t_integration_s", r->view.h.t_integration_ticks * (r->view.h.tick_ps * 1e-12));
    cJSON_AddNumberToObject(root, "worst_error_lsb", r->worst_lsb);
    cJSON_AddNumberToObject(root, "worst_error_at_A", r->worst_i);
    cJSON_AddBoolToObject(root, "repaired", r->ramp.repaired);
    if (r->ramp.repaired) {
        cJSON_AddNumberToObject(root, "repaired_from_A", r->ramp.bad_i_lo);
        cJSON_AddNumberToObject(root, "repaired_to_A", r->ramp.bad_i_hi);
        cJSON_AddNumberToObject(root, "repair_max_change_V", r->ramp.repair_max_dev_v);
    }
    char *text = cJSON_Print(root);
    puts(text);
    free(text);
    cJSON_Delete(root);
}

/* Two data files per operator: the ramp (t, V_ref) and the response (I, target, LUT response). */
static int write_plot_data(const char *dir, const char *tag, const wdr_operator *op, const lut_result *r,
                           const wdr_board *b)
{
    char path[1100];
    snprintf(path, sizeof path, "%s/%s.ramp", dir, tag);
    FILE *f = fopen(path, "w");
    if (!f)
        return EX_CANTCREAT;
    for (int j = 0; j < r->ramp.n; j += r->ramp.n / 1024 + 1)
        fprintf(f, "%.9g %.9g\n", r->ramp.t[j] > 0 ? r->ramp.t[j] : 1e-9, r->ramp.v[j]);
    fclose(f);
    snprintf(path, sizeof path, "%s/%s.resp", dir, tag);
    if (!(f = fopen(path, "w")))
        return EX_CANTCREAT;
    wdr_lut_steps steps; /* built once for the 301 points */
    int no_steps = wdr_lut_steps_init(&r->px, &r->view, &steps);
    for (int j = 0; j <= 300; j++) {
        double i = b->i_min_a * pow(b->i_max_a / b->i_min_a, j / 300.0);
        double g = no_steps ? NAN : wdr_lut_steps_response(&r->px, &steps, i);
        fprintf(f, "%.9g %.9g %.9g\n", i, wdr_ideal_target(&r->px, op, i), g);
    }
    wdr_lut_steps_free(&steps);
    fclose(f);
    return EX_OK;
}

static int run_plot(const char *script)
{
    char err[256];
    int rc = wdr_gnuplot_run(script, err, sizeof err);
    if (rc)
        return wdrctl_fail(rc == WDR_E_UNSUPPORTED ? EX_UNAVAILABLE : EX_SOFTWARE, "plot: %s", err);
    return EX_OK;
}

static int plot_one(const char *png, const wdr_operator *op, const lut_result *r, const wdr_board *b)
{
    char dir[512], script[4096];
    if (wdr_plot_tmpdir(dir, sizeof dir))
        return wdrctl_fail(EX_CANTCREAT, "cannot create a temporary directory for plot data");
    int rc = write_plot_data(dir, "op", op, r, b);
    const char *name = wdr_operator_info_by_id(op->id)->name;
    snprintf(script, sizeof script,
             "set terminal pngcairo size 1200,500 font ',10'\nset output '%s'\nset multiplot layout 1,2\n"
             "set grid\nset logscale x\nset format x '10^{%%L}'\n"
             "set title 'Reference ramp V_ref(t), %s' noenhanced\nset xlabel 't (s)'\nset ylabel 'V_{ref} (V)'\n"
             "plot '%s/op.ramp' using 1:2 with lines lw 2 title 'V_{ref}(t)'\n"
             "set title 'Ideal pixel response, %s (worst %.2f LSB)' noenhanced\nset xlabel 'photocurrent (A)'\n"
             "set ylabel 'held G (V)'\n"
             "set y2label 'LUT pixel - g(I) (DAC LSB)'\nset y2tics\nset ytics nomirror\n"
             "plot '%s/op.resp' using 1:2 with lines lw 3 title 'operator g(I)', "
             "'' using 1:3 with lines lw 1 dt 2 title 'pixel with quantised LUT', "
             "'' using 1:(($3-$2)/%.9g) axes x1y2 with lines lw 1 title 'error (LSB)'\nunset multiplot\n",
             png, name, dir, name, r->worst_lsb, dir,
             (r->view.h.dac_hi_v - r->view.h.dac_lo_v) / ((1 << r->view.h.dac_bits) - 1));
    if (rc == EX_OK)
        rc = run_plot(script);
    wdr_plot_tmpdir_remove(dir);
    return rc;
}

static void lut_result_free(lut_result *r)
{
    wdr_ramp_free(&r->ramp);
    free(r->bytes);
    r->bytes = NULL;
}

int cmd_lut_build(int argc, char **argv)
{
    lut_opts o;
    wdr_board b;
    static wdr_operator op; /* large: holds the user curve */
    lut_result r = {0};
    int rc = parse_lut_opts(argc, argv, &o);
    if (rc == EX_OK)
        rc = wdrctl_check_output("lut build", o.plot, ".png");
    if (rc == EX_OK)
        rc = load_board(o.board, &b);
    if (rc == EX_OK && o.dac_bits && (o.dac_bits < 4 || o.dac_bits > 16))
        rc = wdrctl_fail(EX_USAGE, "option --dac-bits: %d is not 4..16", o.dac_bits);
    if (rc == EX_OK && o.dac_bits)
        b.dac_bits = o.dac_bits;
    if (rc == EX_OK)
        rc = setup_operator(&o, &b, &op);
    if (rc == EX_OK)
        rc = build_lut(&o, &b, &op, &r);
    if (rc == EX_OK && r.ramp.repaired)
        fprintf(stderr, "wdrctl: warning: operator %s repaired for %.3g..%.3g A; response changed by up to %.4f V\n",
                wdr_operator_info_by_id(op.id)->name, r.ramp.bad_i_lo, r.ramp.bad_i_hi, r.ramp.repair_max_dev_v);
    if (rc == EX_OK)
        rc = write_bytes(o.out, r.bytes, r.len);
    if (rc == EX_OK && o.csv)
        rc = write_csv(o.csv, &r.view);
    if (rc == EX_OK && o.plot)
        rc = plot_one(o.plot, &op, &r, &b);
    if (rc == EX_OK && o.json)
        print_json(&b, &op, &r);
    lut_result_free(&r);
    return rc;
}

/* ---- wdrctl lut plots: every operator on one chart (paper Fig. 2 and 3) ---- */

static int plot_all_script(const char *outdir, const char *dir, const int *ok)
{
    char script[8192], *p = script;
    size_t left = sizeof script;
    const char *panels[2] = {"ramp", "resp"};
    for (int k = 0; k < 2; k++) {
        int n = snprintf(p, left,
                         "set terminal pngcairo size 900,600 font ',10'\nset output '%s/%s.png'\nset grid\n"
                         "set logscale x\nset format x '10^{%%L}'\nset key %s\nset xlabel '%s'\n"
                         "set ylabel '%s'\nset title '%s'\nplot ",
                         outdir, k ? "response_all" : "vref_all", k ? "left bottom" : "left top",
                         k ? "photocurrent (A)" : "t (s)",
                         k ? "held G (V)" : "V_{ref} (V)",
                         k ? "Ideal pixel response over six decades" : "Reference ramps V_{ref}(t)");
        p += n, left -= (size_t)n;
        for (int id = 0; id < WDR_OP_COUNT; id++) {
            if (!ok[id])
                continue;
            /* one style per operator (plot.h): its own dashes, so curves that coincide
             * (reinhard and reinhard_white over most of the range) both show */
            n = snprintf(p, left, "'%s/%s.%s' using 1:2 with lines lw 2 %s title '%s' noenhanced, ", dir,
                         wdr_operator_info_by_id(id)->name, panels[k], wdr_plot_style(id),
                         wdr_operator_info_by_id(id)->name);
            p += n, left -= (size_t)n;
        }
        p[-2] = '\n', p[-1] = 0, p--, left++;
    }
    return run_plot(script);
}

int cmd_lut_plots(int argc, char **argv)
{
    lut_plots_opts po = {.outdir = "."};
    int n_args, rc = wdrctl_parse(&wdrctl_cmd_lut_plots, argc, argv, &po, &n_args);
    if (rc != EX_OK)
        return rc;
    const char *outdir = po.outdir;
    wdr_board b;
    char dir[512];
    int ok[WDR_OP_COUNT] = {0};
    rc = load_board(po.board, &b);
    if (rc == EX_OK && mkdir(outdir, 0755) && errno != EEXIST)
        return wdrctl_fail(EX_CANTCREAT, "%s: cannot create the output directory (%s)", outdir, strerror(errno));
    if (rc == EX_OK && wdr_plot_tmpdir(dir, sizeof dir))
        return wdrctl_fail(EX_CANTCREAT, "cannot create a temporary directory for plot data");
    for (int id = 0; rc == EX_OK && id < WDR_OP_COUNT; id++) {
        static wdr_operator op;
        lut_result r = {0};
        /* Repair rather than skip: on a physical pixel even `linear` needs it (body effect). */
        lut_opts o = {.op_name = wdr_operator_info_by_id(id)->name, .timing = -1, .l_avg = NAN, .l_max = NAN,
                      .l_min = NAN, .repair = 1};
        if (id == WDR_OP_USER_CURVE)
            continue;
        if (setup_operator(&o, &b, &op) == EX_OK && build_lut(&o, &b, &op, &r) == EX_OK) {
            ok[id] = write_plot_data(dir, o.op_name, &op, &r, &b) == EX_OK;
            printf("%-18s entries %6u  t_int %.4g s  worst %.3f LSB", o.op_name, r.view.h.entry_count,
                   (double)r.view.h.t_integration_ticks * r.view.h.tick_ps * 1e-12, r.worst_lsb);
            if (r.ramp.repaired) /* say why the worst is large: the repair, not the table */
                printf("  (repaired: over %.3g..%.3g A its ramp would have to fall, which a DAC ramp cannot; "
                       "the response there moved by up to %.3f V, which is this worst)",
                       r.ramp.bad_i_lo, r.ramp.bad_i_hi, r.ramp.repair_max_dev_v);
            putchar('\n');
        }
        lut_result_free(&r);
    }
    if (rc == EX_OK)
        rc = plot_all_script(outdir, dir, ok);
    if (rc == EX_OK)
        printf("wrote %s/vref_all.png and %s/response_all.png\n", outdir, outdir);
    wdr_plot_tmpdir_remove(dir);
    return rc;
}
