#include "operators.h"
#include "wdr_err.h"
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SCENE NAN /* default taken from the scene statistics */

/* ---- the table of operators ---- */

static const wdr_operator_info op_table[WDR_OP_COUNT] = {
    [WDR_OP_LINEAR] = {WDR_OP_LINEAR, "linear", "T = min(1, L/L_max): no compression, an ordinary pixel", 0, {{0}}},
    [WDR_OP_REINHARD] = {WDR_OP_REINHARD, "reinhard", "Reinhard 2002 simple: L/(1+L), L = a L_w / L_avg", 1,
                         {{"key", 0.18, 1e-6, 1e6, "key value a"}}},
    [WDR_OP_REINHARD_WHITE] = {WDR_OP_REINHARD_WHITE, "reinhard_white",
                               "Reinhard 2002 with white point: L(1+L/L_white^2)/(1+L)", 2,
                               {{"key", 0.18, 1e-6, 1e6, "key value a"},
                                {"white", SCENE, 1e-12, 1e15, "world luminance mapped to white (default L_max)"}}},
    [WDR_OP_SCHLICK] = {WDR_OP_SCHLICK, "schlick", "Schlick 1994: p L/((p-1) L + L_max)", 1,
                        {{"p", 100.0, 1.0, 1e12, "rational mapping parameter, p >= 1"}}},
    [WDR_OP_TUMBLIN_RUSHMEIER] = {WDR_OP_TUMBLIN_RUSHMEIER, "tumblin_rushmeier",
                                  "Tumblin-Rushmeier 1999 revision: m L_da (L/L_wa)^(g_w/g_d) / L_dmax", 4,
                                  {{"l_da", 20.0, 1e-3, 1e5, "display adaptation luminance (cd/m2)"},
                                   {"l_dmax", 100.0, 1e-3, 1e5, "display maximum luminance (cd/m2)"},
                                   {"c_max", 100.0, 1.0, 1e6, "maximum display contrast"},
                                   {"l_wa", SCENE, 1e-12, 1e15, "world adaptation luminance (default L_avg)"}}},
    [WDR_OP_DRAGO] = {WDR_OP_DRAGO, "drago", "Drago 2003 adaptive logarithmic mapping", 2,
                      {{"bias", 0.85, 0.5, 1.0, "bias b"},
                       {"l_dmax", 100.0, 1e-3, 1e5, "display maximum luminance (cd/m2)"}}},
    [WDR_OP_EXPONENTIAL] = {WDR_OP_EXPONENTIAL, "exponential", "1 - exp(-L/L_avg)", 0, {{0}}},
    [WDR_OP_LOGARITHMIC] = {WDR_OP_LOGARITHMIC, "logarithmic", "log(1 + L/l_ref) / log(1 + L_max/l_ref)", 1,
                            {{"l_ref", SCENE, 1e-15, 1e15,
                              "luminance unit inside the log (default L_min; 1 gives the paper's eq. 15)"}}},
    [WDR_OP_USER_CURVE] = {WDR_OP_USER_CURVE, "user", "user curve from a CSV file (luminance,display)", 0, {{0}}},
};

const wdr_operator_info *wdr_operator_info_by_id(int id)
{
    return id >= 0 && id < WDR_OP_COUNT ? &op_table[id] : NULL;
}

const wdr_operator_info *wdr_operator_info_by_name(const char *name)
{
    for (int i = 0; i < WDR_OP_COUNT; i++)
        if (!strcmp(op_table[i].name, name))
            return &op_table[i];
    return NULL;
}

/* ---- set-up and validation ---- */

static void known_names(char *buf, size_t len)
{
    buf[0] = 0;
    for (int i = 0; i < WDR_OP_COUNT; i++) {
        strncat(buf, op_table[i].name, len - strlen(buf) - 1);
        if (i + 1 < WDR_OP_COUNT)
            strncat(buf, ", ", len - strlen(buf) - 1);
    }
}

