/* Figures of merit (see cal_metrics.h): recovered currents, contrast error as the spread of
 * ln(x_hat / x), total error, display-space error, the quantisation floor; model error, DSNU, PRNU. */
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
    case WDR_PATH_RAW: return wdr_nominal_invert(&res->nominal, y_raw);
    case WDR_PATH_MODEL: return wdr_cal_recover(res, i, y_raw, &st);
    default: return wdr_nominal_invert(&res->nominal, y_table);
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

/* The table path's corrected frame (*corr, to be freed), or NULL on the model path: both frame
 * measures read a frame through the same checks. */
static int corrected_frame(const wdr_cal_result *res, const wdr_cal_view *tab, int path, const float *frame,
                           float **corr)
{
    *corr = NULL;
    if (path != WDR_PATH_TABLE)
        return WDR_OK;
    if (!tab || tab->h.width != res->width || tab->h.height != res->height)
        return WDR_E_INVAL;
    if (!(*corr = malloc(sizeof(float) * (size_t)res->width * (size_t)res->height)))
        return WDR_E_NOMEM;
    int rc = table_frame(tab, frame, *corr);
    if (rc) {
        free(*corr);
        *corr = NULL;
    }
    return rc;
}

/* A pixel flagged by the calibration, or (table path) by the table itself, is left out. */
static int left_out_pixel(const wdr_cal_result *res, const wdr_cal_view *tab, const float *corr, const uint8_t *flags,
                          long i)
{
    if (flags && flags[i])
        return 1;
    return corr && tab->payload &&
           wdr_cal_pixel_flags(tab->h.form, wdr_cal_row_flags(tab, (int)(i / res->width))[i % res->width]);
}

/* ---- x_hat ---- */

int wdr_fpn_recover(const wdr_cal_result *res, const wdr_cal_view *tab, int path, const float *frame,
                    const uint8_t *flags, double *x_hat)
{
    long np = (long)res->width * res->height;
    float *corr;
    int rc = corrected_frame(res, tab, path, frame, &corr);
    if (rc)
        return rc;
    for (long i = 0; i < np; i++)
        x_hat[i] =
            left_out_pixel(res, tab, corr, flags, i) ? NAN : recovered(res, path, i, frame[i], corr ? corr[i] : 0);
    free(corr);
    return WDR_OK;
}

/* ---- contrast error ---- */

#define UNRESOLVED_DECADES 1.0 /* beyond a decade past the calibrated range an inverse is a clamp */

void wdr_contrast_of(const double *x_hat, long n, double x, double x_lo, double x_hi, wdr_contrast *out)
{
    double sum = 0, sum2 = 0, lim_lo = x_lo * pow(10, -UNRESOLVED_DECADES), lim_hi = x_hi * pow(10, UNRESOLVED_DECADES);
    memset(out, 0, sizeof *out);
    out->x = x;
    for (long i = 0; i < n; i++) {
        double v = x_hat[i];
        if (isnan(v)) {
            out->excluded++;
            continue;
        }
        if (!isfinite(v) || !(v >= lim_lo && v <= lim_hi)) {
            out->unresolved++;
            continue;
        }
        double e = 100 * log(v / x);
        out->used++;
        out->beyond += v < x_lo || v > x_hi;
        sum += e, sum2 += e * e;
        out->max_abs_pct = fmax(out->max_abs_pct, fabs(e));
    }
    if (out->used) {
        out->mean_pct = sum / out->used;
        out->sd_pct = sqrt(fmax(sum2 / out->used - out->mean_pct * out->mean_pct, 0));
    }
    long seen = out->used + out->unresolved;
    out->beyond_frac = seen ? (double)(out->beyond + out->unresolved) / seen : 0;
}

/* ---- total error ---- */

