/* wdrsim: render raw frames of a scene through a LUT on a board, without the firmware.
 * Writes PFM (codes as floats) or a 16-bit PNG; the report (parameters, exposure, floor and
 * ceiling fractions, effects) goes where --json says: stdout, or --json=FILE. No output may be
 * an input. Exit codes follow sysexits. */
#include "cli_options.h"
#include "image_io.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include "wdr_scene.h"
#include "file_io.h"
#include "ramp.h"
#include "wdr_sim.h"
#include "value_lists.h"
#include <cJSON.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sysexits.h>
#include <time.h>
#include <unistd.h>

typedef struct options {
    const char *board, *scene, *lut, *operator_name, *out, *json_path, *exposure_text;
    int json, threads, unquantised;
    wdr_exposure exposure;
    int have_seed, have_chip_seed;
    uint64_t seed, chip_seed;
    int n_effects;
    const char *effects[32];
} options;

static int fail(int code, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

static int fail(int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("wdrsim: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return code;
}

/* ---- arguments: one row each (host/lib/cli_options.h) ---- */

#define O(f) offsetof(options, f)
static const cli_option rows[] = {
    {"board", 0, CLI_STRING, O(board), "NAME|FILE", "board: a name (sim-vga) or a board.json file",
     .flags = CLI_REQUIRED, .values = "@boards"},
    {"scene", 0, CLI_STRING, O(scene), "NAME|FILE", "the scene: a name (window) or a scene file",
     .flags = CLI_REQUIRED, .values = "@scenes"},
    {"lut", 0, CLI_STRING, O(lut), "LUT.bin", "the ramp table to play (or --operator)"},
    {"operator", 0, CLI_STRING, O(operator_name), "NAME", "build the board's LUT of this operator (or --lut)",
     .values = "@operators"},
    {"output", 'o', CLI_STRING, O(out), "OUT.pfm|OUT.png", "the frame (PFM: codes as floats; PNG: 16-bit)"},
    {"json", 0, CLI_FLAG, O(json), NULL, "print the report (parameters, exposure, floor/ceiling, effects) as JSON"},
    {"report", 0, CLI_STRING, O(json_path), "FILE", "write that report to FILE instead (also spelt --json=FILE)"},
    {"exposure", 0, CLI_STRING, O(exposure_text), "auto|A", "auto: the scene's log-average onto the ramp's key; or A per cd/m2"},
    {"seed", 0, CLI_U64, O(seed), "N", "frame seed: temporal noise (default: the scene's)",
     .given = CLI_GIVEN(options, have_seed)},
    {"chip-seed", 0, CLI_U64, O(chip_seed), "N", "chip seed: fixed-pattern draw (default: the scene's)",
     .given = CLI_GIVEN(options, have_chip_seed)},
    {"threads", 0, CLI_INT, O(threads), "N", "render threads, 0: all cores", .min = 0, .max = 64},
    {"unquantised", 0, CLI_FLAG, O(unquantised), NULL, "codes before the ADC rounds them"},
    {"effect", 0, CLI_LIST, O(effects), "NAME=on|off|auto",
     "force an effect: mismatch dark shot ktc read dac_quant adc_quant leakage clipping", .max = 32,
     .count = O(n_effects)},
    {0}};
#undef O

static const cli_command wdrsim_command = {NULL, NULL, 0, 0,
                                           "render raw frames of a scene through a LUT on a board, without the firmware",
                                           NULL, rows, NULL, 0};

static const cli_section sections[] = {
    {"ENVIRONMENT", "WDR_BOARDS_DIR: where board names are looked up (BOARDS_DIR/NAME/board.json; default: the installed share/wdrcam/boards).\n"
                    "WDR_SCENES_DIR: where scene names are looked up (SCENES_DIR/NAME.json; default: the installed share/wdrcam/scenes)."},
    {"EXAMPLES", "wdrsim --board sim-vga --scene window --operator reinhard -o w.png --json"},
    {"EXIT STATUS", "0 on success; otherwise a sysexits(3) code: 64 usage, 65 bad data, 66 an input that cannot be "
                    "read, 70 internal error, 71 out of memory, 73 an output that cannot be created, 78 a bad "
                    "board file."},
    {"SEE ALSO", "wdrctl(1), wdr-simboard(1), wdr-hdrgen(1)"},
    {NULL, NULL}};

static const cli_program wdrsim_program = {
    .name = "wdrsim",
    .summary = "render raw frames of a scene through a LUT on a simulated sensor",
    .description = "wdrsim runs the physical pixel-array simulator: the scene's light on the board's pixels, the "
                   "ramp of a LUT, every effect the scene asks for (or --effect forces). It writes PFM (codes as "
                   "floats) or a 16-bit PNG; the report (parameters, exposure, floor and ceiling fractions, effects) "
                   "goes to stdout with --json, or to a file with --json=FILE. No output may be an input.",
    .single = &wdrsim_command,
    .sections = sections,
    .print_values = wdr_print_values,
};

static int parse_args(options *o, int argc, char **argv, int *done)
{
    int n_args;
    if (argc < 2) { /* nothing asked: say how to ask */
        cli_print_program_help(stderr, &wdrsim_program);
        return fail(EX_USAGE, "need --board, --scene and one of --lut or --operator");
    }
    /* --json=FILE is the short spelling of --report FILE: the table knows only the latter. */
    char **args = calloc(2 * (size_t)argc, sizeof *args);
    if (!args)
        return fail(EX_OSERR, "out of memory");
    int n = 0;
    for (int i = 0; i < argc; i++) {
        if (!strncmp(argv[i], "--json=", 7)) {
            args[n++] = "--report";
            args[n++] = argv[i] + 7;
        } else
            args[n++] = argv[i];
    }
    int rc = cli_main_single(&wdrsim_program, n, args, o, &n_args, done);
    free(args);
    if (rc != EX_OK || *done)
        return rc;
    if (o->json_path)
        o->json = 1;
    if (o->exposure_text && wdr_exposure_parse(o->exposure_text, &o->exposure))
        return fail(EX_USAGE, "--exposure: '%s' must be auto or a scale in A per cd/m2 in (0, 1]", o->exposure_text);
    if (!o->lut == !o->operator_name)
        return fail(EX_USAGE, "need one of --lut or --operator (see 'wdrsim --help')");
    return EX_OK;
}

static int apply_effect(wdr_sim *s, const char *spec)
{
    char name[64];
    const char *eq = strchr(spec, '=');
    if (!eq || (size_t)(eq - spec) >= sizeof name)
        return fail(EX_USAGE, "--effect '%s': expected name=on|off|auto", spec);
    snprintf(name, sizeof name, "%.*s", (int)(eq - spec), spec);
    int fx = wdr_effect_from_name(name);
    if (fx < 0)
        return fail(EX_USAGE, "--effect '%s': unknown effect '%s'", spec, name);
    const char *m = eq + 1;
    wdr_fx_mode mode = !strcmp(m, "on") ? WDR_FX_ON : !strcmp(m, "off") ? WDR_FX_OFF : WDR_FX_AUTO;
    if (mode == WDR_FX_AUTO && strcmp(m, "auto"))
        return fail(EX_USAGE, "--effect '%s': value '%s' must be on, off or auto", spec, m);
    wdr_sim_set_effect(s, fx, mode);
    return EX_OK;
}

/* ---- inputs ---- */

static int load_board(const char *name, wdr_board *b, char *path, int pathlen)
{
    char err[512];
    wdr_board_path(name, path, pathlen);
    wdr_board_defaults(b);
    int rc = wdr_board_load_named(name, b, err, sizeof err);
    return rc ? fail(rc == WDR_E_IO ? EX_NOINPUT : EX_CONFIG, "%s", err) : EX_OK;
}

static int read_lut_file(const char *path, uint8_t **buf, size_t *len)
{
    int rc = wdr_read_file(path, buf, len);
    if (rc)
        return fail(rc == WDR_E_IO ? EX_NOINPUT : EX_OSERR, "%s: cannot read LUT file", path);
    return EX_OK;
}

static int load_lut(const options *o, const wdr_board *b, uint8_t **bytes, wdr_lut_view *lut)
{
    size_t len;
    char err[512];
    if (o->operator_name) {
        int rc = wdr_ramp_board_lut(b, o->operator_name, bytes, &len, NULL, err, sizeof err);
        if (rc)
            return fail(EX_USAGE, "--operator %s: %s", o->operator_name, err);
    } else if (read_lut_file(o->lut, bytes, &len)) {
        return EX_NOINPUT;
    }
    int rc = wdr_lut_parse(*bytes, len, lut);
    if (rc)
        return fail(EX_DATAERR, "%s: not a valid LUT: %s", o->lut ? o->lut : "built LUT", wdr_strerror(rc));
    return EX_OK;
}

/* ---- outputs ---- */

static const char *mode_name(wdr_fx_mode m) { return m == WDR_FX_ON ? "on" : m == WDR_FX_OFF ? "off" : "auto"; }

static cJSON *report_json(const options *o, const wdr_board *b, const wdr_scene *sc, const wdr_sim *s,
                          double seconds, uint64_t chip_seed, uint64_t frame_seed)
{
    cJSON *root = cJSON_CreateObject(), *fx = cJSON_AddObjectToObject(root, "effects");
    cJSON_AddStringToObject(root, "board", b->name);
    cJSON_AddStringToObject(root, "scene", o->scene);
    cJSON_AddStringToObject(root, "illumination", sc->illumination);
    cJSON_AddStringToObject(root, "lut", o->lut ? o->lut : o->operator_name);
    cJSON_AddNumberToObject(root, "width", b->width);
    cJSON_AddNumberToObject(root, "height", b->height);
    cJSON_AddNumberToObject(root, "adc_bits", b->adc_bits);
    cJSON_AddNumberToObject(root, "chip_seed", (double)chip_seed);
    cJSON_AddNumberToObject(root, "frame_seed", (double)frame_seed);
    cJSON_AddStringToObject(root, "exposure", sc->exposure_auto ? "auto" : "fixed");
    cJSON_AddNumberToObject(root, "amp_per_cd_m2", sc->amp_per_lum);
    cJSON_AddNumberToObject(root, "scene_log_average_cd_m2", sc->l_avg);
    cJSON_AddNumberToObject(root, "fraction_below_floor", sc->below_floor);
    cJSON_AddNumberToObject(root, "fraction_above_ceiling", sc->above_ceiling);
    cJSON_AddNumberToObject(root, "photocurrent_min_A", sc->i_min);
    cJSON_AddNumberToObject(root, "photocurrent_max_A", sc->i_max);
    cJSON_AddNumberToObject(root, "integration_s", wdr_sim_integration_time(s));
    cJSON_AddNumberToObject(root, "row_time_s", b->row_time_s);
    cJSON_AddBoolToObject(root, "reference", sc->reference);
    cJSON_AddNumberToObject(root, "auto_tolerance_lsb", sc->tolerance_lsb);
    cJSON_AddNumberToObject(root, "render_seconds", seconds);
    const wdr_fx_report *r = wdr_sim_report(s);
    for (int k = 0; k < WDR_FX_COUNT; k++) {
        cJSON *e = cJSON_AddObjectToObject(fx, wdr_effect_name(k));
        cJSON_AddStringToObject(e, "requested", mode_name(r[k].requested));
        cJSON_AddBoolToObject(e, "ran", r[k].ran);
        cJSON_AddNumberToObject(e, "estimate_lsb", r[k].estimate_lsb);
        cJSON_AddStringToObject(e, "why", r[k].why);
    }
    return root;
}

/* An output must never replace an input (a scene, LUT or board file of the same name). */
static int same_file(const char *a, const char *b)
{
    struct stat sa, sb;
    return a && b && stat(a, &sa) == 0 && stat(b, &sb) == 0 && sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

static int check_outputs(const options *o, const char *board_path)
{
    const char *outs[2] = {o->out, o->json_path}, *ins[3] = {o->scene, o->lut, board_path};
    char err[300];
    if (o->out && wdr_output_name_check(o->out, ".pfm .png", err, sizeof err))
        return fail(EX_USAGE, "%s", err);
    for (int i = 0; i < 2; i++)
        for (int k = 0; k < 3; k++)
            if (same_file(outs[i], ins[k]))
                return fail(EX_CANTCREAT, "%s: refusing to overwrite an input (%s)", outs[i],
                            k == 0 ? "the scene" : k == 1 ? "the LUT" : "the board");
    if (o->out && o->json_path && !strcmp(o->out, o->json_path))
        return fail(EX_USAGE, "-o and --json name the same file %s", o->out);
    return EX_OK;
}

static int write_report(const char *path, const cJSON *report)
{
    char *text = cJSON_Print(report);
    if (!path) {
        puts(text ? text : "{}");
        free(text);
        return EX_OK;
    }
    FILE *f = fopen(path, "w");
    int ok = f && text && fputs(text, f) >= 0 && fputc('\n', f) != EOF;
    if (f && fclose(f))
        ok = 0;
    free(text);
    return ok ? EX_OK : fail(EX_CANTCREAT, "%s: cannot write the report", path);
}

/* PNG: codes shifted to fill 16 bits (the report's adc_bits undoes it); PFM: codes as floats. */
static int write_image(const char *out, const wdr_board *b, const float *codes)
{
    char err[512];
    long n = (long)b->width * b->height;
    int rc;
    if (wdr_path_has_ext(out, ".pfm")) {
        rc = wdr_pfm_write(out, codes, b->width, b->height, err, sizeof err);
    } else {
        uint16_t *px = malloc((size_t)n * sizeof *px);
        if (!px)
            return fail(EX_OSERR, "out of memory");
        for (long i = 0; i < n; i++)
            px[i] = (uint16_t)((codes[i] < 0 ? 0 : (uint32_t)(codes[i] + 0.5f)) << (16 - b->adc_bits));
        rc = wdr_png_write_gray(out, px, b->width, b->height, 16, err, sizeof err);
        free(px);
    }
    return rc ? fail(EX_CANTCREAT, "%s", err) : EX_OK;
}

/* ---- rendering ---- */

static void show_progress(void *ctx, int done, int total)
{
    int *last = ctx, pct = (int)(100.0 * done / total);
    if (pct == *last)
        return;
    *last = pct;
    fprintf(stderr, "\rwdrsim: rendering %3d%%", pct);
    if (done == total)
        fputc('\n', stderr);
}

static int progress_wanted(void)
{
    const char *ci = getenv("CI");
    return isatty(2) && !(ci && *ci && strcmp(ci, "false"));
}

static int render(wdr_sim *s, const options *o, uint64_t frame_seed, float *codes, double *seconds)
{
    long n = (long)wdr_sim_board(s)->width * wdr_sim_board(s)->height;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    int rc;
    if (o->unquantised) {
        rc = wdr_sim_render_float(s, frame_seed, codes);
    } else {
        uint16_t *raw = malloc((size_t)n * sizeof *raw);
        rc = raw ? wdr_sim_render(s, frame_seed, raw) : WDR_E_NOMEM;
        for (long i = 0; !rc && i < n; i++)
            codes[i] = raw[i];
        free(raw);
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    *seconds = (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec);
    return rc ? fail(EX_SOFTWARE, "render failed: %s", wdr_strerror(rc)) : EX_OK;
}

static int run(const options *o, const wdr_board *b, wdr_scene *sc, const wdr_lut_view *lut)
{
    uint64_t chip_seed = o->have_chip_seed ? o->chip_seed : sc->chip_seed;
    uint64_t frame_seed = o->have_seed ? o->seed : sc->frame_seed;
    wdr_sim *s = wdr_sim_create(b, chip_seed);
    float *codes = malloc((size_t)b->width * b->height * sizeof *codes);
    if (!s || !codes) {
        wdr_sim_destroy(s);
        free(codes);
        return fail(EX_OSERR, "out of memory for a %dx%d sensor", b->width, b->height);
    }
    int rc = wdr_sim_set_lut(s, lut) ? fail(EX_DATAERR, "%s: the simulator cannot play this LUT (a falling ramp?)",
                                            o->lut ? o->lut : "LUT")
                                     : wdr_scene_apply(sc, s) ? fail(EX_DATAERR, "%s: cannot apply", o->scene) : EX_OK;
    wdr_sim_set_threads(s, o->threads);
    for (int k = 0; !rc && k < o->n_effects; k++)
        rc = apply_effect(s, o->effects[k]);
    int last_pct = -1;
    if (!rc && progress_wanted())
        wdr_sim_set_progress(s, show_progress, &last_pct);
    double seconds = 0;
    if (!rc)
        rc = render(s, o, frame_seed, codes, &seconds);
    cJSON *report = rc ? NULL : report_json(o, b, sc, s, seconds, chip_seed, frame_seed);
    if (!rc && o->out)
        rc = write_image(o->out, b, codes);
    if (!rc && o->json)
        rc = write_report(o->json_path, report);
    cJSON_Delete(report);
    wdr_sim_destroy(s);
    free(codes);
    return rc;
}

int main(int argc, char **argv)
{
    options o = {0};
    int done = 0;
    wdr_board b;
    wdr_scene sc;
    wdr_lut_view lut;
    uint8_t *bytes = NULL;
    char err[1024], board_path[1024];
    int rc = parse_args(&o, argc, argv, &done);
    if (rc || done)
        return rc;
    if (!rc)
        rc = load_board(o.board, &b, board_path, sizeof board_path);
    if (!rc)
        rc = check_outputs(&o, board_path);
    if (!rc)
        rc = load_lut(&o, &b, &bytes, &lut);
    if (!rc && (rc = wdr_scene_load_exposed(o.scene, &b, &o.exposure, &sc, err, sizeof err)))
        rc = fail(rc == WDR_E_IO ? EX_NOINPUT : rc == WDR_E_NOMEM ? EX_OSERR : EX_DATAERR, "%s", err);
    else if (!rc) {
        if (sc.warning[0])
            fprintf(stderr, "wdrsim: warning: %s\n", sc.warning);
        wdr_scene_print_range(stderr, "wdrsim", &sc, &b);
        rc = run(&o, &b, &sc, &lut);
        wdr_scene_free(&sc);
    }
    free(bytes);
    return rc;
}