int wdr_operator_init(wdr_operator *op, const char *name, const wdr_lum_stats *stats, char *err, int errlen)
{
    const wdr_operator_info *info = wdr_operator_info_by_name(name);
    if (!info) {
        char names[256];
        known_names(names, sizeof names);
        snprintf(err, (size_t)errlen, "unknown operator '%s' (known: %s)", name, names);
        return WDR_E_INVAL;
    }
    op->id = info->id;
    op->stats = *stats;
    op->n_knots = 0;
    for (int i = 0; i < WDR_OP_MAX_PARAMS; i++)
        op->p[i] = i < info->n_params ? info->params[i].def : 0.0;
    return WDR_OK;
}

static int find_param(const wdr_operator_info *info, const char *key, size_t keylen)
{
    for (int i = 0; i < info->n_params; i++)
        if (strlen(info->params[i].name) == keylen && !strncmp(info->params[i].name, key, keylen))
            return i;
    return -1;
}

int wdr_operator_set_param(wdr_operator *op, const char *kv, char *err, int errlen)
{
    const wdr_operator_info *info = wdr_operator_info_by_id(op->id);
    const char *eq = strchr(kv, '=');
    if (!eq) {
        snprintf(err, (size_t)errlen, "parameter '%s': expected key=value", kv);
        return WDR_E_INVAL;
    }
    int i = find_param(info, kv, (size_t)(eq - kv));
    if (i < 0) {
        snprintf(err, (size_t)errlen, "operator %s has no parameter '%.*s'", info->name, (int)(eq - kv), kv);
        return WDR_E_INVAL;
    }
    char *end;
    errno = 0;
    double v = strtod(eq + 1, &end);
    if (end == eq + 1 || *end || errno == ERANGE) {
        snprintf(err, (size_t)errlen, "parameter %s: '%s' is not a number", info->params[i].name, eq + 1);
        return WDR_E_INVAL;
    }
    op->p[i] = v;
    return wdr_operator_validate(op, err, errlen);
}

static int check_stat(const char *name, double v, char *err, int errlen)
{
    if (isfinite(v) && v > 0)
        return WDR_OK;
    snprintf(err, (size_t)errlen, "scene statistic %s = %g must be finite and positive", name, v);
    return WDR_E_INVAL;
}

int wdr_operator_validate(const wdr_operator *op, char *err, int errlen)
{
    const wdr_operator_info *info = wdr_operator_info_by_id(op->id);
    if (!info) {
        snprintf(err, (size_t)errlen, "operator id %d is unknown", op->id);
        return WDR_E_INVAL;
    }
    for (int i = 0; i < info->n_params; i++) {
        const wdr_param_info *pi = &info->params[i];
        double v = op->p[i];
        if (isnan(pi->def) && isnan(v))
            continue; /* taken from the scene */
        if (!isfinite(v) || v < pi->min || v > pi->max) {
            snprintf(err, (size_t)errlen, "operator %s: parameter %s = %g is out of range [%g, %g] (%s)", info->name,
                     pi->name, v, pi->min, pi->max, pi->doc);
            return WDR_E_INVAL;
        }
    }
    int rc = check_stat("L_avg", op->stats.l_avg, err, errlen);
    if (!rc)
        rc = check_stat("L_max", op->stats.l_max, err, errlen);
    if (!rc)
        rc = check_stat("L_min", op->stats.l_min, err, errlen);
    if (!rc && op->id == WDR_OP_USER_CURVE && op->n_knots < 2) {
        snprintf(err, (size_t)errlen, "operator user: no curve loaded (use --curve FILE.csv)");
        rc = WDR_E_INVAL;
    }
    return rc;
}

/* ---- evaluation ---- */

static double param_or(double v, double scene_value) { return isnan(v) ? scene_value : v; }

static double clamp01(double t) { return t < 0 ? 0 : (t > 1 ? 1 : t); }

/* Stevens' brightness exponent of the 1999 Tumblin-Rushmeier revision. */
static double tr_gamma(double l)
{
    return l > 100.0 ? 2.655 : 1.855 + 0.4 * log10(l + 2.3e-5);
}

