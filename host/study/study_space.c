/* The study's knobs: lists and ranges as text (command line or study file), expanded into every
 * valid combination of design points. */
#include "study.h"
#include "operators.h"
#include "wdr_cal.h"
#include "wdr_lut.h"
#include <cJSON.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sysexits.h>

#define MAX_VALUES 64

int study_fail(int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("wdrctl: study: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return code;
}

/* ---- lists ---- */

/* Split text at commas into at most MAX_VALUES items of buf. */
static int split(const char *text, char *buf, size_t cap, char **items)
{
    snprintf(buf, cap, "%s", text);
    int n = 0;
    char *save = NULL;
    for (char *t = strtok_r(buf, ",", &save); t && n < MAX_VALUES; t = strtok_r(NULL, ",", &save))
        items[n++] = t;
    return n;
}

/* Whole numbers: "10,12" or "10:16:2" (add) or "4:64:*4" (multiply), mixed. */
static int int_list(const char *knob, const char *text, int lo, int hi, int *v, int *n)
{
    char buf[1024], *items[MAX_VALUES];
    int m = split(text, buf, sizeof buf, items);
    *n = 0;
    for (int i = 0; i < m; i++) {
        long a, b, step = 1;
        char mul = 0, *e;
        a = strtol(items[i], &e, 10);
        b = a;
        if (e != items[i] && *e == ':') {
            b = strtol(e + 1, &e, 10);
            if (*e == ':')
                mul = e[1] == '*' ? '*' : 0, step = strtol(e + 1 + (mul != 0), &e, 10);
        }
        if (e == items[i] || *e || a < lo || b > hi || a > b || step < 1 + (mul != 0))
            return study_fail(EX_USAGE,
                              "--%s: '%s' is not a whole number, or a range A:B[:STEP|:*FACTOR], "
                              "in %d..%d",
                              knob, items[i], lo, hi);
        for (long x = a; x <= b && *n < MAX_VALUES; x = mul ? x * step : x + step)
            v[(*n)++] = (int)x;
    }
    return *n ? EX_OK : study_fail(EX_USAGE, "--%s: empty list", knob);
}

static int double_list(const char *knob, const char *text, double lo, double hi, double *v, int *n)
{
    char buf[1024], *items[MAX_VALUES];
    int m = split(text, buf, sizeof buf, items);
    for (int i = 0; i < m; i++) {
        char *e;
        v[i] = strtod(items[i], &e);
        if (e == items[i] || *e || !(v[i] >= lo && v[i] <= hi))
            return study_fail(EX_USAGE, "--%s: '%s' is not a number in %g..%g", knob, items[i], lo, hi);
    }
    *n = m;
    return m ? EX_OK : study_fail(EX_USAGE, "--%s: empty list", knob);
}

/* Voltage ranges "LO:HI,LO:HI" (V). */
static int range_list(const char *knob, const char *text, double *lo, double *hi, int *n)
{
    char buf[1024], *items[MAX_VALUES];
    int m = split(text, buf, sizeof buf, items);
    for (int i = 0; i < m; i++) {
        char *e;
        lo[i] = strtod(items[i], &e);
        hi[i] = *e == ':' ? strtod(e + 1, &e) : NAN;
        if (*e || !isfinite(lo[i]) || !isfinite(hi[i]) || !(hi[i] > lo[i]) || lo[i] < -5 || hi[i] > 10)
            return study_fail(EX_USAGE, "--%s: '%s' is not a voltage range LO:HI with LO < HI (V)", knob, items[i]);
    }
    *n = m;
    return m ? EX_OK : study_fail(EX_USAGE, "--%s: empty list", knob);
}

/* Names from a fixed set: v gets the ids. */
static int name_list(const char *knob, const char *text, const char *const *names, const int *ids, int n_names, int *v,
                     int *n)
{
    char buf[1024], *items[MAX_VALUES], known[256] = "";
    int m = split(text, buf, sizeof buf, items);
    for (int k = 0; k < n_names; k++)
        snprintf(known + strlen(known), sizeof known - strlen(known), "%s%s", k ? ", " : "", names[k]);
    for (int i = 0; i < m; i++) {
        int k = 0;
        while (k < n_names && strcmp(items[i], names[k]))
            k++;
        if (k == n_names)
            return study_fail(EX_USAGE, "--%s: unknown value '%s' (known: %s)", knob, items[i], known);
        v[i] = ids[k];
    }
    *n = m;
    return m ? EX_OK : study_fail(EX_USAGE, "--%s: empty list", knob);
}

static int size_list(const char *text, int *w, int *h, int *n)
{
    char buf[1024], *items[MAX_VALUES];
    int m = split(text, buf, sizeof buf, items);
    for (int i = 0; i < m; i++) {
        char *e;
        long a = strtol(items[i], &e, 10), b = *e == 'x' ? strtol(e + 1, &e, 10) : 0;
        if (*e || a < 16 || b < 16 || a > 4096 || b > 4096)
            return study_fail(EX_USAGE, "--size: '%s' is not WIDTHxHEIGHT with each in 16..4096", items[i]);
        w[i] = (int)a, h[i] = (int)b;
    }
    *n = m;
    return m ? EX_OK : study_fail(EX_USAGE, "--size: empty list");
}

/* Operator parameters "key=a,b;key2=c": every combination, as "key=a;key2=c" strings. */
static int param_list(const char *text, char out[][STUDY_OP_PARAMS], int *n)
{
    char buf[1024], *save = NULL, *keys[8];
    int nk = 0;
    snprintf(buf, sizeof buf, "%s", text);
    for (char *t = strtok_r(buf, ";", &save); t && nk < 8; t = strtok_r(NULL, ";", &save))
        keys[nk++] = t;
    *n = 1;
    out[0][0] = 0;
    for (int k = 0; k < nk; k++) {
        char *eq = strchr(keys[k], '=');
        if (!eq || eq == keys[k])
            return study_fail(EX_USAGE, "--param: '%s' is not KEY=V1[,V2...]", keys[k]);
        *eq = 0;
        char vbuf[512], *vals[MAX_VALUES];
        int nv = split(eq + 1, vbuf, sizeof vbuf, vals), m = *n;
        if (!nv || m * nv > MAX_VALUES)
            return study_fail(EX_USAGE, "--param: %s: no values, or too many combinations", keys[k]);
        for (int j = nv - 1; j >= 0; j--)
            for (int i = 0; i < m; i++) {
                char *dst = out[j * m + i];
                if (j)
                    memcpy(dst, out[i], STUDY_OP_PARAMS);
                size_t l = strlen(dst);
                snprintf(dst + l, STUDY_OP_PARAMS - l, "%s%s=%s", l ? ";" : "", keys[k], vals[j]);
            }
        *n = m * nv;
    }
    return EX_OK;
}

/* ---- the study file ---- */

int study_knobs_from_file(const char *path, study_knobs *k, void **keep)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return study_fail(EX_NOINPUT, "%s: cannot read the study file", path);
    static char text[1 << 16];
    size_t len = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[len] = 0;
    cJSON *j = cJSON_Parse(text);
    if (!cJSON_IsObject(j))
        return cJSON_Delete(j), study_fail(EX_DATAERR, "%s: not a JSON object", path);
    static const struct {
        const char *key;
        size_t off;
    } keys[] = {
#define K(name, field) {name, offsetof(study_knobs, field)}
        K("adc-bits", adc_bits),
        K("adc-range", adc_range),
        K("dac-bits", dac_bits),
        K("dac-range", dac_range),
        K("converter-ranges", ranges),
        K("timing", timing),
        K("entries", entries),
        K("dac-timer-hz", timer_hz),
        K("operator", op),
        K("param", params),
        K("model", model),
        K("form", form),
        K("coeffs", coeffs),
        K("coeff-bits", coeff_bits),
        K("levels", levels),
        K("levels-choice", levels_choice),
        K("frames", frames),
        K("image-frames", image_frames),
        K("size", size)};
#undef K
    cJSON *store = cJSON_CreateArray(), *holder = cJSON_CreateArray();
    cJSON_AddItemToArray(holder, j), cJSON_AddItemToArray(holder, store);
    for (cJSON *it = j->child; it; it = it->next) {
        size_t i = 0;
        while (i < sizeof keys / sizeof keys[0] && strcmp(it->string, keys[i].key))
            i++;
        if (i == sizeof keys / sizeof keys[0]) {
            study_fail(EX_DATAERR, "%s: unknown field '%s' (fields are the long options: adc-bits, frames, ...)", path,
                       it->string);
            return cJSON_Delete(holder), EX_DATAERR;
        }
        /* a list is written as the command line's comma list */
        char list[1024] = "";
        cJSON *vals = cJSON_IsArray(it) ? it->child : it;
        for (cJSON *v = vals; v; v = cJSON_IsArray(it) ? v->next : NULL) {
            size_t l = strlen(list);
            if (cJSON_IsString(v))
                snprintf(list + l, sizeof list - l, "%s%s", l ? "," : "", v->valuestring);
            else if (cJSON_IsNumber(v))
                snprintf(list + l, sizeof list - l, "%s%.17g", l ? "," : "", v->valuedouble);
            else {
                study_fail(EX_DATAERR, "%s: field '%s': values must be strings or numbers", path, it->string);
                return cJSON_Delete(holder), EX_DATAERR;
            }
        }
        cJSON *s = cJSON_CreateString(list);
        cJSON_AddItemToArray(store, s); /* kept alive with the document */
        *(const char **)((char *)k + keys[i].off) = s->valuestring;
    }
    *keep = holder;
    return EX_OK;
}