/* Temporal spread of one frame: half the variance of ln(x_a / x_b) over pixels resolved in both. */
static double temporal_pct(const double *a, const double *b, long n, double lim_lo, double lim_hi)
{
    double sum = 0, sum2 = 0;
    long m = 0;
    for (long i = 0; i < n; i++) {
        if (!(a[i] >= lim_lo && a[i] <= lim_hi && b[i] >= lim_lo && b[i] <= lim_hi))
            continue;
        double d = 100 * log(a[i] / b[i]);
        sum += d, sum2 += d * d, m++;
    }
    if (m < 2)
        return 0;
    double mean = sum / m;
    return sqrt(fmax(sum2 / m - mean * mean, 0) / 2);
}

void wdr_total_error_of(const double *x_hat_a, const double *x_hat_b, const double *x_hat_m, long n, int frames,
                        double x, double x_lo, double x_hi, wdr_total_error *out)
{
    wdr_contrast ca, cm;
    memset(out, 0, sizeof *out);
    out->x = x;
    out->frames = frames;
    wdr_contrast_of(x_hat_a, n, x, x_lo, x_hi, &ca);
    wdr_contrast_of(x_hat_m, n, x, x_lo, x_hi, &cm);
    out->total_1_pct = ca.sd_pct;
    out->total_m_pct = cm.sd_pct;
    out->left_out = ca.excluded + ca.unresolved;
    out->temporal_pct =
        temporal_pct(x_hat_a, x_hat_b, n, x_lo * pow(10, -UNRESOLVED_DECADES), x_hi * pow(10, UNRESOLVED_DECADES));
    out->fpn_pct = sqrt(fmax(ca.sd_pct * ca.sd_pct - out->temporal_pct * out->temporal_pct, 0));
}

/* ---- display-space error ---- */

int wdr_display_map_init(wdr_display_map *d, const wdr_board *b, const char *op_name, char *err, int errlen)
{
    wdr_lum_stats st;
    memset(d, 0, sizeof *d);
    wdr_lum_stats_default(b->i_min_a, b->i_center_a, b->i_max_a, b->lum_per_amp, 0.18, &st);
    d->lum_per_amp = b->lum_per_amp;
    d->gamma = 2.2;
    return wdr_operator_init(&d->op, op_name, &st, err, errlen);
}

double wdr_display_level(const wdr_display_map *d, double x)
{
    double t = wdr_operator_eval(&d->op, d->lum_per_amp * fmax(x, 0));
    t = t > 0 ? (t < 1 ? t : 1) : 0;
    return 255.0 * pow(t, 1.0 / d->gamma);
}

void wdr_display_error_of(const double *x_hat, long n, double x, const wdr_display_map *d, wdr_display_error *out)
{
    double want = wdr_display_level(d, x), sum = 0, sum_abs = 0, sum2 = 0;
    long over = 0;
    memset(out, 0, sizeof *out);
    out->x_lo = out->x_hi = x;
    for (long i = 0; i < n; i++) {
        if (isnan(x_hat[i]))
            continue;
        double e = wdr_display_level(d, x_hat[i]) - want; /* an infinite x_hat shows as white: finite */
        sum += e, sum_abs += fabs(e), sum2 += e * e;
        over += fabs(e) > 1;
        out->used++;
    }
    if (out->used) {
        out->mean_levels = sum / out->used;
        out->mean_abs_levels = sum_abs / out->used;
        out->rms_levels = sqrt(sum2 / out->used);
        out->frac_over_1 = (double)over / out->used;
    }
}

static void pool_display(wdr_display_error *acc, const wdr_display_error *e)
{
    double w0 = (double)acc->used, w1 = (double)e->used, w = w0 + w1;
    if (w1 == 0)
        return;
    acc->mean_levels = (acc->mean_levels * w0 + e->mean_levels * w1) / w;
    acc->mean_abs_levels = (acc->mean_abs_levels * w0 + e->mean_abs_levels * w1) / w;
    acc->rms_levels = sqrt((acc->rms_levels * acc->rms_levels * w0 + e->rms_levels * e->rms_levels * w1) / w);
    acc->frac_over_1 = (acc->frac_over_1 * w0 + e->frac_over_1 * w1) / w;
    acc->used += e->used;
    acc->x_hi = fmax(acc->x_hi, e->x_hi);
}

