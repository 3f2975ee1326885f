/* Calibration current selection and evaluation against a frame source. */
#include "cal_select.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_SUBSETS 6000
#define MAX_CANDIDATES 40

/* A width*1 array of every k-th pixel: selection judges on a sample, not the whole chip. */
static int sample_grid(const wdr_cal_levels *g, int want, wdr_cal_levels *s)
{
    long np = (long)g->width * g->height, step = np / (want > 0 ? want : 1);
    if (step < 1)
        step = 1;
    long m = (np + step - 1) / step;
    memset(s, 0, sizeof *s);
    s->width = (int)m, s->height = 1, s->n = g->n;
    memcpy(s->amps, g->amps, sizeof g->amps);
    memcpy(s->noise, g->noise, sizeof g->noise); /* the same noise statistics as the full array */
    s->dark_noise = g->dark_noise, s->m_avg = g->m_avg;
    s->frames = malloc(sizeof(float) * (size_t)m * (size_t)g->n);
    s->dark = g->dark ? malloc(sizeof(float) * (size_t)m) : NULL;
    if (!s->frames || (g->dark && !s->dark))
        return WDR_E_NOMEM;
    for (long j = 0; j < m; j++) {
        for (int k = 0; k < g->n; k++)
            s->frames[(long)k * m + j] = g->frames[(long)k * np + j * step];
        if (g->dark)
            s->dark[j] = g->dark[j * step];
    }
    return WDR_OK;
}

/* Neighbouring chosen levels must differ in the array's response by more than the ramp can
 * resolve (one DAC step) plus spacing_sigmas sd of their difference: closer, their order is noise
 * and a healthy pixel's responses there reverse. med: the sample's median per grid level. */
static int spaced_enough(const wdr_cal_levels *s, const wdr_cal_config *cfg, const double *med, const int *idx,
                         int n)
{
    for (int j = 1; j < n; j++) {
        if (idx[j - 1] < 0)
            continue; /* the dark reference is judged by the paper models themselves */
        double a = wdr_cal_level_sd(s, idx[j - 1]), b = wdr_cal_level_sd(s, idx[j]);
        double need = cfg->step_codes + cfg->spacing_sigmas * sqrt(a * a + b * b);
        if (!(fabs(med[idx[j - 1]] - med[idx[j]]) > need))
            return 0;
    }
    return 1;
}

/* The fixed-pattern part of a judged level's contrast error: the probe's own temporal noise is
 * taken out in quadrature, so a noisy probe does not choose by its noise. It enters twice, about
 * equally: in the judged level's M-frame mean and in the pixel's fitted curve there, interpolated
 * between its neighbouring levels' means (each sd over the response slope, in ln x). */
static double fpn_only_pct(const wdr_cal_levels *s, const wdr_cal_result *res, int k, double sd_pct)
{
    double slope = wdr_nominal_log_slope(&res->nominal, s->amps[k]);
    double noise_pct = slope > 0 ? 100 * wdr_cal_level_sd(s, k) / slope : 0;
    double v = sd_pct * sd_pct - 2 * noise_pct * noise_pct;
    return v > 0 ? sqrt(v) : 0;
}

/* Worst sd over the levels in range for one candidate set; INFINITY when it cannot be fitted.
 * *left_out: the sampled pixels its fit flagged, which the worst leaves out. */
