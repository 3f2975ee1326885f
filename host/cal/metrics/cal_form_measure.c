/* --form auto on this chip's frames (cal_form_measure.h): one fit, every candidate form's table
 * built from it, each judged against the fit's own model on the same pixels of the same frames,
 * so the noise and the converters the frames carry fall on both alike. */
#include "cal_form_measure.h"
#include "cal_metrics.h"
#include "wdr_cal.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const struct {
    int form, n_coeffs;
} candidates[WDR_FORM_CANDIDATES] = {
    {WDR_FORM_COMPACT, WDR_CAL_COMPACT_COEFFS},
    {WDR_FORM_SHIFTED, WDR_CAL_COMPACT_COEFFS},
    {WDR_FORM_POLY, 5},
    {WDR_FORM_BASIS, 8},
};

/* The average of m captures at amps, numbered first_no onwards, into out. */
static int capture_average(const wdr_cal_source *src, double amps, int m, int first_no, double *acc, float *one,
                           float *out)
{
    long np = (long)src->width * src->height;
    int rc = WDR_OK;
    memset(acc, 0, sizeof(double) * (size_t)np);
    for (int f = 0; !rc && f < m; f++) {
        rc = src->capture(src->ctx, amps, first_no + f, one);
        for (long i = 0; !rc && i < np; i++)
            acc[i] += one[i];
    }
    for (long i = 0; !rc && i < np; i++)
        out[i] = (float)(acc[i] / m);
    return rc;
}

int wdr_form_frames_capture(const wdr_cal_source *src, const double *x, int n, int frames_avg, int first_frame_no,
                            float **frames, float **frames_b)
{
    long np = (long)src->width * src->height;
    int m = frames_avg > 0 ? frames_avg : 1;
    float *a = malloc(sizeof(float) * (size_t)np * (size_t)n), *one = malloc(sizeof(float) * (size_t)np);
    float *b = frames_b ? malloc(sizeof(float) * (size_t)np * (size_t)n) : NULL;
    double *acc = malloc(sizeof(double) * (size_t)np);
    int rc = a && one && acc && (b || !frames_b) ? WDR_OK : WDR_E_NOMEM;
    for (int k = 0; !rc && k < n; k++) { /* both sets at one current before the next: one light each */
        int no = first_frame_no + WDR_FORM_FRAME_STRIDE * k;
        rc = capture_average(src, x[k], m, no, acc, one, a + (long)k * np);
        if (!rc && b)
            rc = capture_average(src, x[k], m, no + WDR_FORM_FRAME_STRIDE / 2, acc, one, b + (long)k * np);
    }
    free(one);
    free(acc);
    if (rc)
        free(a), free(b), a = b = NULL;
    *frames = a;
    if (frames_b)
        *frames_b = b;
    return rc;
}

/* The table's contrast error (%) at every frame. */
static int table_errors(const wdr_cal_result *res, const wdr_cal_view *tab, const uint8_t *mask, const float *frames,
                        const double *x, int n, double *xh, double *pct)
{
    long np = (long)res->width * res->height;
    for (int k = 0; k < n; k++) {
        wdr_contrast c;
        int rc = wdr_fpn_recover(res, tab, WDR_PATH_TABLE, frames + (long)k * np, mask, xh);
        if (rc)
            return rc;
        wdr_contrast_of(xh, np, x[k], res->nominal.x_lo, res->nominal.x_hi, &c);
        pct[k] = c.sd_pct;
    }
    return WDR_OK;
}

/* The model's contrast error at each frame of set a into model_pct and, with set b, the temporal
 * part of it: 100 sd of ln(x_a / x_b) / sqrt 2 over the pixels both resolve (the table sees the
 * same codes, so the same noise). One pass: each frame through the model's inverse once. */
static int model_and_noise(const wdr_cal_result *res, const uint8_t *mask, const wdr_form_frames *f, double *xa,
                           double *model_pct, double *noise_pct)
{
    long np = (long)res->width * res->height;
    double *xb = f->frames_b ? malloc(sizeof(double) * (size_t)np) : NULL;
    int rc = f->frames_b && !xb ? WDR_E_NOMEM : WDR_OK;
    for (int k = 0; !rc && k < f->n; k++) {
        wdr_contrast c;
        rc = wdr_fpn_recover(res, NULL, WDR_PATH_MODEL, f->frames + (long)k * np, mask, xa);
        if (!rc)
            wdr_contrast_of(xa, np, f->x[k], res->nominal.x_lo, res->nominal.x_hi, &c), model_pct[k] = c.sd_pct;
        if (!rc && xb)
            rc = wdr_fpn_recover(res, NULL, WDR_PATH_MODEL, f->frames_b + (long)k * np, mask, xb);
        double s = 0, s2 = 0;
        long used = 0;
        for (long i = 0; !rc && xb && i < np; i++)
            if (xa[i] > 0 && xb[i] > 0 && isfinite(xa[i]) && isfinite(xb[i])) {
                double d = log(xa[i] / xb[i]);
                s += d, s2 += d * d, used++;
            }
        noise_pct[k] = used > 1 ? 100 * sqrt(fmax(0, (s2 - s * s / used) / (used - 1)) / 2) : 0;
    }
    free(xb);
    return rc;
}