int wdr_display_by_decade(const wdr_display_error *e, int n, wdr_display_error *out, int max_out)
{
    int m = 0;
    double cur = NAN;
    for (int k = 0; k < n; k++) {
        double dec = floor(log10(e[k].x_lo) + 1e-9);
        if (dec != cur) {
            if (m == max_out)
                break;
            cur = dec;
            out[m] = e[k];
            out[m].x_lo = pow(10, dec), out[m].x_hi = pow(10, dec + 1);
            m++;
            continue;
        }
        double keep_hi = out[m - 1].x_hi;
        pool_display(&out[m - 1], &e[k]);
        out[m - 1].x_hi = keep_hi;
    }
    return m;
}

int wdr_nominal_response_table(const wdr_nominal *nom, int per_decade, double *ln_x, double *code, int max)
{
    double l0 = log(nom->x_lo) - 0.5 * log(10), l1 = log(nom->x_hi) + 0.5 * log(10);
    int n = (int)ceil((l1 - l0) / log(10) * per_decade) + 1;
    if (n > max || n < 2)
        return 0;
    for (int k = 0; k < n; k++) {
        ln_x[k] = l0 + (l1 - l0) * k / (n - 1);
        code[k] = wdr_nominal_eval(nom, exp(ln_x[k]));
        if (!isfinite(code[k]) || (k > 0 && !(code[k] < code[k - 1])))
            return 0;
    }
    return n;
}

/* ---- quantisation floor ---- */

double wdr_quant_floor_pct(double log_slope_codes, double dac_step_codes)
{
    double q = sqrt(2 * (1 + dac_step_codes * dac_step_codes) / 12);
    return 100 * q / fmax(fabs(log_slope_codes), 1e-12);
}

/* ---- everything at one current ---- */

typedef struct eval_buffers {
    float *one, *avg;
    double *acc, *xa, *xb, *xm;
} eval_buffers;

static void free_buffers(eval_buffers *b)
{
    free(b->one), free(b->avg), free(b->acc), free(b->xa), free(b->xb), free(b->xm);
}

static int alloc_buffers(eval_buffers *b, long np)
{
    size_t f = sizeof(float) * (size_t)np, d = sizeof(double) * (size_t)np;
    *b = (eval_buffers){malloc(f), malloc(f), malloc(d), malloc(d), malloc(d), malloc(d)};
    if (b->one && b->avg && b->acc && b->xa && b->xb && b->xm)
        return WDR_OK;
    free_buffers(b);
    return WDR_E_NOMEM;
}

/* Mean of m frames at x into b->avg; the first frame also stays in b->one. */
static int capture_average(const wdr_cal_source *src, double x, int m, int frame_no, eval_buffers *b, float *first)
{
    long np = (long)src->width * src->height;
    memset(b->acc, 0, sizeof(double) * (size_t)np);
    for (int f = 0; f < m; f++) {
        int rc = src->capture(src->ctx, x, frame_no + f, b->one);
        if (rc)
            return rc;
        for (long i = 0; i < np; i++)
            b->acc[i] += b->one[i];
        if (f == 0 && first)
            memcpy(first, b->one, sizeof(float) * (size_t)np);
    }
    for (long i = 0; i < np; i++)
        b->avg[i] = (float)(b->acc[i] / m);
    return WDR_OK;
}

static double floor_at(const wdr_cal_result *res, const wdr_eval_opts *o, double x)
{
    if (!o->quantised)
        return 0;
    if (o->design)
        return wdr_quant_floor_pct(wdr_cal_design_log_slope(o->design, x), wdr_cal_design_dac_step_codes(o->design, x));
    return wdr_quant_floor_pct(wdr_nominal_log_slope(&res->nominal, x), 1.0);
}

