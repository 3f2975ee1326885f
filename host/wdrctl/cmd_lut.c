/* wdrctl operators, wdrctl lut build, wdrctl lut plots: operator tables and their plots. */
#include "board.h"
#include "hdr_image.h"
#include "image_io.h"
#include "operators.h"
#include "plot.h"
#include "ramp.h"
#include "wdr_err.h"
#include "wdrctl.h"
#include <cJSON.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define RAMP_SAMPLES 8192
#define CHECK_CURRENTS 2001

typedef struct lut_opts {
    const char *op_name, *board, *out, *csv, *plot, *curve, *scene_image;
    const char *params[16];
    int n_params, json, repair, timing, entries, dac_bits;
    double l_avg, l_max, l_min;
} lut_opts;

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
    (void)argc;
    (void)argv;
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

/* ---- option parsing ---- */

static int parse_number(const char *opt, const char *text, double *out)
{
    char *end;
    double v = strtod(text, &end);
    if (end == text || *end || !isfinite(v))
        return wdrctl_fail(EX_USAGE, "option %s: '%s' is not a finite number", opt, text);
    *out = v;
    return EX_OK;
}

static int parse_timing(const char *text, int *timing)
{
    if (!strcmp(text, "uniform"))
        *timing = WDR_TIMING_UNIFORM;
    else if (!strcmp(text, "stamped"))
        *timing = WDR_TIMING_STAMPED;
    else
        return wdrctl_fail(EX_USAGE, "option --timing: '%s' is not uniform or stamped", text);
    return EX_OK;
}

static int parse_lut_option(int c, lut_opts *o)
{
    double v = 0;
    int rc = EX_OK;
    switch (c) {
    case 'p':
        if (o->n_params == 16)
            return wdrctl_fail(EX_USAGE, "too many --param options");
        o->params[o->n_params++] = optarg;
        break;
    case 'O': o->op_name = optarg; break;
    case 'b': o->board = optarg; break;
    case 'o': o->out = optarg; break;
    case 'c': o->csv = optarg; break;
    case 'P': o->plot = optarg; break;
    case 'u': o->curve = optarg; break;
    case 'S': o->scene_image = optarg; break;
    case 'j': o->json = 1; break;
    case 'r': o->repair = 1; break;
    case 't': rc = parse_timing(optarg, &o->timing); break;
    case 'e':
    case 'd':
        if ((rc = parse_number(c == 'e' ? "--entries" : "--dac-bits", optarg, &v)) == EX_OK) {
            if (v != floor(v) || v < 1 || v > 65536)
                return wdrctl_fail(EX_USAGE, "option %s: %s is out of range", c == 'e' ? "--entries" : "--dac-bits",
                                   optarg);
            *(c == 'e' ? &o->entries : &o->dac_bits) = (int)v;
        }
        break;
    case 'A': rc = parse_number("--l-avg", optarg, &o->l_avg); break;
    case 'M': rc = parse_number("--l-max", optarg, &o->l_max); break;
    case 'N': rc = parse_number("--l-min", optarg, &o->l_min); break;
    default: return EX_USAGE;
    }
    return rc;
}

static int parse_lut_opts(int argc, char **argv, lut_opts *o)
{
    static const struct option longopts[] = {
        {"operator", required_argument, 0, 'O'}, {"param", required_argument, 0, 'p'},
        {"board", required_argument, 0, 'b'},    {"csv", required_argument, 0, 'c'},
        {"plot", required_argument, 0, 'P'},     {"json", no_argument, 0, 'j'},
        {"repair", no_argument, 0, 'r'},         {"timing", required_argument, 0, 't'},
        {"entries", required_argument, 0, 'e'},  {"dac-bits", required_argument, 0, 'd'},
        {"curve", required_argument, 0, 'u'},    {"l-avg", required_argument, 0, 'A'},
        {"l-max", required_argument, 0, 'M'},    {"l-min", required_argument, 0, 'N'},
        {"scene-image", required_argument, 0, 'S'},
        {0, 0, 0, 0}};
    memset(o, 0, sizeof *o);
    o->timing = -1;
    o->l_avg = o->l_max = o->l_min = NAN;
    optind = 1;
    int c, rc;
    while ((c = getopt_long(argc, argv, "o:", longopts, NULL)) != -1)
        if ((rc = parse_lut_option(c, o)) != EX_OK)
            return rc;
    if (optind < argc)
        return wdrctl_fail(EX_USAGE, "unexpected argument '%s'", argv[optind]);
    if (!o->op_name)
        return wdrctl_fail(EX_USAGE, "lut build needs --operator NAME (see 'wdrctl operators')");
    return EX_OK;
}