/* The fixed-pattern part: sqrt(total^2 - temporal^2). */
static void remove_noise(double *pct, const double *noise_pct, int n)
{
    for (int k = 0; noise_pct && k < n; k++)
        pct[k] = sqrt(fmax(0, pct[k] * pct[k] - noise_pct[k] * noise_pct[k]));
}

/* The form's allowance at x (cal_form_measure.h). */
static double allowed_pct(wdr_form_target t, double model_pct)
{
    return fmax(t.analog_pct, t.floor_ratio * model_pct);
}

/* The trial's figures from the table's error at each frame against its allowance. */
static void judge(wdr_form_trial *tr, const wdr_form_frames *f, const double *table_pct, const double *model_pct,
                  wdr_form_target t)
{
    tr->worst_pct = 0, tr->excess = 0;
    for (int k = 0; k < f->n; k++) {
        double allowed = allowed_pct(t, model_pct[k]), e = table_pct[k] / allowed;
        if (!(table_pct[k] <= tr->worst_pct)) /* a NaN is the worst */
            tr->worst_pct = table_pct[k], tr->worst_at = f->x[k];
        if (!(e <= tr->excess))
            tr->excess = e, tr->excess_at = f->x[k], tr->table_pct = table_pct[k], tr->model_pct = model_pct[k],
            tr->allowed_pct = allowed;
    }
    tr->meets = tr->excess <= 1;
}

/* Build one form's table from res and measure its fixed-pattern error on every frame. */
static int try_form(const wdr_cal_result *res, const uint8_t *mask, const wdr_form_frames *f, const double *model_pct,
                    const double *noise_pct, wdr_form_target t, uint32_t sensor_id, int operator_id, double *xh,
                    wdr_form_trial *tr, wdr_form_table *keep, char *err, int errlen)
{
    wdr_cal_result alt = *res;
    uint8_t *tb;
    size_t tl;
    wdr_cal_view tab;
    double table_pct[WDR_FORM_MAX_CURRENTS] = {0};
    char why[400];
    alt.cfg.form = tr->form, alt.cfg.n_coeffs = tr->n_coeffs;
    if (wdr_cal_build_table(&alt, sensor_id, operator_id, &tb, &tl, why, sizeof why))
        return snprintf(err, (size_t)errlen, "form %d: %s", tr->form, why), WDR_E_INVAL;
    int rc =
        wdr_cal_parse(tb, tl, &tab) ? WDR_E_INVAL : table_errors(res, &tab, mask, f->frames, f->x, f->n, xh, table_pct);
    tr->bytes_px = (double)tl / ((double)res->width * res->height);
    if (rc)
        return free(tb), snprintf(err, (size_t)errlen, "form %d: its table could not be read back", tr->form), rc;
    if (keep) /* the last form tried: the chosen one, or basis-8 when none met (keep_nearest swaps in a nearer) */
        free(keep->table), keep->table = tb, keep->len = tl;
    else
        free(tb);
    remove_noise(table_pct, noise_pct, f->n);
    judge(tr, f, table_pct, model_pct, t);
    return WDR_OK;
}

/* The pixels judged: the unflagged ones, of them one in ceil(pixels / WDR_FORM_SAMPLE_PIXELS)
 * chosen by a hash of the index (no row or column pattern: a column's FPN is not sampled apart).
 * mask[i] set: left out. @return NULL when out of memory */
static uint8_t *sample_mask(const wdr_cal_result *res)
{
    long np = (long)res->width * res->height, every = (np + WDR_FORM_SAMPLE_PIXELS - 1) / WDR_FORM_SAMPLE_PIXELS;
    uint8_t *m = malloc((size_t)np);
    for (long i = 0; m && i < np; i++)
        m[i] = (res->flags && res->flags[i]) || ((uint32_t)i * 2654435761u >> 7) % (uint32_t)every != 0;
    return m;
}