static double judge(const wdr_cal_levels *s, const wdr_cal_config *cfg, const double *med, const int *idx, int n,
                    const int *eval, int n_eval, double *worst_at, long *left_out)
{
    wdr_cal_levels lv;
    wdr_cal_result res;
    char err[160];
    double worst = INFINITY;
    if (!spaced_enough(s, cfg, med, idx, n) || wdr_cal_levels_subset(s, idx, n, &lv))
        return INFINITY;
    lv.dark = s->dark;
    if (!wdr_cal_fit_array(&lv, cfg, &res, err, sizeof err) && res.n_bad * 4 < (long)s->width) {
        worst = 0;
        *left_out = res.n_bad;
        for (int e = 0; e < n_eval && worst < INFINITY; e++) {
            wdr_fpn_stats st;
            int k = eval[e], used = 0;
            for (int j = 0; j < n; j++)
                used |= idx[j] == k;
            if (used)
                continue; /* judged where the fit did not look: an interpolating model is exact there */
            wdr_fpn_frame(&res, NULL, WDR_PATH_MODEL, s->frames + (long)k * s->width, s->amps[k], res.flags, NULL,
                          &st);
            double v = st.nonfinite || !st.used ? INFINITY : fpn_only_pct(s, &res, k, st.sd_pct);
            if (v > worst)
                worst = v, *worst_at = s->amps[k];
        }
    }
    wdr_cal_result_free(&res);
    lv.dark = NULL;
    wdr_cal_levels_free(&lv);
    return worst;
}

static void keep_if_better(wdr_cal_choice *best, const wdr_cal_levels *s, const int *idx, int n, double worst,
                           double at, long left_out)
{
    best->tried++;
    if (!(worst < best->worst_pct))
        return;
    best->worst_pct = worst;
    best->worst_at = at;
    best->judged = s->width, best->left_out = left_out;
    best->n = n;
    for (int k = 0; k < n; k++) {
        best->idx[k] = idx[k];
        best->amps[k] = idx[k] < 0 ? 0 : s->amps[idx[k]];
    }
}

static int levels_in_range(const wdr_cal_levels *g, double lo, double hi, int *out)
{
    int m = 0;
    for (int k = 0; k < g->n; k++)
        if (g->amps[k] >= lo * (1 - 1e-9) && g->amps[k] <= hi * (1 + 1e-9))
            out[m++] = k;
    return m;
}

static long binomial(int n, int k)
{
    long r = 1;
    for (int i = 1; i <= k; i++)
        r = r * (n - k + i) / i;
    return r;
}

/* Every k-subset of cand (lexicographic), the dark reference in front when used. */
static void search_subsets(const wdr_cal_levels *s, const wdr_cal_config *cfg, const double *med, const int *cand,
                           int nc, int k, const int *eval, int n_eval, wdr_cal_choice *best)
{
    int pos[WDR_CAL_MAX_LEVELS], idx[WDR_CAL_MAX_LEVELS], ref = cfg->use_dark_ref ? 1 : 0;
    for (int j = 0; j < k; j++)
        pos[j] = j;
    for (;;) {
        idx[0] = -1;
        for (int j = 0; j < k; j++)
            idx[ref + j] = cand[pos[j]];
        double at = 0;
        long left_out = 0;
        double w = judge(s, cfg, med, idx, k + ref, eval, n_eval, &at, &left_out);
        keep_if_better(best, s, idx, k + ref, w, at, left_out);
        int j = k - 1;
        while (j >= 0 && pos[j] == nc - k + j)
            j--;
        if (j < 0)
            return;
        pos[j]++;
        for (int i = j + 1; i < k; i++)
            pos[i] = pos[i - 1] + 1;
    }
}

/* Position k of n in [0, 1]: a power warp, denser at the dark end for gamma > 1 and at the
 * bright end for gamma < 1; gamma 0 means denser at both ends (cosine spacing). */
static double warp_position(int k, int n, double gamma)
{
    double t = (double)k / (n - 1);
    return gamma > 0 ? pow(t, gamma) : 0.5 * (1 - cos(3.141592653589793 * t));
}

/* n log-spaced currents over the candidates, warped, snapped to the grid; duplicates make the
 * set invalid. */
static int warped_set(const wdr_cal_levels *s, const int *cand, int nc, int n, double gamma, int *idx)
{
    double l0 = log(s->amps[cand[0]]), l1 = log(s->amps[cand[nc - 1]]);
    for (int k = 0; k < n; k++) {
        double t = warp_position(k, n, gamma), target = l0 + (l1 - l0) * t;
        int best = cand[0];
        for (int j = 0; j < nc; j++)
            if (fabs(log(s->amps[cand[j]]) - target) < fabs(log(s->amps[best]) - target))
                best = cand[j];
        if (k > 0 && best <= idx[k - 1])
            return 0;
        idx[k] = best;
    }
    return 1;
}