/* ---- building ---- */

static int load_board(const char *name, wdr_board *b)
{
    char path[1024], err[512];
    wdr_board_path(name ? name : WDR_DEFAULT_BOARD, path, sizeof path);
    wdr_board_defaults(b);
    int rc = wdr_board_load(path, b, err, sizeof err);
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
    int w, h, rc = wdr_hdr_load(path, &lum, &w, &h, err, sizeof err);
    if (rc)
        return wdrctl_fail(rc == WDR_E_IO ? EX_NOINPUT : EX_DATAERR, "%s", err);
    rc = wdr_lum_stats_measure(lum, (long)w * h, st);
    free(lum);
    if (rc < 0)
        return wdrctl_fail(EX_DATAERR, "%s: field 'pixels': no finite positive luminance", path);
    fprintf(stderr, "wdrctl: scene %s: L_avg %.4g, L_max %.4g, L_min %.4g cd/m2 (%d pixels)\n", path, st->l_avg,
            st->l_max, st->l_min, rc);
    return EX_OK;
}

static int setup_operator(const lut_opts *o, const wdr_board *b, wdr_operator *op)
{
    char err[512];
    wdr_lum_stats st;
    wdr_lum_stats_default(b->i_min_a, b->i_center_a, b->i_max_a, b->lum_per_amp, 0.18, &st);
    int ex = o->scene_image ? wdrctl_stats_from_image(o->scene_image, &st) : EX_OK;
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
    for (int j = 0; j <= 300; j++) {
        double i = b->i_min_a * pow(b->i_max_a / b->i_min_a, j / 300.0);
        fprintf(f, "%.9g %.9g %.9g\n", i, wdr_ideal_target(&r->px, op, i), wdr_ramp_lut_ideal_response(&r->px, &r->view, i));
    }
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
    if (rc == EX_OK && !o.out)
        rc = wdrctl_fail(EX_USAGE, "lut build needs -o LUT.bin");
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
            n = snprintf(p, left, "'%s/%s.%s' using 1:2 with lines lw 2 title '%s' noenhanced, ", dir,
                         wdr_operator_info_by_id(id)->name, panels[k], wdr_operator_info_by_id(id)->name);
            p += n, left -= (size_t)n;
        }
        p[-2] = '\n', p[-1] = 0, p--, left++;
    }
    return run_plot(script);
}

int cmd_lut_plots(int argc, char **argv)
{
    const char *outdir = ".", *board = NULL;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--outdir") && i + 1 < argc)
            outdir = argv[++i];
        else if (!strcmp(argv[i], "--board") && i + 1 < argc)
            board = argv[++i];
        else
            return wdrctl_fail(EX_USAGE, "lut plots: unknown argument '%s'", argv[i]);
    }
    wdr_board b;
    char dir[512];
    int rc = load_board(board, &b), ok[WDR_OP_COUNT] = {0};
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
            printf("%-18s entries %6u  t_int %.4g s  worst %.3f LSB%s\n", o.op_name, r.view.h.entry_count,
                   (double)r.view.h.t_integration_ticks * r.view.h.tick_ps * 1e-12, r.worst_lsb,
                   r.ramp.repaired ? "  (repaired to be realisable)" : "");
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