void study_knobs_free_file(void *keep)
{
    cJSON_Delete(keep);
}

/* ---- expansion ---- */

enum {
    D_ADC,
    D_ADCR,
    D_DAC,
    D_DACR,
    D_FIT,
    D_TIM,
    D_ENT,
    D_HZ,
    D_OP,
    D_PAR,
    D_MOD,
    D_FORM,
    D_NC,
    D_CB,
    D_LEV,
    D_CH,
    D_FR,
    D_IMG,
    D_SIZE,
    D_COUNT
};

typedef struct space {
    int n[D_COUNT];
    int adc[MAX_VALUES], dac[MAX_VALUES], fit[2], tim[2], ent[MAX_VALUES], ops[16], mod[8], form[8], nc[MAX_VALUES],
        cb[2], lev[MAX_VALUES], ch[2], fr[MAX_VALUES], img[MAX_VALUES], w[MAX_VALUES], h[MAX_VALUES];
    double adc_lo[MAX_VALUES], adc_hi[MAX_VALUES], dac_lo[MAX_VALUES], dac_hi[MAX_VALUES], hz[MAX_VALUES];
    char op_names[16][32];
    char params[MAX_VALUES][STUDY_OP_PARAMS];
} space;

static int parse_names(const study_knobs *k, space *sp)
{
    static const char *const ranges[] = {"full", "fit"}, *const timing[] = {"stamped", "uniform"},
                             *const models[] = {"simple3", "complex4", "lsq", "polymap", "spline"},
                             *const forms[] = {"auto", "moebius", "poly", "basis", "compact", "shifted"},
                             *const choice[] = {"log", "select"};
    static const int ranges_id[] = {0, 1}, timing_id[] = {WDR_TIMING_STAMPED, WDR_TIMING_UNIFORM},
                     models_id[] = {WDR_MODEL_SIMPLE3, WDR_MODEL_COMPLEX4, WDR_MODEL_LSQ, WDR_MODEL_POLYMAP,
                                    WDR_MODEL_SPLINE},
                     forms_id[] = {-1, WDR_FORM_MOEBIUS, WDR_FORM_POLY, WDR_FORM_BASIS, WDR_FORM_COMPACT, WDR_FORM_SHIFTED},
                     choice_id[] = {STUDY_LEVELS_LOG, STUDY_LEVELS_SELECT};
    int rc;
    if ((rc = name_list("converter-ranges", k->ranges ? k->ranges : "full", ranges, ranges_id, 2, sp->fit,
                        &sp->n[D_FIT])) ||
        (rc = name_list("timing", k->timing ? k->timing : "stamped", timing, timing_id, 2, sp->tim, &sp->n[D_TIM])) ||
        (rc = name_list("model", k->model ? k->model : "spline", models, models_id, 5, sp->mod, &sp->n[D_MOD])) ||
        (rc = name_list("form", k->form ? k->form : "auto", forms, forms_id, 6, sp->form, &sp->n[D_FORM])) ||
        (rc = name_list("levels-choice", k->levels_choice ? k->levels_choice : "log", choice, choice_id, 2, sp->ch,
                        &sp->n[D_CH])))
        return rc;
    char buf[512], *items[MAX_VALUES];
    sp->n[D_OP] = split(k->op ? k->op : "reinhard", buf, sizeof buf, items);
    for (int i = 0; i < sp->n[D_OP] && i < 16; i++) {
        if (!wdr_operator_info_by_name(items[i]))
            return study_fail(EX_USAGE, "--operator: unknown operator '%s' (see 'wdrctl operators')", items[i]);
        snprintf(sp->op_names[i], sizeof sp->op_names[i], "%s", items[i]);
    }
    sp->n[D_OP] = sp->n[D_OP] > 16 ? 16 : sp->n[D_OP];
    return EX_OK;
}