/* Total error from two single frames (b->one holds frame a on entry) and the average's x_hat. */
static int measure_total(const wdr_cal_result *res, const wdr_cal_view *tab, const wdr_cal_source *src, double x,
                         const wdr_eval_opts *o, eval_buffers *b, wdr_eval_point *out)
{
    const double lo = res->nominal.x_lo, hi = res->nominal.x_hi;
    int m = o->frames > 0 ? o->frames : 1, rc = wdr_fpn_recover(res, tab, WDR_PATH_TABLE, b->one, res->flags, b->xa);
    if (!rc)
        rc = src->capture(src->ctx, x, o->first_frame_no + m, b->one);
    if (!rc)
        rc = wdr_fpn_recover(res, tab, WDR_PATH_TABLE, b->one, res->flags, b->xb);
    if (!rc)
        wdr_total_error_of(b->xa, b->xb, b->xm, (long)src->width * src->height, m, x, lo, hi, &out->total);
    return rc;
}

int wdr_eval_point_measure(const wdr_cal_result *res, const wdr_cal_view *tab, const wdr_cal_source *src, double x,
                           const wdr_eval_opts *o, wdr_eval_point *out)
{
    long np = (long)src->width * src->height;
    const double lo = res->nominal.x_lo, hi = res->nominal.x_hi;
    eval_buffers b;
    float *first = NULL;
    memset(out, 0, sizeof *out);
    out->x = x;
    out->floor_pct = floor_at(res, o, x);
    if (alloc_buffers(&b, np) || (o->temporal && !(first = malloc(sizeof(float) * (size_t)np)))) {
        free_buffers(&b);
        return WDR_E_NOMEM;
    }
    int m = o->frames > 0 ? o->frames : 1, rc = capture_average(src, x, m, o->first_frame_no, &b, first);
    if (!rc && !(rc = wdr_fpn_recover(res, NULL, WDR_PATH_RAW, b.avg, res->flags, b.xm))) {
        wdr_contrast_of(b.xm, np, x, lo, hi, &out->before);
        if (o->display)
            wdr_display_error_of(b.xm, np, x, o->display, &out->display_before);
        rc = wdr_fpn_recover(res, NULL, WDR_PATH_MODEL, b.avg, res->flags, b.xm);
        if (!rc)
            wdr_contrast_of(b.xm, np, x, lo, hi, &out->model);
    }
    if (!rc && tab && !(rc = wdr_fpn_recover(res, tab, WDR_PATH_TABLE, b.avg, res->flags, b.xm))) {
        wdr_contrast_of(b.xm, np, x, lo, hi, &out->table);
        if (o->display)
            wdr_display_error_of(b.xm, np, x, o->display, &out->display);
        if (o->temporal) {
            memcpy(b.one, first, sizeof(float) * (size_t)np);
            rc = measure_total(res, tab, src, x, o, &b, out);
        } else { /* no temporal noise: every frame is the same, all of it is FPN */
            out->total = (wdr_total_error){.x = x,
                                           .fpn_pct = out->table.sd_pct,
                                           .total_1_pct = out->table.sd_pct,
                                           .frames = m,
                                           .total_m_pct = out->table.sd_pct,
                                           .left_out = out->table.excluded + out->table.unresolved};
        }
    }
    free(first);
    free_buffers(&b);
    return rc;
}

/* ---- the older per-frame summary ---- */

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
    float *corr;
    memset(out, 0, sizeof *out);
    out->x = x;
    if (!(x > 0))
        return WDR_E_INVAL;
    int rc = corrected_frame(res, tab, path, frame, &corr);
    if (rc)
        return rc;
    double sum = 0, sum2 = 0;
    for (long i = 0; i < np; i++) {
        if (rel_err)
            rel_err[i] = NAN;
        if (left_out_pixel(res, tab, corr, flags, i)) {
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