static double eval_tumblin(const wdr_operator *op, double lw)
{
    double l_da = op->p[0], l_dmax = op->p[1], c_max = op->p[2];
    double l_wa = param_or(op->p[3], op->stats.l_avg);
    double g_w = tr_gamma(l_wa), g_d = tr_gamma(l_da);
    double m = pow(sqrt(c_max), g_w / (1.855 + 0.4 * log10(l_da)) - 1.0);
    return clamp01(m * l_da * pow(lw / l_wa, g_w / g_d) / l_dmax);
}

static double eval_drago(const wdr_operator *op, double lw)
{
    double b = op->p[0], l_dmax = op->p[1];
    double l = lw / op->stats.l_avg, lmax = op->stats.l_max / op->stats.l_avg;
    if (l >= lmax)
        return l_dmax * 0.01; /* the scene has nothing brighter: saturate */
    double denom = log(2.0 + 8.0 * pow(l / lmax, log(b) / log(0.5)));
    /* Not clamped: past L_max/L_avg ~ 2e5 the curve overshoots 1 and turns down before L_max,
     * and the ramp builder must see that to refuse or repair it. */
    return l_dmax * 0.01 / log10(1.0 + lmax) * log1p(l) / denom;
}

/* Linear in ln L between knots; proportional to L below the first knot; flat above the last. */
static double eval_user(const wdr_operator *op, double lw)
{
    int n = op->n_knots;
    if (lw <= 0)
        return 0;
    double x = log(lw);
    if (x <= op->knot_ln_l[0])
        return op->knot_t[0] * exp(x - op->knot_ln_l[0]);
    if (x >= op->knot_ln_l[n - 1])
        return op->knot_t[n - 1];
    int lo = 0, hi = n - 1;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (op->knot_ln_l[mid] <= x)
            lo = mid;
        else
            hi = mid;
    }
    double f = (x - op->knot_ln_l[lo]) / (op->knot_ln_l[hi] - op->knot_ln_l[lo]);
    return op->knot_t[lo] + f * (op->knot_t[hi] - op->knot_t[lo]);
}

double wdr_operator_eval(const wdr_operator *op, double lw)
{
    const wdr_lum_stats *s = &op->stats;
    if (!(lw > 0))
        return 0;
    if (isinf(lw))
        return 1;
    switch (op->id) {
    case WDR_OP_LINEAR: return clamp01(lw / s->l_max);
    case WDR_OP_REINHARD: {
        double l = op->p[0] * lw / s->l_avg;
        return l / (1.0 + l);
    }
    case WDR_OP_REINHARD_WHITE: {
        double l = op->p[0] * lw / s->l_avg, w = op->p[0] * param_or(op->p[1], s->l_max) / s->l_avg;
        return clamp01(l * (1.0 + l / (w * w)) / (1.0 + l));
    }
    case WDR_OP_SCHLICK: return clamp01(op->p[0] * lw / ((op->p[0] - 1.0) * lw + s->l_max));
    case WDR_OP_TUMBLIN_RUSHMEIER: return eval_tumblin(op, lw);
    case WDR_OP_DRAGO: return eval_drago(op, lw);
    case WDR_OP_EXPONENTIAL: return -expm1(-lw / s->l_avg);
    case WDR_OP_LOGARITHMIC: {
        double r = param_or(op->p[0], s->l_min);
        return clamp01(log1p(lw / r) / log1p(s->l_max / r));
    }
    case WDR_OP_USER_CURVE: return eval_user(op, lw);
    default: return 0;
    }
}

/* ---- user curve file ---- */