static int parse_space(const study_knobs *k, space *sp)
{
    int rc = parse_names(k, sp);
    if (rc)
        return rc;
    sp->n[D_ADCR] = sp->n[D_DACR] = sp->n[D_ENT] = sp->n[D_HZ] = 1;
    sp->adc_lo[0] = sp->adc_hi[0] = sp->dac_lo[0] = sp->dac_hi[0] = NAN, sp->ent[0] = 0, sp->hz[0] = 0;
    if ((rc = int_list("adc-bits", k->adc_bits ? k->adc_bits : "12", 8, 16, sp->adc, &sp->n[D_ADC])) ||
        (rc = int_list("dac-bits", k->dac_bits ? k->dac_bits : "12", 8, 16, sp->dac, &sp->n[D_DAC])) ||
        (k->adc_range && (rc = range_list("adc-range", k->adc_range, sp->adc_lo, sp->adc_hi, &sp->n[D_ADCR]))) ||
        (k->dac_range && (rc = range_list("dac-range", k->dac_range, sp->dac_lo, sp->dac_hi, &sp->n[D_DACR]))) ||
        (k->entries && (rc = int_list("entries", k->entries, 16, (int)WDR_LUT_MAX_ENTRIES, sp->ent, &sp->n[D_ENT]))) ||
        (k->timer_hz && (rc = double_list("dac-timer-hz", k->timer_hz, 1e3, 4e9, sp->hz, &sp->n[D_HZ]))) ||
        (rc = int_list("coeffs", k->coeffs ? k->coeffs : "0", 0, 8, sp->nc, &sp->n[D_NC])) ||
        (rc = int_list("levels", k->levels ? k->levels : "19", 3, 40, sp->lev, &sp->n[D_LEV])) ||
        (rc = int_list("frames", k->frames ? k->frames : "4", 1, 4096, sp->fr, &sp->n[D_FR])) ||
        (rc = int_list("image-frames", k->image_frames ? k->image_frames : "1", 1, 4096, sp->img, &sp->n[D_IMG])) ||
        (rc = size_list(k->size ? k->size : "64x48", sp->w, sp->h, &sp->n[D_SIZE])) ||
        (rc = param_list(k->params ? k->params : "", sp->params, &sp->n[D_PAR])))
        return rc;
    sp->n[D_CB] = 0;
    int cb[MAX_VALUES], ncb;
    if ((rc = int_list("coeff-bits", k->coeff_bits ? k->coeff_bits : "32", 16, 32, cb, &ncb)))
        return rc;
    for (int i = 0; i < ncb; i++) {
        if (cb[i] != 16 && cb[i] != 32)
            return study_fail(EX_USAGE, "--coeff-bits: %d is not 16 (IEEE half) or 32 (float32)", cb[i]);
        if (sp->n[D_CB] < 2)
            sp->cb[sp->n[D_CB]++] = cb[i];
    }
    return EX_OK;
}