/* Drop levels of a warped set that lie closer to the level kept before them than spacing
 * allows (greedy from the dark end; the brightest level replaces the last one kept when it
 * would be dropped, so the set keeps its span). Returns the new count. */
static int prune_close(const wdr_cal_levels *s, const wdr_cal_config *cfg, const double *med, int *idx, int n)
{
    int m = 1;
    for (int j = 1; j < n; j++) {
        int pair[2] = {idx[m - 1], idx[j]};
        if (spaced_enough(s, cfg, med, pair, 2))
            idx[m++] = idx[j];
        else if (j == n - 1 && m >= 2) {
            int alt[2] = {idx[m - 2], idx[j]};
            if (spaced_enough(s, cfg, med, alt, 2))
                idx[m - 1] = idx[j];
        }
    }
    return m;
}

static void search_warped(const wdr_cal_levels *s, const wdr_cal_config *cfg, const double *med, const int *cand,
                          int nc, int n, const int *eval, int n_eval, wdr_cal_choice *best)
{
    static const double gammas[] = {0, 0.6, 0.7, 0.8, 0.9, 1.0, 1.12, 1.25, 1.4, 1.6};
    int ref = cfg->use_dark_ref ? 1 : 0; /* the dark reference in front (paper models) */
    for (size_t g = 0; g < sizeof gammas / sizeof gammas[0]; g++) {
        int idx[WDR_CAL_MAX_LEVELS];
        idx[0] = -1;
        if (!warped_set(s, cand, nc, n, gammas[g], idx + ref))
            continue;
        int m = prune_close(s, cfg, med, idx, n + ref);
        double at = 0;
        long left_out = 0;
        double w = judge(s, cfg, med, idx, m, eval, n_eval, &at, &left_out);
        keep_if_better(best, s, idx, m, w, at, left_out);
    }
}

static double median_level(const wdr_cal_levels *g, int k, float *scratch);

static int sample_medians(const wdr_cal_levels *s, double *med)
{
    float *scratch = malloc(sizeof(float) * (size_t)s->width * (size_t)s->height);
    if (!scratch)
        return WDR_E_NOMEM;
    for (int k = 0; k < s->n; k++)
        med[k] = median_level(s, k, scratch);
    free(scratch);
    return WDR_OK;
}

/* Thin the candidates (keeping both ends) until the subset count is affordable. */
static int thin_candidates(int *cand, int nc, int k)
{
    while (nc > k + 1 && (nc > MAX_CANDIDATES || binomial(nc, k) > MAX_SUBSETS)) {
        int m = 0;
        for (int j = 0; j < nc; j++)
            if (j % 2 == 0 || j == nc - 1)
                cand[m++] = cand[j];
        nc = m;
    }
    return nc;
}

int wdr_cal_select_currents(const wdr_cal_levels *grid, const wdr_cal_config *cfg, int n_currents, double x_lo,
                            double x_hi, int sample_pixels, wdr_cal_choice *out, char *err, int errlen)
{
    int cand[WDR_CAL_MAX_LEVELS], eval[WDR_CAL_MAX_LEVELS];
    int nc = levels_in_range(grid, x_lo, x_hi, cand), n_eval = levels_in_range(grid, x_lo, x_hi, eval);
    memset(out, 0, sizeof *out);
    out->worst_pct = INFINITY;
    if (nc < n_currents || n_currents < 2 || (cfg->use_dark_ref && !grid->dark)) {
        snprintf(err, (size_t)errlen, "need %d grid levels in %.3g..%.3g A%s, have %d", n_currents, x_lo, x_hi,
                 cfg->use_dark_ref && !grid->dark ? " and a dark frame" : "", nc);
        return WDR_E_INVAL;
    }
    wdr_cal_levels s;
    int rc = sample_grid(grid, sample_pixels, &s);
    double med[WDR_CAL_MAX_LEVELS];
    if (!rc)
        rc = sample_medians(&s, med);
    if (!rc) {
        /* the paper models' exact fits through 3 or 4 levels: every subset; their least-squares
         * fits through more, as the curve models, sets that span the range (a subset search would
         * find sets whose extrapolation clamps, which judging leaves out, and cost binomially) */
        if (n_currents == (cfg->model == WDR_MODEL_SIMPLE3 ? 3 : cfg->model == WDR_MODEL_COMPLEX4 ? 4 : -1))
            search_subsets(&s, cfg, med, cand, thin_candidates(cand, nc, n_currents), n_currents, eval, n_eval, out);
        else
            search_warped(&s, cfg, med, cand, nc, n_currents, eval, n_eval, out);
    }
    wdr_cal_levels_free(&s);
    if (!rc && !isfinite(out->worst_pct)) {
        snprintf(err, (size_t)errlen, "no set of %d currents in %.3g..%.3g A could be fitted", n_currents, x_lo, x_hi);
        rc = WDR_E_NUMERIC;
    }
    return rc;
}

