/* Calibration current selection and evaluation against a frame source. */
#include "cal_select.h"
#include "cal_design.h"
#include "wdr_err.h"
#include <limits.h>
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
static int spaced_enough(const wdr_cal_levels *s, const wdr_cal_config *cfg, const double *med, const int *idx, int n)
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

static int is_paper_model(int model)
{
    return model == WDR_MODEL_SIMPLE3 || model == WDR_MODEL_COMPLEX4;
}

/* What one candidate set did on the sample: its worst error, and the pixels the model left unfit. */
typedef struct verdict {
    double worst, at;
    long px, unfit, by_status[WDR_FIT_COUNT];
    long bad; /* flagged by the fit (defects included): what worst leaves out */
} verdict;

/* Pixels the fit left unfit, by reason (the defect tests' flags are the chip's, not the model's). */
static void count_unfit(const wdr_cal_result *res, verdict *v)
{
    long np = (long)res->width * res->height;
    v->px = np, v->unfit = 0;
    memset(v->by_status, 0, sizeof v->by_status);
    for (long i = 0; i < np; i++)
        if (res->status[i]) {
            v->unfit++;
            v->by_status[res->status[i]]++;
        }
}

/* The curve models reject a set that leaves a quarter of the sample bad; the paper models rank
 * every set by what it leaves unfit (better), so their worst is judged on the pixels fitted. */
static int judge_worst(const wdr_cal_levels *s, const wdr_cal_config *cfg, const wdr_cal_result *res, const int *idx,
                       int n, const int *eval, int n_eval, verdict *v)
{
    if (!is_paper_model(cfg->model) && !(res->n_bad * 4 < (long)s->width))
        return 0;
    if (res->n_bad >= (long)s->width)
        return 0;
    v->worst = 0;
    for (int e = 0; e < n_eval && v->worst < INFINITY; e++) {
        wdr_fpn_stats st;
        int k = eval[e], used = 0;
        for (int j = 0; j < n; j++)
            used |= idx[j] == k;
        if (used)
            continue; /* judged where the fit did not look: an interpolating model is exact there */
        wdr_fpn_frame(res, NULL, WDR_PATH_MODEL, s->frames + (long)k * s->width, s->amps[k], res->flags, NULL, &st);
        double x = st.nonfinite || !st.used ? INFINITY : fpn_only_pct(s, res, k, st.sd_pct);
        if (x > v->worst)
            v->worst = x, v->at = s->amps[k];
    }
    return 1;
}

/* Judge one candidate set on the sample: worst sd over the levels in range (INFINITY when it
 * cannot be fitted) and the unfit pixels. */
static void judge(const wdr_cal_levels *s, const wdr_cal_config *cfg, const double *med, const int *idx, int n,
                  const int *eval, int n_eval, verdict *v, char *err, int errlen)
{
    wdr_cal_levels lv;
    wdr_cal_result res;
    memset(v, 0, sizeof *v);
    v->worst = INFINITY;
    v->unfit = LONG_MAX;
    if (!spaced_enough(s, cfg, med, idx, n) || wdr_cal_levels_subset(s, idx, n, &lv))
        return;
    lv.dark = s->dark;
    if (!wdr_cal_fit_array(&lv, cfg, &res, err, errlen)) {
        count_unfit(&res, v);
        v->bad = res.n_bad;
        if (!judge_worst(s, cfg, &res, idx, n, eval, n_eval, v))
            v->worst = INFINITY;
    }
    wdr_cal_result_free(&res);
    lv.dark = NULL;
    wdr_cal_levels_free(&lv);
}

/* Paper models: fewer unfit pixels first, then the lower worst error; curve models: the worst. */
static int ranks_before(const wdr_cal_config *cfg, const verdict *a, const verdict *b)
{
    if (is_paper_model(cfg->model) && a->unfit != b->unfit)
        return a->unfit < b->unfit;
    return a->worst < b->worst;
}

/* The best candidate sets so far, best first (the paper models check them on the whole probe). */
#define N_RANKED 8
typedef struct ranked {
    int count, n[N_RANKED], idx[N_RANKED][WDR_CAL_MAX_LEVELS];
    verdict v[N_RANKED];
    long tried;
    char fit_err[160]; /* the last array fit that failed outright */
} ranked;