/* A knob that does not act on this point takes its first value only, so no point repeats. */
static int knob_acts(const study_point *p, int d)
{
    switch (d) {
    case D_ADCR:
    case D_DACR: return !p->fit_ranges;
    case D_ENT: return p->timing == WDR_TIMING_UNIFORM;
    case D_HZ: return p->timing == WDR_TIMING_STAMPED;
    case D_NC: return p->form != WDR_FORM_MOEBIUS && !wdr_cal_form_compact((uint16_t)p->form); /* fixed counts */
    default: return 1; /* D_LEV too: the paper models take 3 or 4 levels exact, more by least squares */
    }
}

/* Model and table form pairs the table builder accepts (cal_table.c check_form), and paper models
 * given at least as many levels as they have parameters. */
static int form_valid(const study_point *p)
{
    if (p->n_levels < (p->model == WDR_MODEL_SIMPLE3 ? 3 : p->model == WDR_MODEL_COMPLEX4 ? 4 : 0))
        return 0; /* fewer levels than the paper model's parameters */
    if (p->form == WDR_FORM_MOEBIUS)
        return p->model == WDR_MODEL_SIMPLE3;
    if (wdr_cal_form_compact((uint16_t)p->form)) /* the shared basis: learnt from the spline's maps */
        return p->model == WDR_MODEL_SPLINE;
    if (p->model == WDR_MODEL_POLYMAP && p->form == WDR_FORM_POLY)
        return p->n_coeffs == 0; /* the polynomial map is its own table */
    return p->n_coeffs == 0 || p->n_coeffs >= 2;
}

static int same_double(double a, double b)
{
    return a == b || (isnan(a) && isnan(b));
}