static int curve_row(wdr_operator *op, const char *path, int lineno, const char *line, char *err, int errlen)
{
    char *end;
    double l = strtod(line, &end);
    if (end == line || *end != ',') {
        snprintf(err, (size_t)errlen, "%s:%d: field 'luminance': '%.40s' is not a number followed by ','", path,
                 lineno, line);
        return WDR_E_INVAL;
    }
    const char *rest = end + 1;
    double t = strtod(rest, &end);
    while (*end == ' ' || *end == '\r' || *end == '\n' || *end == '\t')
        end++;
    if (end == rest || *end) {
        snprintf(err, (size_t)errlen, "%s:%d: field 'display': '%.40s' is not a number", path, lineno, rest);
        return WDR_E_INVAL;
    }
    if (!isfinite(l) || l <= 0) {
        snprintf(err, (size_t)errlen, "%s:%d: field 'luminance' = %g must be finite and > 0", path, lineno, l);
        return WDR_E_INVAL;
    }
    if (!isfinite(t) || t < 0 || t > 1) {
        snprintf(err, (size_t)errlen, "%s:%d: field 'display' = %g must be in [0, 1]", path, lineno, t);
        return WDR_E_INVAL;
    }
    int n = op->n_knots;
    if (n > 0 && (log(l) <= op->knot_ln_l[n - 1] || t < op->knot_t[n - 1])) {
        snprintf(err, (size_t)errlen,
                 "%s:%d: curve not monotone: luminance %g, display %g after luminance %g, display %g", path,
                 lineno, l, t, exp(op->knot_ln_l[n - 1]), op->knot_t[n - 1]);
        return WDR_E_INVAL;
    }
    if (n >= WDR_USER_CURVE_MAX) {
        snprintf(err, (size_t)errlen, "%s:%d: more than %d rows", path, lineno, WDR_USER_CURVE_MAX);
        return WDR_E_TOO_LARGE;
    }
    op->knot_ln_l[n] = log(l);
    op->knot_t[n] = t;
    op->n_knots = n + 1;
    return WDR_OK;
}

static int is_blank_or_header(const char *line, int lineno)
{
    while (*line == ' ' || *line == '\t')
        line++;
    if (*line == '\n' || *line == '\r' || *line == 0 || *line == '#')
        return 1;
    return lineno == 1 && (line[0] < '0' || line[0] > '9') && line[0] != '.' && line[0] != '-' && line[0] != '+';
}

int wdr_operator_load_curve(wdr_operator *op, const char *path, char *err, int errlen)
{
    FILE *f = fopen(path, "r");
    if (!f) {
        snprintf(err, (size_t)errlen, "%s: cannot open curve file", path);
        return WDR_E_IO;
    }
    char line[512];
    int lineno = 0, rc = WDR_OK;
    op->id = WDR_OP_USER_CURVE;
    op->n_knots = 0;
    while (rc == WDR_OK && fgets(line, sizeof line, f)) {
        lineno++;
        if (!is_blank_or_header(line, lineno))
            rc = curve_row(op, path, lineno, line, err, errlen);
    }
    fclose(f);
    if (rc == WDR_OK && op->n_knots < 2) {
        snprintf(err, (size_t)errlen, "%s: curve needs at least 2 rows of luminance,display (found %d)", path,
                 op->n_knots);
        rc = WDR_E_INVAL;
    }
    if (rc == WDR_OK && op->knot_t[op->n_knots - 1] <= op->knot_t[0]) {
        snprintf(err, (size_t)errlen, "%s: curve is flat (display %g everywhere)", path, op->knot_t[0]);
        rc = WDR_E_INVAL;
    }
    return rc;
}

/* ---- scene statistics ---- */

int wdr_lum_stats_measure(const float *lum, long n, wdr_lum_stats *out)
{
    /* Guard: values at or below 1e-9 of the maximum are clamped there before the log. */
    double lmax = 0, sum = 0;
    long used = 0;
    for (long i = 0; i < n; i++)
        if (isfinite(lum[i]) && lum[i] > lmax)
            lmax = lum[i];
    if (!(lmax > 0))
        return WDR_E_INVAL;
    double floor_l = lmax * 1e-9, lmin = lmax;
    for (long i = 0; i < n; i++) {
        if (!isfinite(lum[i]))
            continue;
        double l = lum[i] > floor_l ? lum[i] : floor_l;
        sum += log(l);
        lmin = l < lmin ? l : lmin;
        used++;
    }
    out->l_avg = exp(sum / (double)used);
    out->l_max = lmax;
    out->l_min = lmin;
    return used > 0x7fffffff ? 0x7fffffff : (int)used;
}

void wdr_lum_stats_default(double i_min, double i_center, double i_max, double lum_per_amp, double key,
                             wdr_lum_stats *out)
{
    out->l_avg = key * lum_per_amp * i_center;
    out->l_max = lum_per_amp * i_max;
    out->l_min = lum_per_amp * i_min;
}