static void consider(ranked *r, const wdr_cal_config *cfg, const int *idx, int n, const verdict *v)
{
    r->tried++;
    if (!isfinite(v->worst) && v->unfit == LONG_MAX)
        return; /* not fitted at all */
    int at = r->count;
    while (at > 0 && ranks_before(cfg, v, &r->v[at - 1]))
        at--;
    if (at >= N_RANKED)
        return;
    int last = r->count < N_RANKED ? r->count : N_RANKED - 1;
    for (int j = last; j > at; j--) {
        r->n[j] = r->n[j - 1], r->v[j] = r->v[j - 1];
        memcpy(r->idx[j], r->idx[j - 1], sizeof r->idx[j]);
    }
    r->n[at] = n, r->v[at] = *v;
    memcpy(r->idx[at], idx, sizeof(int) * (size_t)n);
    if (r->count < N_RANKED)
        r->count++;
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
                           int nc, int k, const int *eval, int n_eval, ranked *best)
{
    int pos[WDR_CAL_MAX_LEVELS], idx[WDR_CAL_MAX_LEVELS], ref = cfg->use_dark_ref ? 1 : 0;
    for (int j = 0; j < k; j++)
        pos[j] = j;
    for (;;) {
        idx[0] = -1;
        for (int j = 0; j < k; j++)
            idx[ref + j] = cand[pos[j]];
        verdict v;
        judge(s, cfg, med, idx, k + ref, eval, n_eval, &v, best->fit_err, sizeof best->fit_err);
        consider(best, cfg, idx, k + ref, &v);
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
                          int nc, int n, const int *eval, int n_eval, ranked *best)
{
    static const double gammas[] = {0, 0.6, 0.7, 0.8, 0.9, 1.0, 1.12, 1.25, 1.4, 1.6};
    int ref = cfg->use_dark_ref ? 1 : 0; /* the dark reference in front (paper models) */
    for (size_t g = 0; g < sizeof gammas / sizeof gammas[0]; g++) {
        int idx[WDR_CAL_MAX_LEVELS];
        idx[0] = -1;
        if (!warped_set(s, cand, nc, n, gammas[g], idx + ref))
            continue;
        int m = prune_close(s, cfg, med, idx, n + ref);
        verdict v;
        judge(s, cfg, med, idx, m, eval, n_eval, &v, best->fit_err, sizeof best->fit_err);
        consider(best, cfg, idx, m, &v);
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

static void fill_choice(wdr_cal_choice *out, const wdr_cal_levels *s, const ranked *r, int j)
{
    out->worst_pct = r->v[j].worst, out->worst_at = r->v[j].at, out->n = r->n[j];
    for (int k = 0; k < r->n[j]; k++) {
        out->idx[k] = r->idx[j][k];
        out->amps[k] = r->idx[j][k] < 0 ? 0 : s->amps[r->idx[j][k]];
    }
    out->sampled = r->v[j].px, out->sampled_unfit = r->v[j].unfit;
    out->judged = r->v[j].px, out->left_out = r->v[j].bad;
    memcpy(out->by_status, r->v[j].by_status, sizeof out->by_status);
}

/* Why a status leaves a healthy pixel unfit, in the user's terms. */
static const char *unfit_cause(int status)
{
    switch (status) {
    case WDR_FIT_REVERSED:
        return "the least-squares curve turns up inside the range: the response bends more than the model can";
    case WDR_FIT_DARK:
        return "the dark reading, put on the model, lands at or below zero current: the model cannot bend to this "
               "response's dark end";
    case WDR_FIT_ILL_COND:
        return "the model's linear system is near singular for these levels (reciprocal condition below 1e-13)";
    case WDR_FIT_POLE: return "the fitted curve has its pole inside the calibrated range";
    case WDR_FIT_FLAT: return "neighbouring levels give the same response";
    default: return "the fit fails";
    }
}

/* "simple3 cannot serve this response ...: the best of N sets (A, B, .. A) leaves u of n pixels
 * unfit (ppm): reason count, ..; cause" */
static int refuse(const wdr_cal_config *cfg, const wdr_cal_levels *s, const ranked *r, int j, const verdict *v,
                  const char *where, double x_lo, double x_hi, char *err, int errlen)
{
    char set[160] = "", why[256] = "";
    int at = 0, top = 0;
    for (int k = 0; k < r->n[j] && at < (int)sizeof set; k++)
        at += snprintf(set + at, sizeof set - (size_t)at, "%s%.3g", k ? " " : "",
                       r->idx[j][k] < 0 ? 0 : s->amps[r->idx[j][k]]);
    at = 0;
    for (int st = 1; st < WDR_FIT_COUNT; st++)
        if (v->by_status[st]) {
            if (at < (int)sizeof why)
                at += snprintf(why + at, sizeof why - (size_t)at, "%s%s %ld", at ? ", " : "", wdr_fit_status_name(st),
                               v->by_status[st]);
            if (v->by_status[st] > v->by_status[top])
                top = st;
        }
    snprintf(err, (size_t)errlen,
             "%s cannot serve this response over %.3g..%.3g A: the best of %ld sets of %d currents (%s A, 0 the dark "
             "reference) leaves %ld of %ld %s pixels unfit (%.0f ppm, limit %.0f): %s; %s",
             cfg->model == WDR_MODEL_SIMPLE3 ? "simple3" : "complex4", x_lo, x_hi, r->tried, r->n[j] - 1, set, v->unfit,
             v->px, where, 1e6 * (double)v->unfit / (double)(v->px > 0 ? v->px : 1), WDR_CAL_SELECT_MAX_UNFIT_PPM, why,
             unfit_cause(top));
    return WDR_E_NUMERIC;
}

/* The paper models: the ranked sets that left no sampled pixel unfit are fitted on the whole probe,
 * best first; the first within the limit is the choice, else the refusal names the closest. */
static int choose_paper_set(const wdr_cal_levels *grid, const wdr_cal_levels *s, const wdr_cal_config *cfg,
                            const ranked *r, double x_lo, double x_hi, wdr_cal_choice *out, char *err, int errlen)
{
    if (r->v[0].unfit > 0)
        return refuse(cfg, s, r, 0, &r->v[0], "sampled", x_lo, x_hi, err, errlen);
    long np = (long)grid->width * grid->height, limit = (long)floor(WDR_CAL_SELECT_MAX_UNFIT_PPM * (double)np / 1e6);
    verdict closest = {.unfit = LONG_MAX};
    int closest_j = 0;
    for (int j = 0; j < r->count && r->v[j].unfit == 0; j++) {
        wdr_cal_levels lv;
        wdr_cal_result res;
        verdict pv = {0};
        if (wdr_cal_levels_subset(grid, r->idx[j], r->n[j], &lv))
            return WDR_E_NOMEM;
        lv.dark = grid->dark;
        int rc = wdr_cal_fit_array(&lv, cfg, &res, err, errlen);
        if (!rc)
            count_unfit(&res, &pv);
        wdr_cal_result_free(&res);
        lv.dark = NULL;
        wdr_cal_levels_free(&lv);
        if (rc)
            continue;
        if (pv.unfit < closest.unfit)
            closest = pv, closest_j = j;
        if (pv.unfit <= limit)
            break;
    }
    if (closest.unfit == LONG_MAX) {
        snprintf(err, (size_t)errlen, "no set of %d currents in %.3g..%.3g A could be fitted on the whole probe",
                 r->n[0] - 1, x_lo, x_hi);
        return WDR_E_NUMERIC;
    }
    if (closest.unfit > limit)
        return refuse(cfg, s, r, closest_j, &closest, "probed", x_lo, x_hi, err, errlen);
    fill_choice(out, s, r, closest_j);
    out->probe_px = closest.px, out->probe_unfit = closest.unfit;
    memcpy(out->by_status, closest.by_status, sizeof out->by_status);
    return WDR_OK;
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
    ranked *best = calloc(1, sizeof *best);
    int rc = best ? sample_grid(grid, sample_pixels, &s) : WDR_E_NOMEM;
    double med[WDR_CAL_MAX_LEVELS];
    if (!rc)
        rc = sample_medians(&s, med);
    if (!rc) {
        /* the paper models' exact fits through 3 or 4 levels: every subset; their least-squares
         * fits through more, as the curve models, sets that span the range (a subset search would
         * find sets whose extrapolation clamps, which judging leaves out, and cost binomially) */
        if (n_currents == (cfg->model == WDR_MODEL_SIMPLE3 ? 3 : cfg->model == WDR_MODEL_COMPLEX4 ? 4 : -1))
            search_subsets(&s, cfg, med, cand, thin_candidates(cand, nc, n_currents), n_currents, eval, n_eval, best);
        else
            search_warped(&s, cfg, med, cand, nc, n_currents, eval, n_eval, best);
        if (best->count == 0 || (!is_paper_model(cfg->model) && !isfinite(best->v[0].worst))) {
            snprintf(err, (size_t)errlen, "no set of %d currents in %.3g..%.3g A could be fitted%s%s", n_currents, x_lo,
                     x_hi, best->fit_err[0] ? ": " : "", best->fit_err);
            rc = WDR_E_NUMERIC;
        } else if (is_paper_model(cfg->model))
            rc = choose_paper_set(grid, &s, cfg, best, x_lo, x_hi, out, err, errlen);
        else
            fill_choice(out, &s, best, 0);
        out->tried = best->tried;
    }
    if (best)
        wdr_cal_levels_free(&s);
    free(best);
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

int wdr_cal_evaluate(const wdr_cal_result *res, const wdr_cal_view *tab, const wdr_cal_source *src, const double *amps,
                     int n, wdr_fpn_stats *raw, wdr_fpn_stats *model, wdr_fpn_stats *table)
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

/* ---- can the model serve the design at all ---- */

/* The design's codes (unrounded) on the board's grid, 6 levels per decade, or at the given levels;
 * the design's dark reading as the dark frame: a one-pixel probe with no noise measured. */
static int design_probe(const wdr_cal_design *d, const double *amps, int n_amps, wdr_cal_levels *g)
{
    memset(g, 0, sizeof *g);
    g->width = g->height = 1;
    if (n_amps > 0) {
        g->n = n_amps < WDR_CAL_MAX_LEVELS ? n_amps : WDR_CAL_MAX_LEVELS;
        memcpy(g->amps, amps, sizeof(double) * (size_t)g->n);
    } else {
        double lo = d->board.i_min_a, hi = d->board.i_max_a;
        g->n = (int)lround(log10(hi / lo) * 6) + 1;
        g->n = g->n < WDR_CAL_MAX_LEVELS ? g->n : WDR_CAL_MAX_LEVELS;
        for (int k = 0; k < g->n; k++)
            g->amps[k] = lo * pow(10, k / 6.0);
    }
    g->frames = malloc(sizeof(float) * (size_t)g->n);
    g->dark = malloc(sizeof(float));
    if (!g->frames || !g->dark)
        return WDR_E_NOMEM;
    for (int k = 0; k < g->n; k++)
        g->frames[k] = (float)wdr_cal_design_code(d, g->amps[k]);
    g->dark[0] = (float)wdr_cal_design_code(d, 0);
    return WDR_OK;
}

/* The user's levels (and the dark reference) through the design's pixel. */
static int design_fit_given(const wdr_cal_levels *g, const wdr_cal_config *cfg, char *err, int errlen)
{
    int idx[WDR_CAL_MAX_LEVELS + 1];
    wdr_cal_levels lv;
    wdr_cal_result res;
    char e[256];
    idx[0] = -1;
    for (int k = 0; k < g->n && k < WDR_CAL_MAX_LEVELS - 1; k++)
        idx[k + 1] = k;
    int n = g->n + 1 < WDR_CAL_MAX_LEVELS ? g->n + 1 : WDR_CAL_MAX_LEVELS;
    if (wdr_cal_levels_subset(g, idx, n, &lv))
        return WDR_E_NOMEM;
    lv.dark = g->dark;
    int rc = wdr_cal_fit_array(&lv, cfg, &res, e, sizeof e);
    if (!rc && res.status[0]) {
        snprintf(e, sizeof e, "the model leaves it unfit through these levels: %s (%s)",
                 wdr_fit_status_name(res.status[0]), unfit_cause(res.status[0]));
        rc = WDR_E_NUMERIC;
    }
    if (rc && rc != WDR_E_NOMEM)
        snprintf(err, (size_t)errlen, "known from the design (the board's mismatch-free pixel under this operator): %s",
                 e);
    wdr_cal_result_free(&res);
    lv.dark = NULL;
    wdr_cal_levels_free(&lv);
    return rc ? WDR_E_NUMERIC : WDR_OK;
}

int wdr_cal_design_check(const wdr_cal_design *d, const wdr_cal_config *cfg, int n_currents, const double *amps,
                         int n_amps, double min_slope, char *err, int errlen)
{
    if (!d || !is_paper_model(cfg->model))
        return WDR_OK;
    wdr_cal_levels g;
    int rc = design_probe(d, amps, n_amps, &g);
    char e[768];
    if (!rc && n_amps > 0)
        rc = design_fit_given(&g, cfg, err, errlen);
    else if (!rc) {
        double lo, hi;
        wdr_cal_config c = *cfg;
        wdr_cal_choice ch;
        if (wdr_cal_informative_range(&g, min_slope, &lo, &hi)) {
            snprintf(err, (size_t)errlen, "known from the design: the response is flat everywhere");
            rc = WDR_E_NUMERIC;
        } else {
            c.range_lo = lo, c.range_hi = hi;
            rc = wdr_cal_select_currents(&g, &c, n_currents, lo, hi, 1, &ch, e, sizeof e);
            if (rc && rc != WDR_E_NOMEM) {
                snprintf(err, (size_t)errlen,
                         "known from the design (the board's mismatch-free pixel under this operator, before any "
                         "frame): %s",
                         e);
                rc = WDR_E_NUMERIC;
            }
        }
    }
    wdr_cal_levels_free(&g);
    return rc;
}