static int same_point(const study_point *a, const study_point *b)
{
    return a->adc_bits == b->adc_bits && a->dac_bits == b->dac_bits && a->fit_ranges == b->fit_ranges &&
           same_double(a->adc_lo_v, b->adc_lo_v) && same_double(a->adc_hi_v, b->adc_hi_v) &&
           same_double(a->dac_lo_v, b->dac_lo_v) && same_double(a->dac_hi_v, b->dac_hi_v) && a->timing == b->timing &&
           a->uniform_entries == b->uniform_entries && a->dac_timer_hz == b->dac_timer_hz && !strcmp(a->op, b->op) &&
           !strcmp(a->op_params, b->op_params) && a->model == b->model && a->form == b->form &&
           a->n_coeffs == b->n_coeffs && a->coeff_bits == b->coeff_bits && a->n_levels == b->n_levels &&
           a->levels_choice == b->levels_choice && a->frames_cal == b->frames_cal && a->frames_img == b->frames_img &&
           a->width == b->width && a->height == b->height;
}

static void fill_point(const space *sp, const int *i, study_point *p)
{
    *p = (study_point){.adc_bits = sp->adc[i[D_ADC]],
                       .adc_lo_v = sp->adc_lo[i[D_ADCR]],
                       .adc_hi_v = sp->adc_hi[i[D_ADCR]],
                       .dac_bits = sp->dac[i[D_DAC]],
                       .dac_lo_v = sp->dac_lo[i[D_DACR]],
                       .dac_hi_v = sp->dac_hi[i[D_DACR]],
                       .fit_ranges = sp->fit[i[D_FIT]],
                       .timing = sp->tim[i[D_TIM]],
                       .uniform_entries = (uint32_t)sp->ent[i[D_ENT]],
                       .dac_timer_hz = sp->hz[i[D_HZ]],
                       .model = sp->mod[i[D_MOD]],
                       .n_coeffs = sp->nc[i[D_NC]],
                       .coeff_bits = sp->cb[i[D_CB]],
                       .n_levels = sp->lev[i[D_LEV]],
                       .levels_choice = sp->ch[i[D_CH]],
                       .frames_cal = sp->fr[i[D_FR]],
                       .frames_img = sp->img[i[D_IMG]],
                       .width = sp->w[i[D_SIZE]],
                       .height = sp->h[i[D_SIZE]]};
    snprintf(p->op, sizeof p->op, "%s", sp->op_names[i[D_OP]]);
    snprintf(p->op_params, sizeof p->op_params, "%s", sp->params[i[D_PAR]]);
    int f = sp->form[i[D_FORM]];
    p->form = f >= 0                          ? f
              : p->model == WDR_MODEL_SIMPLE3 ? WDR_FORM_MOEBIUS
              : p->model == WDR_MODEL_SPLINE  ? WDR_FORM_BASIS
                                              : WDR_FORM_POLY;
    if (wdr_cal_form_compact((uint16_t)p->form))
        p->n_coeffs = WDR_CAL_COMPACT_COEFFS; /* fixed by the form */
}

int study_expand(const study_knobs *k, study *s, int *skipped)
{
    space *sp = calloc(1, sizeof *sp);
    int rc = sp ? parse_space(k, sp) : study_fail(EX_OSERR, "out of memory");
    s->n = *skipped = 0;
    s->pts = rc ? NULL : malloc(sizeof(study_point) * STUDY_MAX_POINTS);
    if (!rc && !s->pts)
        rc = study_fail(EX_OSERR, "out of memory");
    int idx[D_COUNT] = {0};
    for (int done = rc != EX_OK; !done;) {
        study_point p;
        fill_point(sp, idx, &p);
        int dup = 0;
        for (int d = 0; d < D_COUNT; d++)
            dup |= idx[d] > 0 && !knob_acts(&p, d);
        for (int q = s->n - 1; !dup && q >= 0; q--) /* "auto" may name a form also listed */
            dup = same_point(&s->pts[q], &p);
        if (!dup && !form_valid(&p))
            ++*skipped;
        else if (!dup && s->n == STUDY_MAX_POINTS)
            rc = study_fail(EX_USAGE, "more than %d points: narrow the lists", STUDY_MAX_POINTS), done = 1;
        else if (!dup)
            s->pts[s->n++] = p;
        int d = 0; /* the odometer */
        while (d < D_COUNT && ++idx[d] == sp->n[d])
            idx[d++] = 0;
        done |= d == D_COUNT;
    }
    free(sp);
    if (!rc && !s->n)
        rc = study_fail(EX_USAGE, "no valid point (every model/form pair was refused)");
    return rc;
}
