/* wdrctl tonemap: the scene tone-mapped in software, and a capture beside it. */
#include "board.h"
#include "file_io.h"
#include "image_io.h"
#include "operators.h"
#include "ramp.h"
#include "tonemap.h"
#include "wdr_err.h"
#include "wdr_scene.h"
#include "wdrctl.h"
#include <cJSON.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct tonemap_opts {
    const char *board, *scene, *op_name, *capture, *out, *side, *scene_image;
    const char *nominal; /* calibration JSON whose nominal_response maps corrected codes to display */
    const char *params[16];
    int n_params;
    const char *exposure_text;
    wdr_exposure exposure;
} tonemap_opts;

#define O(f) offsetof(tonemap_opts, f)
#define AGREE_LEVELS 8 /* display levels a capture may stray from the software image and still agree */
static const cli_option tonemap_rows[] = {
    {"scene", 0, CLI_STRING, O(scene), "NAME|FILE", "the scene: a name (window) or a scene file", .flags = CLI_REQUIRED,
     .values = "@scenes"},
    {"output", 'o', CLI_STRING, O(out), "SOFT.png", "the scene tone-mapped in software", .flags = CLI_REQUIRED},
    {"board", 0, CLI_STRING, O(board), "NAME|FILE", "board: a name (sim-vga) or a board.json file", .values = "@boards"},
    {"operator", 0, CLI_STRING, O(op_name), "NAME", "tone-mapping operator (default reinhard)", .values = "@operators"},
    {"param", 0, CLI_LIST, O(params), "KEY=VALUE", "an operator parameter", .max = 16, .count = O(n_params)},
    {"scene-image", 0, CLI_STRING, O(scene_image), "HDR", "take L_avg, L_max, L_min from an HDR image"},
    {"exposure", 0, CLI_STRING, O(exposure_text), "auto|A", "scene scale: auto (log-average to the ramp's key) or A per cd/m2"},
    {"capture", 0, CLI_STRING, O(capture), "CAP.pfm", "a capture of the scene (with --side-by-side)"},
    {"nominal", 0, CLI_STRING, O(nominal), "CAL.json",
     "corrected capture: map codes through this calibration's nominal response (calibrate --json)"},
    {"side-by-side", 0, CLI_STRING, O(side), "OUT.png", "the capture beside the software image (with --capture)"},
    {0}};
#undef O

const cli_command wdrctl_cmd_tonemap = {"tonemap", NULL, 0, 0,
                                        "the scene tone-mapped in software, and a capture beside it", NULL,
                                        tonemap_rows, cmd_tonemap, 0};

static int parse_tonemap(int argc, char **argv, tonemap_opts *o)
{
    int n_args;
    memset(o, 0, sizeof *o);
    o->op_name = "reinhard";
    int rc = wdrctl_parse(&wdrctl_cmd_tonemap, argc, argv, o, &n_args);
    if (rc == EX_OK && o->exposure_text && wdr_exposure_parse(o->exposure_text, &o->exposure))
        return wdrctl_fail(EX_USAGE, "tonemap: --exposure '%s' must be auto or A per cd/m2 in (0, 1]", o->exposure_text);
    return rc;
}

static int load_inputs(const tonemap_opts *o, wdr_board *b, wdr_scene *sc, wdr_operator *op)
{
    char err[512];
    wdr_board_defaults(b);
    int rc = wdr_board_load_named(o->board ? o->board : WDR_DEFAULT_BOARD, b, err, sizeof err);
    if (!rc)
        rc = wdr_scene_load_exposed(o->scene, b, &o->exposure, sc, err, sizeof err);
    if (!rc)
        wdr_scene_print_range(stderr, "wdrctl", sc, b);
    /* The operator sees the scene as the sensor does (amps * lum_per_A): statistics from the
     * scene's own image unless --scene-image names another, which is then scaled the same way. */
    wdr_lum_stats st;
    wdr_lum_stats_default(b->i_min_a, b->i_center_a, b->i_max_a, b->lum_per_amp, 0.18, &st);
    if (!rc && o->scene_image) {
        if (wdrctl_stats_from_image(o->scene_image, &st) != EX_OK)
            return EX_DATAERR;
        double k = sc->amp_per_lum * b->lum_per_amp;
        st.l_avg *= k, st.l_max *= k, st.l_min *= k;
    } else if (!rc && sc->from_image && wdrctl_stats_from_scene(sc, b, &st) != EX_OK)
        return EX_DATAERR;
    if (!rc)
        rc = wdr_operator_init(op, o->op_name, &st, err, sizeof err);
    for (int i = 0; !rc && i < o->n_params; i++)
        rc = wdr_operator_set_param(op, o->params[i], err, sizeof err);
    if (rc)
        return wdrctl_fail(rc == WDR_E_IO ? EX_NOINPUT : EX_DATAERR, "%s", err);
    return EX_OK;
}