int wdr_cal_levels_from_choice(const wdr_cal_levels *grid, const wdr_cal_choice *c, wdr_cal_levels *out)
{
    int rc = wdr_cal_levels_subset(grid, c->idx, c->n, out);
    if (!rc)
        out->dark = grid->dark;
    return rc;
}

static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

static double median_level(const wdr_cal_levels *g, int k, float *scratch)
{
    long np = (long)g->width * g->height;
    memcpy(scratch, g->frames + (long)k * np, sizeof(float) * (size_t)np);
    qsort(scratch, (size_t)np, sizeof *scratch, cmp_float);
    return scratch[np / 2];
}

int wdr_cal_informative_range(const wdr_cal_levels *grid, double min_slope, double *lo, double *hi)
{
    long np = (long)grid->width * grid->height;
    float *scratch = malloc(sizeof(float) * (size_t)np);
    double med[WDR_CAL_MAX_LEVELS];
    if (!scratch)
        return WDR_E_NOMEM;
    for (int k = 0; k < grid->n; k++)
        med[k] = median_level(grid, k, scratch);
    free(scratch);
    /* a level counts when the segments on both sides are steep enough: a kink into a flat
     * stretch (a burnt-out operator) leaves its last level out */
    int first = -1, last = -1;
    for (int k = 0; k < grid->n; k++) {
        int ok = 1;
        for (int j = k - 1; j <= k; j++)
            if (j >= 0 && j + 1 < grid->n &&
                fabs(med[j + 1] - med[j]) / log(grid->amps[j + 1] / grid->amps[j]) < min_slope)
                ok = 0;
        if (ok && grid->n > 1) {
            if (first < 0)
                first = k;
            last = k;
        }
    }
    if (first >= 0 && last <= first)
        first = -1;
    if (first < 0)
        return WDR_E_NUMERIC;
    *lo = grid->amps[first];
    *hi = grid->amps[last];
    return WDR_OK;
}

int wdr_cal_evaluate(const wdr_cal_result *res, const wdr_cal_view *tab, const wdr_cal_source *src,
                     const double *amps, int n, wdr_fpn_stats *raw, wdr_fpn_stats *model, wdr_fpn_stats *table)
{
    long np = (long)src->width * src->height;
    float *frame = malloc(sizeof(float) * (size_t)np);
    const uint8_t *flags = res->flags;
    if (!frame)
        return WDR_E_NOMEM;
    int rc = WDR_OK;
    for (int k = 0; !rc && k < n; k++) {
        if ((rc = src->capture(src->ctx, amps[k], 1000000 + k, frame)))
            break;
        if (raw)
            wdr_fpn_frame(res, NULL, WDR_PATH_RAW, frame, amps[k], flags, NULL, &raw[k]);
        if (model)
            wdr_fpn_frame(res, NULL, WDR_PATH_MODEL, frame, amps[k], flags, NULL, &model[k]);
        if (table && tab)
            rc = wdr_fpn_frame(res, tab, WDR_PATH_TABLE, frame, amps[k], flags, NULL, &table[k]);
    }
    free(frame);
    return rc;
}