int wdr_form_nearest(const wdr_form_trial *trials, int n_tried)
{
    int best = -1;
    for (int k = 0; k < n_tried; k++) /* smallest first: a tie keeps the smaller; NaN is never below */
        if (!isnan(trials[k].excess) && (best < 0 || trials[k].excess < trials[best].excess))
            best = k;
    return best >= 0 ? best : n_tried - 1;
}

/* None met: *table (the last form's) becomes the nearest form's, built again unless it is the last. */
static int keep_nearest(const wdr_cal_result *res, const wdr_form_trial *trials, int n_tried, uint32_t sensor_id,
                        int operator_id, wdr_form_table *table, char *err, int errlen)
{
    const wdr_form_trial *t = &trials[wdr_form_nearest(trials, n_tried)];
    if (t == &trials[n_tried - 1])
        return 0;
    wdr_cal_result alt = *res;
    uint8_t *tb;
    size_t tl;
    char why[400];
    alt.cfg.form = t->form, alt.cfg.n_coeffs = t->n_coeffs;
    if (wdr_cal_build_table(&alt, sensor_id, operator_id, &tb, &tl, why, sizeof why))
        return snprintf(err, (size_t)errlen, "form %d: %s", t->form, why), 1;
    free(table->table);
    table->table = tb, table->len = tl;
    return 0;
}

int wdr_form_choose_measured(const wdr_cal_result *res, const wdr_form_frames *f, wdr_form_target t, uint32_t sensor_id,
                             int operator_id, wdr_form_trial *trials, int *n_tried, wdr_form_table *table, char *err,
                             int errlen)
{
    double model_pct[WDR_FORM_MAX_CURRENTS] = {0}, noise_pct[WDR_FORM_MAX_CURRENTS] = {0};
    double *xh = malloc(sizeof(double) * (size_t)res->width * (size_t)res->height);
    uint8_t *mask = sample_mask(res);
    int chosen = -1;
    *n_tried = 0;
    if (!xh || !mask || f->n < 1 || f->n > WDR_FORM_MAX_CURRENTS)
        return free(xh), free(mask),
               snprintf(err, (size_t)errlen, xh && mask ? "%d judged currents" : "out of memory", f->n), -2;
    if (model_and_noise(res, mask, f, xh, model_pct, noise_pct))
        chosen = -2, snprintf(err, (size_t)errlen, "the model's inverse failed");
    if (chosen != -2) /* every figure measured */
        remove_noise(model_pct, f->frames_b ? noise_pct : NULL, f->n);
    for (int c = 0; chosen == -1 && c < WDR_FORM_CANDIDATES; c++) {
        wdr_form_trial *tr = &trials[(*n_tried)++];
        memset(tr, 0, sizeof *tr);
        tr->form = candidates[c].form, tr->n_coeffs = candidates[c].n_coeffs;
        if (try_form(res, mask, f, model_pct, f->frames_b ? noise_pct : NULL, t, sensor_id, operator_id, xh, tr, table,
                     err, errlen))
            chosen = -2;
        else if (tr->meets)
            chosen = c;
    }
    free(xh);
    free(mask);
    if (chosen == -1 && table && keep_nearest(res, trials, *n_tried, sensor_id, operator_id, table, err, errlen))
        chosen = -2;
    if (chosen == -2 && table)
        free(table->table), table->table = NULL, table->len = 0;
    return chosen;
}

int wdr_form_choose_on_source(const wdr_cal_result *res, const wdr_cal_source *src, double lo, double hi,
                              const wdr_form_judging *j, wdr_form_target t, uint32_t sensor_id, int operator_id,
                              wdr_form_trial *trials, int *n_tried, wdr_form_table *table, char *err, int errlen)
{
    double x[WDR_FORM_MAX_CURRENTS];
    float *a = NULL, *b = NULL;
    int n = j->currents < WDR_FORM_MAX_CURRENTS ? j->currents : WDR_FORM_MAX_CURRENTS, rc = WDR_OK, chosen = -2;
    *n_tried = 0;
    for (int k = 0; k < n; k++)
        x[k] = lo * pow(hi / lo, (k + WDR_FORM_JUDGING_OFFSET) / n);
    rc = wdr_form_frames_capture(src, x, n, j->frames_avg, j->first_frame_no, &a, j->temporal ? &b : NULL);
    wdr_form_frames f = {a, b, x, n};
    if (rc)
        snprintf(err, (size_t)errlen, "frames over %.3g..%.3g A failed: %s", lo, hi, wdr_strerror(rc));
    else
        chosen = wdr_form_choose_measured(res, &f, t, sensor_id, operator_id, trials, n_tried, table, err, errlen);
    free(a);
    free(b);
    return chosen;
}