/* The conventional pipeline: world luminance through the operator, then display gamma. */
static void software_image(const wdr_board *b, const wdr_scene *sc, const wdr_operator *op, uint8_t *out)
{
    for (long i = 0; i < (long)sc->width * sc->height; i++)
        out[i] = wdr_display_to_u8(wdr_operator_eval(op, sc->amps[i] * b->lum_per_amp));
}

/* The nominal response of `wdrctl calibrate --json` (field nominal_response: amps_A, codes). */
typedef struct nominal_curve {
    double ln_x[2048], code[2048];
    wdr_response_curve c;
} nominal_curve;

static int read_number_array(const cJSON *a, double *v, int max, int *n)
{
    *n = 0;
    const cJSON *e;
    cJSON_ArrayForEach(e, a) {
        if (!cJSON_IsNumber(e) || *n >= max)
            return 0;
        v[(*n)++] = e->valuedouble;
    }
    return 1;
}

static int load_nominal(const char *path, nominal_curve *nc)
{
    uint8_t *text;
    size_t len;
    int na = 0, nk = 0, ok = 0;
    if (wdr_read_file(path, &text, &len) != WDR_OK)
        return wdrctl_fail(EX_NOINPUT, "%s: cannot read the calibration summary", path);
    cJSON *j = cJSON_ParseWithLength((const char *)text, len);
    const cJSON *nom = cJSON_GetObjectItemCaseSensitive(j, "nominal_response");
    if (nom && read_number_array(cJSON_GetObjectItemCaseSensitive(nom, "amps_A"), nc->ln_x, 2048, &na) &&
        read_number_array(cJSON_GetObjectItemCaseSensitive(nom, "codes"), nc->code, 2048, &nk) && na == nk && na >= 2) {
        ok = 1;
        for (int k = 0; k < na; k++) {
            ok &= nc->ln_x[k] > 0 && isfinite(nc->code[k]) && (k == 0 || nc->code[k] < nc->code[k - 1]);
            nc->ln_x[k] = log(nc->ln_x[k]);
        }
    }
    cJSON_Delete(j);
    free(text);
    if (!ok)
        return wdrctl_fail(EX_DATAERR, "%s: field 'nominal_response': needs amps_A and codes of equal length (>= 2), "
                           "amps > 0 rising, codes falling (the output of 'wdrctl calibrate --json')", path);
    nc->c = (wdr_response_curve){na, nc->ln_x, nc->code};
    return EX_OK;
}

static int capture_image(const char *path, const wdr_board *b, int w, int h, const wdr_operator *op,
                         const nominal_curve *nc, uint8_t *out)
{
    char err[512];
    float *codes;
    int cw, ch, rc = wdr_pfm_read(path, &codes, &cw, &ch, err, sizeof err);
    if (rc)
        return wdrctl_fail(rc == WDR_E_IO ? EX_NOINPUT : EX_DATAERR, "%s", err);
    if (cw != w || ch != h) {
        free(codes);
        return wdrctl_fail(EX_DATAERR, "%s: field 'size': %dx%d, the scene is %dx%d", path, cw, ch, w, h);
    }
    wdr_ideal_pixel px;
    wdr_ideal_pixel_init(b, &px);
    for (long i = 0; i < (long)w * h; i++) /* a corrected capture lies on the calibration's nominal response */
        out[i] = wdr_display_to_u8(nc ? wdr_code_to_display_curve(&nc->c, op, b->lum_per_amp, codes[i])
                                      : wdr_code_to_display(&px, b, codes[i]));
    free(codes);
    return EX_OK;
}

