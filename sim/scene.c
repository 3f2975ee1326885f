/* Scene files: cJSON in, a photocurrent map and effect switches out. Bad input is named by
 * file, field and value; nothing here asserts on what a file says. */
#include "wdr_scene.h"
#include "data_path.h"
#include "file_io.h"
#include "hdr_image.h"
#include "resample.h"
#include "wdr_err.h"
#include <cJSON.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef struct scene_ctx {
    const char *path;
    const wdr_board *board;
    wdr_scene *sc;
    const wdr_exposure *exposure; /* the caller's override, or NULL: the scene's own */
    float *lum; /* luminance map at the sensor's size */
    char *err;
    int errlen;
} scene_ctx;

static int fail(scene_ctx *c, int code, const char *field, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

static int fail(scene_ctx *c, int code, const char *field, const char *fmt, ...)
{
    char why[400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(why, sizeof why, fmt, ap);
    va_end(ap);
    snprintf(c->err, (size_t)c->errlen, "%s: field '%s': %s", c->path, field, why);
    return code;
}

/* ---- numbers and strings ---- */

static int get_number(scene_ctx *c, const cJSON *obj, const char *key, const char *field, double lo, double hi,
                      double def, double *out)
{
    const cJSON *it = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!it) {
        *out = def;
        return WDR_OK;
    }
    if (!cJSON_IsNumber(it))
        return fail(c, WDR_E_INVAL, field, "must be a number");
    double v = it->valuedouble;
    if (!isfinite(v) || v < lo || v > hi)
        return fail(c, WDR_E_INVAL, field, "value %g out of range [%g, %g]", v, lo, hi);
    *out = v;
    return WDR_OK;
}

static int get_seed(scene_ctx *c, const cJSON *root, const char *key, uint64_t *out)
{
    double v = 0;
    int rc = get_number(c, root, key, key, 0, 9007199254740992.0, (double)*out, &v);
    if (!rc && v != floor(v))
        return fail(c, WDR_E_INVAL, key, "value %g must be a whole number", v);
    if (!rc)
        *out = (uint64_t)v;
    return rc;
}

static const char *get_string(const cJSON *obj, const char *key)
{
    const cJSON *it = cJSON_GetObjectItemCaseSensitive(obj, key);
    return cJSON_IsString(it) ? it->valuestring : NULL;
}

/* Every key of obj must be one of allowed (NULL-terminated): a typo is an error, not a default. */
static int check_keys(scene_ctx *c, const cJSON *obj, const char *prefix, const char *const *allowed)
{
    for (const cJSON *it = obj->child; it; it = it->next) {
        int known = 0;
        for (int k = 0; allowed[k] && !known; k++)
            known = !strcmp(it->string, allowed[k]);
        if (!known) {
            char field[128];
            snprintf(field, sizeof field, "%s%s", prefix, it->string);
            return fail(c, WDR_E_INVAL, field, "unknown field");
        }
    }
    return WDR_OK;
}

/* ---- patterns (luminance, cd/m2) ---- */

typedef struct pattern_args {
    double l, l_min, l_max, win[4];
    int cols, rows, vertical;
} pattern_args;

static double log_mix(double lo, double hi, double f) { return lo * pow(hi / lo, f); }

static float window_pixel(const pattern_args *a, double fx, double fy)
{
    const double *w = a->win;
    double cx = 0.5 * (w[0] + w[2]), cy = 0.5 * (w[1] + w[3]);
    double far = hypot(fmax(cx, 1 - cx), fmax(cy, 1 - cy));
    double room = log_mix(a->l_min, a->l_max * 1e-2, 1 - hypot(fx - cx, fy - cy) / far);
    int inside = fx >= w[0] && fx < w[2] && fy >= w[1] && fy < w[3];
    int mullion = fabs(fx - cx) < 0.01 || fabs(fy - cy) < 0.01;
    if (!inside || mullion)
        return (float)room;
    return (float)log_mix(a->l_max, a->l_max * 0.1, (fy - w[1]) / (w[3] - w[1])); /* sky: bright at the top */
}

static float pattern_pixel(int kind, const pattern_args *a, int x, int y, int w, int h)
{
    double fx = w > 1 ? (double)x / (w - 1) : 0, fy = h > 1 ? (double)y / (h - 1) : 0;
    switch (kind) {
    case 0: return (float)a->l;
    case 1: return (float)log_mix(a->l_min, a->l_max, a->vertical ? fy : fx);
    case 2: {
        int n = a->cols * a->rows, cx = x * a->cols / w, cy = y * a->rows / h;
        return (float)log_mix(a->l_min, a->l_max, n > 1 ? (double)(cy * a->cols + cx) / (n - 1) : 0);
    }
    default: return window_pixel(a, (x + 0.5) / w, (y + 0.5) / h);
    }
}

static int pattern_window(scene_ctx *c, const cJSON *ill, pattern_args *a)
{
    const double def[4] = {0.55, 0.15, 0.85, 0.6};
    const cJSON *win = cJSON_GetObjectItemCaseSensitive(ill, "window");
    memcpy(a->win, def, sizeof def);
    if (!win)
        return WDR_OK;
    if (!cJSON_IsArray(win) || cJSON_GetArraySize(win) != 4)
        return fail(c, WDR_E_INVAL, "illumination.window", "must be [x0, y0, x1, y1] as fractions of the frame");
    for (int k = 0; k < 4; k++) {
        const cJSON *v = cJSON_GetArrayItem(win, k);
        if (!cJSON_IsNumber(v) || !(v->valuedouble >= 0 && v->valuedouble <= 1))
            return fail(c, WDR_E_INVAL, "illumination.window", "item %d must be a fraction in [0, 1]", k);
        a->win[k] = v->valuedouble;
    }
    if (!(a->win[0] < a->win[2] && a->win[1] < a->win[3]))
        return fail(c, WDR_E_INVAL, "illumination.window", "need x0 < x1 and y0 < y1");
    return WDR_OK;
}

static int pattern_args_read(scene_ctx *c, const cJSON *ill, int kind, pattern_args *a)
{
    static const char *const keys[] = {"pattern", "luminance", "l_min", "l_max", "direction",
                                       "columns", "rows", "window", "comment", NULL};
    double cols = 6, rows = 4;
    int rc = check_keys(c, ill, "illumination.", keys);
    if (!rc)
        rc = get_number(c, ill, "luminance", "illumination.luminance", 0, 1e30, 100.0, &a->l);
    if (!rc)
        rc = get_number(c, ill, "l_min", "illumination.l_min", 1e-30, 1e30, 1e-3, &a->l_min);
    if (!rc)
        rc = get_number(c, ill, "l_max", "illumination.l_max", 1e-30, 1e30, 1e3, &a->l_max);
    if (!rc && kind != 0 && !(a->l_max > a->l_min))
        return fail(c, WDR_E_INVAL, "illumination.l_max", "value %g must exceed l_min %g", a->l_max, a->l_min);
    if (!rc)
        rc = get_number(c, ill, "columns", "illumination.columns", 1, 256, 6, &cols);
    if (!rc)
        rc = get_number(c, ill, "rows", "illumination.rows", 1, 256, 4, &rows);
    a->cols = (int)cols;
    a->rows = (int)rows;
    const char *dir = get_string(ill, "direction");
    if (!rc && cJSON_GetObjectItemCaseSensitive(ill, "direction") &&
        (!dir || (strcmp(dir, "horizontal") && strcmp(dir, "vertical"))))
        return fail(c, WDR_E_INVAL, "illumination.direction", "must be \"horizontal\" or \"vertical\"");
    a->vertical = dir && !strcmp(dir, "vertical");
    return rc ? rc : (kind == 3 ? pattern_window(c, ill, a) : WDR_OK);
}

static int load_pattern(scene_ctx *c, const cJSON *ill, const char *name)
{
    static const char *const kinds[] = {"uniform", "log_wedge", "step_chart", "window"};
    int kind = -1;
    for (int k = 0; k < 4; k++)
        kind = strcmp(name, kinds[k]) ? kind : k;
    if (kind < 0)
        return fail(c, WDR_E_INVAL, "illumination.pattern",
                    "unknown pattern '%s' (known: uniform, log_wedge, step_chart, window)", name);
    pattern_args a = {0};
    int rc = pattern_args_read(c, ill, kind, &a);
    if (rc)
        return rc;
    int w = c->sc->width, h = c->sc->height;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            c->lum[(long)y * w + x] = pattern_pixel(kind, &a, x, y, w, h);
    snprintf(c->sc->illumination, sizeof c->sc->illumination, "pattern %s", name);
    return WDR_OK;
}

/* ---- images ---- */

static void image_path(const char *scene_path, const char *name, char *out, size_t len)
{
    const char *slash = strrchr(scene_path, '/');
    if (name[0] == '/' || !slash)
        snprintf(out, len, "%s", name);
    else
        snprintf(out, len, "%.*s/%s", (int)(slash - scene_path), scene_path, name);
}

static void add_warning(wdr_scene *sc, const char *text)
{
    size_t used = strlen(sc->warning);
    snprintf(sc->warning + used, sizeof sc->warning - used, "%s%s", used ? "; " : "", text);
}

static int fit_image(scene_ctx *c, const cJSON *ill, const char *file, const float *img, int iw, int ih)
{
    const char *name = get_string(ill, "fit");
    int fit = name ? wdr_fit_from_name(name) : WDR_FIT_CROP; /* aspect kept unless asked otherwise */
    if (cJSON_GetObjectItemCaseSensitive(ill, "fit") && (!name || fit < 0))
        return fail(c, WDR_E_INVAL, "illumination.fit",
                    "must be \"exact\", \"crop\" (or its old name \"resample\"), \"letterbox\" or \"stretch\"");
    int w = c->sc->width, h = c->sc->height;
    char what[300];
    int rc = wdr_resample_fit(img, iw, ih, c->lum, w, h, (wdr_fit)fit, what, sizeof what);
    if (rc == WDR_E_GEOMETRY)
        return fail(c, WDR_E_GEOMETRY, "illumination.image",
                    "%s is %dx%d but the sensor is %dx%d (set \"fit\": \"crop\", \"letterbox\" or \"stretch\")",
                    file, iw, ih, w, h);
    if (rc)
        return rc;
    if (iw != w || ih != h) {
        char line[512];
        snprintf(line, sizeof line, "%.180s %s", file, what);
        add_warning(c->sc, line);
    }
    return WDR_OK;
}

static int load_image(scene_ctx *c, const cJSON *ill, const char *name)
{
    static const char *const keys[] = {"image", "fit", "comment", NULL};
    char file[1024], err[600];
    int rc = check_keys(c, ill, "illumination.", keys), iw, ih;
    if (rc)
        return rc;
    image_path(c->path, name, file, sizeof file);
    float *img;
    long negatives;
    rc = wdr_hdr_load_checked(file, &img, &iw, &ih, &negatives, err, sizeof err);
    if (rc)
        return fail(c, rc, "illumination.image", "%s", err);
    if (negatives) {
        char line[300];
        snprintf(line, sizeof line, "%.180s: %ld negative pixels clamped to 0", file, negatives);
        add_warning(c->sc, line);
    }
    rc = fit_image(c, ill, file, img, iw, ih);
    c->sc->from_image = 1;
    free(img);
    snprintf(c->sc->illumination, sizeof c->sc->illumination, "image %s", name);
    return rc;
}

static int load_illumination(scene_ctx *c, const cJSON *root)
{
    const cJSON *ill = cJSON_GetObjectItemCaseSensitive(root, "illumination");
    if (!cJSON_IsObject(ill))
        return fail(c, WDR_E_INVAL, "illumination", "missing: give {\"image\": FILE} or {\"pattern\": NAME, ...}");
    const char *image = get_string(ill, "image"), *pattern = get_string(ill, "pattern");
    if (!!image == !!pattern)
        return fail(c, WDR_E_INVAL, "illumination", "give exactly one of \"image\" (a file name) and \"pattern\"");
    return image ? load_image(c, ill, image) : load_pattern(c, ill, pattern);
}

/* ---- effects, size, scale ---- */

static int load_effects(scene_ctx *c, const cJSON *root)
{
    static const char *const modes[] = {"off", "on", "auto"};
    for (int k = 0; k < WDR_FX_COUNT; k++)
        c->sc->effects[k] = WDR_FX_AUTO; /* a scene asks only for what matters unless it says more */
    const cJSON *fx = cJSON_GetObjectItemCaseSensitive(root, "effects");
    if (fx && !cJSON_IsObject(fx))
        return fail(c, WDR_E_INVAL, "effects", "must be an object of name: \"on\" | \"off\" | \"auto\"");
    for (const cJSON *it = fx ? fx->child : NULL; it; it = it->next) {
        char field[96];
        snprintf(field, sizeof field, "effects.%s", it->string);
        int e = wdr_effect_from_name(it->string);
        if (e < 0)
            return fail(c, WDR_E_INVAL, field, "unknown effect (known: mismatch, dark, shot, ktc, read, dac_quant, "
                                               "adc_quant, leakage, clipping, defects)");
        int m = -1;
        for (int k = 0; k < 3 && cJSON_IsString(it); k++)
            m = strcmp(it->valuestring, modes[k]) ? m : k;
        if (m < 0)
            return fail(c, WDR_E_INVAL, field, "value %s%s%s must be \"on\", \"off\" or \"auto\"",
                        cJSON_IsString(it) ? "'" : "", cJSON_IsString(it) ? it->valuestring : "(not a string)",
                        cJSON_IsString(it) ? "'" : "");
        c->sc->effects[e] = (wdr_fx_mode)m;
    }
    return WDR_OK;
}

/* "defects": {"dead_ppm", "stuck_ppm", "hot_ppm", "saturated_ppm", "hot_A", "seed",
 *              "pixels": [{"x", "y", "kind"}, ...]} (sim/SPEC.md) */
static int load_defect_pixels(scene_ctx *c, const cJSON *list)
{
    wdr_sim_defects *d = &c->sc->defects;
    int n = cJSON_GetArraySize(list);
    long *index = calloc((size_t)(n ? n : 1), sizeof(long));
    uint8_t *kind = calloc((size_t)(n ? n : 1), 1);
    d->listed_index = index, d->listed_kind = kind;
    if (!index || !kind)
        return fail(c, WDR_E_NOMEM, "defects.pixels", "out of memory for %d pixels", n);
    for (int j = 0; j < n; j++) {
        const cJSON *px = cJSON_GetArrayItem(list, j);
        char field[64];
        snprintf(field, sizeof field, "defects.pixels[%d]", j);
        const char *name = cJSON_IsObject(px) ? get_string(px, "kind") : NULL;
        double x = -1, y = -1;
        int rc = cJSON_IsObject(px) ? get_number(c, px, "x", field, 0, c->sc->width - 1, -1, &x) : WDR_E_INVAL;
        if (!rc)
            rc = get_number(c, px, "y", field, 0, c->sc->height - 1, -1, &y);
        if (rc || x < 0 || y < 0 || x != floor(x) || y != floor(y))
            return rc ? rc : fail(c, WDR_E_INVAL, field, "needs whole \"x\" and \"y\" on the sensor");
        for (int k = 1; k < WDR_DEFECT_KINDS && name; k++)
            if (!strcmp(name, wdr_defect_name(k)))
                kind[j] = (uint8_t)k;
        if (!kind[j])
            return fail(c, WDR_E_INVAL, field, "kind '%s' unknown (known: dead, stuck, hot, saturated)",
                        name ? name : "(missing)");
        index[j] = (long)y * c->sc->width + (long)x;
    }
    d->n_listed = n;
    return WDR_OK;
}

static int load_defects(scene_ctx *c, const cJSON *root)
{
    static const char *const keys[] = {"dead_ppm", "stuck_ppm", "hot_ppm", "saturated_ppm", "hot_A", "seed",
                                       "pixels", NULL};
    const cJSON *obj = cJSON_GetObjectItemCaseSensitive(root, "defects");
    if (!obj)
        return WDR_OK;
    if (!cJSON_IsObject(obj))
        return fail(c, WDR_E_INVAL, "defects", "must be an object (rates in ppm, \"pixels\")");
    int rc = check_keys(c, obj, "defects.", keys);
    wdr_sim_defects *d = &c->sc->defects;
    c->sc->has_defects = 1;
    for (int k = 1; !rc && k < WDR_DEFECT_KINDS; k++) {
        char key[32], field[48];
        snprintf(key, sizeof key, "%s_ppm", wdr_defect_name(k));
        snprintf(field, sizeof field, "defects.%s", key);
        rc = get_number(c, obj, key, field, 0, 1e6, 0, &d->ppm[k]);
    }
    if (!rc)
        rc = get_number(c, obj, "hot_A", "defects.hot_A", 0, 1e-3, 0, &d->hot_amps);
    double seed = 0;
    if (!rc)
        rc = get_number(c, obj, "seed", "defects.seed", 0, 9007199254740992.0, 0, &seed);
    d->seed = (uint64_t)seed;
    const cJSON *list = cJSON_GetObjectItemCaseSensitive(obj, "pixels");
    if (!rc && list && !cJSON_IsArray(list))
        return fail(c, WDR_E_INVAL, "defects.pixels", "must be an array of {\"x\", \"y\", \"kind\"}");
    return !rc && list ? load_defect_pixels(c, list) : rc;
}

static int load_size(scene_ctx *c, const cJSON *root)
{
    const cJSON *size = cJSON_GetObjectItemCaseSensitive(root, "size");
    if (!size)
        return WDR_OK;
    const cJSON *w = cJSON_GetArrayItem(size, 0), *h = cJSON_GetArrayItem(size, 1);
    if (!cJSON_IsArray(size) || cJSON_GetArraySize(size) != 2 || !cJSON_IsNumber(w) || !cJSON_IsNumber(h))
        return fail(c, WDR_E_INVAL, "size", "must be [width, height]");
    if (w->valuedouble != c->sc->width || h->valuedouble != c->sc->height)
        return fail(c, WDR_E_GEOMETRY, "size", "[%g, %g] differs from the board's %dx%d", w->valuedouble,
                    h->valuedouble, c->sc->width, c->sc->height);
    return WDR_OK;
}

static int load_flags(scene_ctx *c, const cJSON *root)
{
    const cJSON *ref = cJSON_GetObjectItemCaseSensitive(root, "reference");
    if (ref && !cJSON_IsBool(ref))
        return fail(c, WDR_E_INVAL, "reference", "must be true or false");
    c->sc->reference = cJSON_IsTrue(ref);
    int rc = get_number(c, root, "auto_tolerance_lsb", "auto_tolerance_lsb", 0, 1e6, 0.25, &c->sc->tolerance_lsb);
    if (!rc)
        rc = get_seed(c, root, "chip_seed", &c->sc->chip_seed);
    return rc ? rc : get_seed(c, root, "frame_seed", &c->sc->frame_seed);
}

/* Log-average luminance with the guard of the statistics (values at or below 1e-9 of the maximum
 * count as that floor), so auto exposure and the operators agree on the key. */
static double log_average(const float *lum, long n)
{
    double lmax = 0, sum = 0;
    for (long i = 0; i < n; i++)
        lmax = lum[i] > lmax ? lum[i] : lmax;
    if (!(lmax > 0))
        return 0;
    for (long i = 0; i < n; i++)
        sum += log(lum[i] > lmax * 1e-9 ? lum[i] : lmax * 1e-9);
    return exp(sum / (double)n);
}

/* A per cd/m2: the caller's override, else the scene's "exposure" ("auto" or a factor on lum_to_amp). */
static int choose_scale(scene_ctx *c, const cJSON *root, double *k)
{
    wdr_scene *sc = c->sc;
    const cJSON *ex = cJSON_GetObjectItemCaseSensitive(root, "exposure");
    int rc = get_number(c, root, "lum_to_amp", "lum_to_amp", 1e-30, 1, 1.0 / c->board->lum_per_amp, &sc->lum_to_amp);
    sc->exposure = 1.0;
    int scene_auto = cJSON_IsString(ex) && !strcmp(ex->valuestring, "auto");
    if (!rc && cJSON_IsString(ex) && !scene_auto)
        return fail(c, WDR_E_INVAL, "exposure", "'%s' must be \"auto\" or a number", ex->valuestring);
    if (!rc && !scene_auto)
        rc = get_number(c, root, "exposure", "exposure", 1e-12, 1e12, 1.0, &sc->exposure);
    if (rc)
        return rc;
    int mode = c->exposure && c->exposure->mode != WDR_EXPOSURE_SCENE ? c->exposure->mode
               : scene_auto                                           ? WDR_EXPOSURE_AUTO
                                                                      : WDR_EXPOSURE_SCENE;
    sc->key_amp = 0.18 * c->board->i_center_a; /* the key of the board's default ramps */
    if (mode == WDR_EXPOSURE_AUTO && !(sc->l_avg > 0))
        return fail(c, WDR_E_INVAL, "exposure", "auto: the scene has no positive luminance to expose for");
    *k = mode == WDR_EXPOSURE_AUTO    ? sc->key_amp / sc->l_avg
         : mode == WDR_EXPOSURE_FIXED ? c->exposure->amp_per_lum
                                      : sc->lum_to_amp * sc->exposure;
    sc->exposure_auto = mode == WDR_EXPOSURE_AUTO;
    return WDR_OK;
}

/* What the sensor cannot see: pixels below the board's floor (they all read as black) and above
 * its ceiling (they all read as the brightest code). */
static void floor_and_ceiling(wdr_scene *sc, const wdr_board *b)
{
    long n = (long)sc->width * sc->height, below = 0, above = 0;
    for (long i = 0; i < n; i++) {
        below += sc->amps[i] < b->i_min_a;
        above += sc->amps[i] > b->i_max_a;
    }
    sc->below_floor = (double)below / (double)n;
    sc->above_ceiling = (double)above / (double)n;
}

static int to_amps(scene_ctx *c, const cJSON *root)
{
    wdr_scene *sc = c->sc;
    sc->l_avg = log_average(c->lum, (long)sc->width * sc->height);
    double k = 0;
    int rc = choose_scale(c, root, &k);
    if (rc)
        return rc;
    sc->amp_per_lum = k;
    sc->i_min = INFINITY;
    sc->i_max = 0;
    for (long i = 0; i < (long)sc->width * sc->height; i++) {
        sc->amps[i] = (float)(c->lum[i] * k);
        sc->i_min = fmin(sc->i_min, sc->amps[i]);
        sc->i_max = fmax(sc->i_max, sc->amps[i]);
    }
    if (!(sc->i_max <= 1e-3))
        return fail(c, WDR_E_INVAL, "exposure", "photocurrents reach %g A: %g A per cd/m2 is far too large",
                    sc->i_max, k);
    floor_and_ceiling(sc, c->board);
    return WDR_OK;
}

static int load_root(scene_ctx *c, const cJSON *root)
{
    static const char *const keys[] = {"format", "version", "comment", "size", "illumination", "lum_to_amp",
                                       "exposure", "reference", "effects", "auto_tolerance_lsb", "chip_seed",
                                       "frame_seed", "defects", NULL};
    const char *format = get_string(root, "format");
    if (format && strcmp(format, "wdrcam-scene"))
        return fail(c, WDR_E_INVAL, "format", "'%s' is not \"wdrcam-scene\"", format);
    int rc = check_keys(c, root, "", keys);
    if (!rc)
        rc = load_size(c, root);
    if (!rc)
        rc = load_effects(c, root);
    if (!rc)
        rc = load_flags(c, root);
    if (!rc)
        rc = load_defects(c, root);
    if (!rc)
        rc = load_illumination(c, root);
    return rc ? rc : to_amps(c, root);
}

int wdr_scene_load(const char *path, const wdr_board *b, wdr_scene *out, char *err, int errlen)
{
    return wdr_scene_load_exposed(path, b, NULL, out, err, errlen);
}

int wdr_exposure_parse(const char *text, wdr_exposure *out)
{
    char *end;
    if (!strcmp(text, "auto")) {
        *out = (wdr_exposure){WDR_EXPOSURE_AUTO, 0};
        return WDR_OK;
    }
    double v = strtod(text, &end);
    if (end == text || *end || !isfinite(v) || !(v > 0) || v > 1)
        return WDR_E_INVAL;
    *out = (wdr_exposure){WDR_EXPOSURE_FIXED, v};
    return WDR_OK;
}

int wdr_scene_load_exposed(const char *path, const wdr_board *b, const wdr_exposure *ex, wdr_scene *out, char *err,
                           int errlen)
{
    memset(out, 0, sizeof *out);
    out->width = b->width;
    out->height = b->height;
    out->chip_seed = out->frame_seed = 1;
    char file[4200];
    wdr_data_path(WDR_DATA_SCENES, path, file, sizeof file); /* a name: the installed scenes */
    scene_ctx c = {file, b, out, ex, NULL, err, errlen};

    char *text = wdr_read_text(file);
    if (!text && wdr_data_is_name(path) && access(file, F_OK) != 0) {
        wdr_data_unknown(WDR_DATA_SCENES, path, err, errlen);
        return WDR_E_IO;
    }
    if (!text) {
        snprintf(err, (size_t)errlen, "%s: cannot read scene file", file);
        return WDR_E_IO;
    }
    cJSON *root = cJSON_Parse(text);
    size_t n = (size_t)out->width * out->height;
    out->amps = malloc(n * sizeof *out->amps);
    c.lum = malloc(n * sizeof *c.lum);
    int rc;
    if (!root || !cJSON_IsObject(root))
        rc = fail(&c, WDR_E_INVAL, "(top level)", "not a JSON object (near '%.20s')",
                  cJSON_GetErrorPtr() ? cJSON_GetErrorPtr() : "");
    else
        rc = out->amps && c.lum ? load_root(&c, root) : WDR_E_NOMEM;
    cJSON_Delete(root);
    free(text);
    free(c.lum);
    if (rc)
        wdr_scene_free(out);
    return rc;
}

void wdr_scene_free(wdr_scene *sc)
{
    free(sc->amps);
    sc->amps = NULL;
    free((void *)sc->defects.listed_index);
    free((void *)sc->defects.listed_kind);
    sc->defects.listed_index = NULL;
    sc->defects.listed_kind = NULL;
}

int wdr_scene_apply(const wdr_scene *sc, wdr_sim *s)
{
    const wdr_board *b = wdr_sim_board(s);
    if (b->width != sc->width || b->height != sc->height)
        return WDR_E_GEOMETRY;
    for (int k = 0; k < WDR_FX_COUNT; k++)
        wdr_sim_set_effect(s, k, sc->effects[k]);
    wdr_sim_set_auto_tolerance(s, sc->tolerance_lsb);
    wdr_sim_set_reference(s, sc->reference);
    int rc = sc->has_defects ? wdr_sim_set_defects(s, &sc->defects) : WDR_OK;
    return rc ? rc : wdr_sim_set_photocurrent(s, sc->amps);
}

void wdr_scene_print_range(FILE *f, const char *tool, const wdr_scene *sc, const wdr_board *b)
{
    if (sc->exposure_auto)
        fprintf(f, "%s: exposure auto: %.4g A per cd/m2 (scene log-average %.4g cd/m2 onto the ramp's key %.4g A)\n",
                tool, sc->amp_per_lum, sc->l_avg, sc->key_amp);
    else
        fprintf(f, "%s: exposure %.4g A per cd/m2 (scene log-average %.4g cd/m2 -> %.4g A; the ramp's key %.4g A)\n",
                tool, sc->amp_per_lum, sc->l_avg, sc->l_avg * sc->amp_per_lum, sc->key_amp);
    fprintf(f, "%s: %.2f %% of the pixels lie below the sensor's floor (%.3g A) and %.2f %% above its ceiling "
               "(%.3g A)%s\n",
            tool, 100 * sc->below_floor, b->i_min_a, 100 * sc->above_ceiling, b->i_max_a,
            sc->below_floor + sc->above_ceiling > 0.01 ? ": they will read as black or as white" : "");
}
