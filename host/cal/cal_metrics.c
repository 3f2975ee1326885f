/* FPN contrast error, model error, DSNU and PRNU. */
#include "cal_metrics.h"
#include "correct.h"
#include "wdr_err.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static double recovered(const wdr_cal_result *res, int path, long i, double y_raw, double y_table)
{
    int st;
    switch (path) {
    case WDR_PATH_RAW:
        return wdr_nominal_invert(&res->nominal, y_raw);
    case WDR_PATH_MODEL:
        return wdr_cal_recover(res, i, y_raw, &st);
    default:
        return wdr_nominal_invert(&res->nominal, y_table);
    }
}

/* Run the firmware kernel over a whole frame (float path) into out, in raw-code units. */
static int table_frame(const wdr_cal_view *tab, const float *frame, float *out)
{
    for (int r = 0; r < tab->h.height; r++) {
        int rc = wdr_correct_row_f32(tab, r, frame + (long)r * tab->h.width, out + (long)r * tab->h.width);
        if (rc)
            return rc;
    }
    long np = (long)tab->h.width * tab->h.height;
    for (long i = 0; i < np; i++)
        out[i] /= tab->h.out_scale;
    return WDR_OK;
}

static void accumulate(wdr_fpn_stats *s, double e, double *sum, double *sum2)
{
    if (!isfinite(e)) {
        s->nonfinite++;
        return;
    }
    s->used++;
    *sum += e;
    *sum2 += e * e;
    s->max_abs_pct = fmax(s->max_abs_pct, fabs(e));
}

int wdr_fpn_frame(const wdr_cal_result *res, const wdr_cal_view *tab, int path, const float *frame, double x,
                  const uint8_t *flags, double *rel_err, wdr_fpn_stats *out)
{
    long np = (long)res->width * res->height;
    float *corr = NULL;
    memset(out, 0, sizeof *out);
    out->x = x;
    if (!(x > 0) || (path == WDR_PATH_TABLE && (!tab || tab->h.width != res->width || tab->h.height != res->height)))
        return WDR_E_INVAL;
    if (path == WDR_PATH_TABLE) {
        if (!(corr = malloc(sizeof(float) * (size_t)np)))
            return WDR_E_NOMEM;
        int rc = table_frame(tab, frame, corr);
        if (rc) {
            free(corr);
            return rc;
        }
    }
    double sum = 0, sum2 = 0;
    for (long i = 0; i < np; i++) {
        if (rel_err)
            rel_err[i] = NAN;
        if ((flags && flags[i]) || (corr && tab->payload && wdr_cal_row_flags(tab, (int)(i / res->width))[i % res->width])) {
            out->excluded++;
            continue;
        }
        double e = 100 * (recovered(res, path, i, frame[i], corr ? corr[i] : 0) - x) / x;
        accumulate(out, e, &sum, &sum2);
        if (rel_err)
            rel_err[i] = e;
    }
    free(corr);
    if (out->used) {
        out->mean_pct = sum / out->used;
        out->sd_pct = sqrt(fmax(sum2 / out->used - out->mean_pct * out->mean_pct, 0));
    }
    return WDR_OK;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double model_residual(const wdr_cal_result *res, long i, double x, double y)
{
    const double *p = res->params + i * res->n_params;
    if (res->model == WDR_MODEL_SIMPLE3) {
        wdr_simple3 m = {p[0], p[1], p[2], p[3], res->x_scale};
        return fabs(wdr_simple3_eval(&m, x / res->x_scale) - y);
    }
    if (res->model == WDR_MODEL_COMPLEX4) {
        wdr_complex4 m = {p[0], p[1], p[2], p[3], p[4], res->x_scale, 0};
        return fabs(wdr_complex4_eval(&m, x / res->x_scale) - y);
    }
    return fabs(wdr_cal_map(res, i, y) - wdr_nominal_eval(&res->nominal, x));
}

void wdr_model_error(const wdr_cal_result *res, const float *frames, const double *amps, int n, const uint8_t *flags,
                     double *max_codes, double *median_codes)
{
    long np = (long)res->width * res->height, m = 0;
    double *worst = malloc(sizeof(double) * (size_t)np);
    *max_codes = *median_codes = 0;
    if (!worst)
        return;
    for (long i = 0; i < np; i++) {
        if (flags && flags[i])
            continue;
        double w = 0;
        for (int k = 0; k < n; k++)
            w = fmax(w, model_residual(res, i, amps[k], frames[(long)k * np + i]));
        worst[m++] = w;
        *max_codes = fmax(*max_codes, w);
    }
    if (m) {
        qsort(worst, (size_t)m, sizeof *worst, cmp_double);
        *median_codes = worst[m / 2];
    }
    free(worst);
}

void wdr_emva_nonuniformity(const float *dark, const float *lit, long np, const uint8_t *flags, double *dsnu_codes,
                            double *prnu_pct)
{
    double sd = 0, sd2 = 0, ss = 0, ss2 = 0;
    long m = 0;
    for (long i = 0; i < np; i++) {
        if (flags && flags[i])
            continue;
        double s = (double)dark[i] - lit[i];
        sd += dark[i], sd2 += (double)dark[i] * dark[i];
        ss += s, ss2 += s * s;
        m++;
    }
    *dsnu_codes = *prnu_pct = 0;
    if (m < 2)
        return;
    double md = sd / m, ms = ss / m;
    *dsnu_codes = sqrt(fmax(sd2 / m - md * md, 0));
    *prnu_pct = ms != 0 ? 100 * sqrt(fmax(ss2 / m - ms * ms, 0)) / fabs(ms) : 0;
}