/* How far the capture lies from the software image, in display levels: the figure the side by
 * side shows by eye (a flat or misplaced capture is far off). */
static void print_agreement(const uint8_t *soft, const uint8_t *cap, long n)
{
    double sum = 0;
    long within = 0;
    for (long i = 0; i < n; i++) {
        int d = abs((int)cap[i] - (int)soft[i]);
        sum += d;
        within += d <= AGREE_LEVELS;
    }
    printf("capture against software: mean |difference| %.2f of 255 levels, %.1f %% of pixels within %d\n",
           sum / (double)n, 100.0 * (double)within / (double)n, AGREE_LEVELS);
}

static int write_outputs(const tonemap_opts *o, int w, int h, const uint8_t *soft, const uint8_t *cap)
{
    char err[512];
    uint16_t *grey = malloc(sizeof *grey * (size_t)w * h);
    int side_w = WDR_SIDE_BY_SIDE_W(w), side_h = wdr_side_by_side_h(w, h);
    uint8_t *rgb = cap ? malloc((size_t)3 * side_w * side_h) : NULL;
    int rc = grey && (!cap || rgb) ? WDR_OK : WDR_E_NOMEM;
    for (long i = 0; !rc && i < (long)w * h; i++)
        grey[i] = soft[i];
    if (!rc)
        rc = wdr_png_write_gray(o->out, grey, w, h, 8, err, sizeof err);
    if (!rc && cap) {
        wdr_side_by_side(cap, soft, w, h, o->nominal ? "SENSOR (CORRECTED)" : "SENSOR (UNCORRECTED)", "SOFTWARE TONE MAP",
                         rgb);
        rc = wdr_png_write_rgb(o->side, rgb, side_w, side_h, err, sizeof err);
    }
    free(grey);
    free(rgb);
    return rc ? wdrctl_fail(EX_CANTCREAT, "%s", rc == WDR_E_NOMEM ? "out of memory" : err) : EX_OK;
}

int cmd_tonemap(int argc, char **argv)
{
    tonemap_opts o;
    wdr_board b;
    wdr_scene sc = {0};
    static wdr_operator op;
    int rc = parse_tonemap(argc, argv, &o);
    if (rc == EX_OK)
        rc = wdrctl_check_output("tonemap", o.out, ".png");
    if (rc == EX_OK)
        rc = wdrctl_check_output("tonemap", o.side, ".png");
    if (rc == EX_OK && !o.capture != !o.side)
        rc = wdrctl_fail(EX_USAGE, "tonemap: --capture CAP.pfm and --side-by-side OUT.png go together");
    if (rc == EX_OK)
        rc = load_inputs(&o, &b, &sc, &op);
    if (rc != EX_OK)
        return rc;
    long n = (long)sc.width * sc.height;
    uint8_t *soft = malloc((size_t)n), *cap = o.capture ? malloc((size_t)n) : NULL;
    if (!soft || (o.capture && !cap))
        rc = wdrctl_fail(EX_OSERR, "out of memory");
    static nominal_curve nc;
    if (rc == EX_OK && o.nominal)
        rc = load_nominal(o.nominal, &nc);
    if (rc == EX_OK) {
        software_image(&b, &sc, &op, soft);
        if (o.capture)
            rc = capture_image(o.capture, &b, sc.width, sc.height, &op, o.nominal ? &nc : NULL, cap);
    }
    if (rc == EX_OK && cap)
        print_agreement(soft, cap, n);
    if (rc == EX_OK)
        rc = write_outputs(&o, sc.width, sc.height, soft, cap);
    if (rc == EX_OK)
        printf("wrote %s%s%s\n", o.out, o.side ? " and " : "", o.side ? o.side : "");
    free(soft);
    free(cap);
    wdr_scene_free(&sc);
    return rc;
}
