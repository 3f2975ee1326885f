#include "ramp.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- the ideal pixel ---- */

void wdr_ideal_pixel_init(const wdr_board *b, wdr_ideal_pixel *px)
{
    wdr_pixel_nominal(b, &px->dev);
    px->v_n0 = wdr_pixel_reset_level(&px->dev);
    px->q_n0 = wdr_pixel_charge(&px->dev, px->v_n0);
    px->v_dark = wdr_pixel_dark_level(&px->dev, px->v_n0) - b->dark_offset_v;
    px->swing = b->swing_v;
    px->lum_per_amp = b->lum_per_amp;
}

double wdr_ideal_target(const wdr_ideal_pixel *px, const wdr_operator *op, double i)
{
    return px->v_dark - px->swing * wdr_operator_eval(op, px->lum_per_amp * i);
}

/* Charge the photocurrent must remove before M2 turns off with G at v_g. */
static double charge_needed(const wdr_ideal_pixel *px, double v_g)
{
    return px->q_n0 - wdr_pixel_charge(&px->dev, wdr_pixel_turnoff_node(&px->dev, v_g));
}

double wdr_ideal_cross_time(const wdr_ideal_pixel *px, double i, double v_g)
{
    double q = charge_needed(px, v_g);
    return q > 0 ? q / i : 0.0;
}

/* G level that M2 lets through when the node sits at v_n and the drain is higher:
 * M2 then acts as a follower, G + V_T2(G) = v_n. */
static double follower_level(const wdr_ideal_pixel *px, double v_n)
{
    return wdr_pixel_dark_level(&px->dev, v_n);
}

/* ---- building V_ref(t) ---- */

static int ramp_alloc(wdr_ramp *r, int n)
{
    memset(r, 0, sizeof *r);
    r->n = n;
    r->t = calloc((size_t)n, sizeof *r->t);
    r->v = calloc((size_t)n, sizeof *r->v);
    r->ln_i = calloc((size_t)n, sizeof *r->ln_i);
    if (!r->t || !r->v || !r->ln_i) {
        wdr_ramp_free(r);
        return WDR_E_NOMEM;
    }
    return WDR_OK;
}

void wdr_ramp_free(wdr_ramp *r)
{
    free(r->t);
    free(r->v);
    free(r->ln_i);
    r->t = r->v = r->ln_i = NULL;
    r->n = 0;
}

/* Samples run from the brightest current (earliest crossing) to the dimmest. */
static int sample_targets(const wdr_ideal_pixel *px, const wdr_operator *op, double i_min, double i_max, wdr_ramp *r,
                          char *err, int errlen)
{
    double a = log(i_max), b = log(i_min);
    for (int j = 0; j < r->n; j++) {
        double ln_i = a + (b - a) * j / (r->n - 1);
        double i = exp(ln_i);
        r->ln_i[j] = ln_i;
        r->v[j] = wdr_ideal_target(px, op, i);
        r->t[j] = wdr_ideal_cross_time(px, i, r->v[j]);
        if (!isfinite(r->v[j]) || !isfinite(r->t[j])) {
            snprintf(err, (size_t)errlen, "non-finite ramp point at I = %g A (V = %g, t = %g)", i, r->v[j], r->t[j]);
            return WDR_E_NUMERIC;
        }
    }
    return WDR_OK;
}

enum { BAD_TIME = 1, BAD_RESPONSE = 2 };

/* Realisable: t*(I) does not rise with I, and g(I) does not rise with I (T monotone).
 * A flat t* is a vertical step of the ramp, which M2 realises as a follower. */
static int violates(const wdr_ramp *r, int j)
{
    double tol_t = 1e-9 * r->t[j - 1], tol_v = 1e-12;
    return (r->t[j] < r->t[j - 1] - tol_t ? BAD_TIME : 0) | (r->v[j] < r->v[j - 1] - tol_v ? BAD_RESPONSE : 0);
}

/* Returns the union of the reasons found; the range covers every violating sample. */
static int find_violations(wdr_ramp *r)
{
    int count = 0, why = 0;
    r->bad_i_lo = r->bad_i_hi = 0;
    for (int j = 1; j < r->n; j++) {
        int v = violates(r, j);
        if (!v)
            continue;
        why |= v;
        double lo = exp(r->ln_i[j]), hi = exp(r->ln_i[j - 1]);
        r->bad_i_lo = count ? fmin(r->bad_i_lo, lo) : lo;
        r->bad_i_hi = count ? fmax(r->bad_i_hi, hi) : hi;
        count++;
    }
    return why;
}

/* Smallest change that makes the ramp rise: running maxima of t and V. */
static void repair_monotone(wdr_ramp *r)
{
    for (int j = 1; j < r->n; j++) {
        r->t[j] = fmax(r->t[j], r->t[j - 1]);
        r->v[j] = fmax(r->v[j], r->v[j - 1]);
    }
}

/* Held G of an ideal pixel on a continuous, sampled ramp: first segment where the charge the
 * current removed reaches what M2 needs, then bisection along that segment. */
static double continuous_response(const wdr_ideal_pixel *px, const wdr_ramp *r, double i)
{
    int j = 0;
    while (j < r->n && i * r->t[j] < charge_needed(px, r->v[j]))
        j++;
    if (j == r->n)
        return r->v[r->n - 1];
    if (j == 0)
        return r->v[0];
    double lo = 0, hi = 1;
    for (int k = 0; k < 50; k++) {
        double s = 0.5 * (lo + hi);
        double t = r->t[j - 1] + s * (r->t[j] - r->t[j - 1]), v = r->v[j - 1] + s * (r->v[j] - r->v[j - 1]);
        if (i * t < charge_needed(px, v))
            lo = s;
        else
            hi = s;
    }
    return r->v[j - 1] + hi * (r->v[j] - r->v[j - 1]);
}

static double repair_deviation(const wdr_ideal_pixel *px, const wdr_operator *op, const wdr_ramp *r)
{
    double worst = 0;
    for (int j = 0; j < r->n; j += 1 + r->n / 2048) {
        double i = exp(r->ln_i[j]);
        worst = fmax(worst, fabs(continuous_response(px, r, i) - wdr_ideal_target(px, op, i)));
    }
    return worst;
}

int wdr_ramp_build(const wdr_ideal_pixel *px, const wdr_operator *op, double i_min, double i_max, int n_samples,
                   int policy, wdr_ramp *out, char *err, int errlen)
{
    if (!(i_min > 0 && i_max > i_min && n_samples >= 2 && isfinite(i_max))) {
        snprintf(err, (size_t)errlen, "bad photocurrent range %g..%g A or sample count %d", i_min, i_max, n_samples);
        return WDR_E_INVAL;
    }
    int rc = ramp_alloc(out, n_samples);
    if (!rc)
        rc = sample_targets(px, op, i_min, i_max, out, err, errlen);
    int why = rc ? 0 : find_violations(out);
    if (why) {
        if (policy == WDR_RAMP_FAIL) {
            snprintf(err, (size_t)errlen, "operator %s is not realisable for photocurrents %.3g..%.3g A: %s%s%s; "
                     "change its parameters or use --repair", wdr_operator_info_by_id(op->id)->name, out->bad_i_lo,
                     out->bad_i_hi, why & BAD_TIME ? "the crossing time t*(I) rises with I there" : "",
                     why == (BAD_TIME | BAD_RESPONSE) ? " and " : "",
                     why & BAD_RESPONSE ? "the operator's curve falls as light rises there" : "");
            rc = WDR_E_UNREALISABLE;
        } else {
            repair_monotone(out);
            out->repaired = 1;
            out->repair_max_dev_v = repair_deviation(px, op, out);
        }
    }
    if (rc) {
        wdr_ramp_free(out);
        return rc;
    }
    out->t_end = out->t[out->n - 1];
    return WDR_OK;
}

double wdr_ramp_eval(const wdr_ramp *r, double t)
{
    if (t <= r->t[0])
        return r->v[0];
    if (t >= r->t[r->n - 1])
        return r->v[r->n - 1];
    int lo = 0, hi = r->n - 1; /* invariant: t[lo] < t <= t[hi] */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (r->t[mid] < t)
            lo = mid;
        else
            hi = mid;
    }
    double f = (t - r->t[lo]) / (r->t[hi] - r->t[lo]);
    return r->v[lo] + f * (r->v[hi] - r->v[lo]);
}

/* First time the sampled ramp reaches voltage v (ramp rises, so the first sample at or above v). */
static double ramp_time_at(const wdr_ramp *r, double v)
{
    if (v <= r->v[0])
        return r->t[0];
    int lo = 0, hi = r->n - 1;
    if (v > r->v[hi])
        return r->t[hi];
    while (hi - lo > 1) { /* invariant: v[lo] < v <= v[hi] */
        int mid = (lo + hi) / 2;
        if (r->v[mid] < v)
            lo = mid;
        else
            hi = mid;
    }
    double f = (v - r->v[lo]) / (r->v[hi] - r->v[lo]);
    return r->t[lo] + f * (r->t[hi] - r->t[lo]);
}

/* Exact crossing time of voltage v: bisection in ln I for g(I) = v inside the sample bracket,
 * then t = Q_needed(v) / I. Used unless the ramp was repaired (then the samples are the truth). */
static double exact_time_at(const wdr_ideal_pixel *px, const wdr_operator *op, const wdr_ramp *r, double v)
{
    if (r->repaired || v <= r->v[0] || v >= r->v[r->n - 1])
        return ramp_time_at(r, v);
    int lo = 0, hi = r->n - 1;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (r->v[mid] < v)
            lo = mid;
        else
            hi = mid;
    }
    double a = r->ln_i[hi], b = r->ln_i[lo]; /* g(e^a) >= v > g(e^b) */
    for (int k = 0; k < 60; k++) {
        double m = 0.5 * (a + b);
        if (wdr_ideal_target(px, op, exp(m)) >= v)
            a = m;
        else
            b = m;
    }
    return wdr_ideal_cross_time(px, exp(a), v);
}

typedef struct lut_build {
    uint32_t *ticks;
    uint16_t *codes;
    uint32_t n, cap;
} lut_build;

/* Append a step; a step that lands on the previous one's tick replaces its code, since the
 * DAC timer cannot place two updates on one tick. */
static void push_step(lut_build *lb, uint32_t tick, uint16_t code)
{
    if (lb->n > 0 && tick <= lb->ticks[lb->n - 1]) {
        lb->codes[lb->n - 1] = code;
        return;
    }
    lb->ticks[lb->n] = tick;
    lb->codes[lb->n] = code;
    lb->n++;
}

static double code_volts(const wdr_board *b, double code)
{
    return b->dac_lo_v + code * (b->dac_hi_v - b->dac_lo_v) / ((1 << b->dac_bits) - 1);
}

static long volts_code(const wdr_board *b, double v)
{
    return lround((v - b->dac_lo_v) / (b->dac_hi_v - b->dac_lo_v) * ((1 << b->dac_bits) - 1));
}

/* One entry per DAC code, stamped when the ideal ramp passes half an LSB below it. */
static int steps_stamped(const wdr_ramp *r, const wdr_board *b, const wdr_operator *op, double tick_s, lut_build *lb)
{
    wdr_ideal_pixel px;
    wdr_ideal_pixel_init(b, &px);
    long c0 = volts_code(b, r->v[0]), c1 = volts_code(b, r->v[r->n - 1]);
    if (c1 - c0 + 1 > (long)WDR_LUT_MAX_ENTRIES)
        return WDR_E_TOO_LARGE;
    push_step(lb, 0, (uint16_t)c0);
    for (long c = c0 + 1; c <= c1; c++) {
        double t = exact_time_at(&px, op, r, code_volts(b, c - 0.5));
        push_step(lb, (uint32_t)llround(t / tick_s), (uint16_t)c);
    }
    return WDR_OK;
}

/* A fixed clock: step k starts at k*dt and holds the code nearest the ramp's mean over it. */
static int steps_uniform(const wdr_ramp *r, const wdr_board *b, uint32_t entries, double tick_s, lut_build *lb)
{
    double dt = r->t_end / entries;
    if (entries > WDR_LUT_MAX_ENTRIES)
        return WDR_E_TOO_LARGE;
    if (entries == 0) /* no step: the table's last tick below would be read before its first */
        return WDR_E_INVAL;
    if (dt < tick_s)
        return WDR_E_INVAL;
    for (uint32_t k = 0; k < entries; k++) {
        double v = 0.5 * (wdr_ramp_eval(r, k * dt) + wdr_ramp_eval(r, (k + 1) * dt));
        push_step(lb, (uint32_t)llround(k * dt / tick_s), (uint16_t)volts_code(b, v));
    }
    return WDR_OK;
}

static int check_dac_range(const wdr_ramp *r, const wdr_board *b, char *err, int errlen)
{
    if (r->v[0] >= b->dac_lo_v && r->v[r->n - 1] <= b->dac_hi_v)
        return WDR_OK;
    snprintf(err, (size_t)errlen, "ramp needs V_ref from %.4f to %.4f V but the DAC spans %.4f..%.4f V (board dac.v_lo_V, "
             "dac.v_hi_V)", r->v[0], r->v[r->n - 1], b->dac_lo_v, b->dac_hi_v);
    return WDR_E_INVAL;
}

static void fill_header(wdr_lut_header *h, const wdr_board *b, const wdr_operator *op, int timing, uint32_t n,
                        uint32_t tick_ps, uint32_t t_int)
{
    memset(h, 0, sizeof *h);
    h->operator_id = (uint16_t)op->id;
    h->dac_bits = (uint8_t)b->dac_bits;
    h->timing = (uint8_t)timing;
    h->entry_count = n;
    h->tick_ps = tick_ps;
    h->t_integration_ticks = t_int;
    h->dac_lo_v = (float)b->dac_lo_v;
    h->dac_hi_v = (float)b->dac_hi_v;
    for (int i = 0; i < WDR_LUT_NPARAMS; i++)
        h->params[i] = isnan(op->p[i]) ? NAN : (float)op->p[i];
}

static int quantise_err(int rc, const wdr_board *b, int timing, uint32_t entries, char *err, int errlen)
{
    if (rc == WDR_E_TOO_LARGE)
        snprintf(err, (size_t)errlen, "LUT would need more than %u entries (dac.bits = %d)", WDR_LUT_MAX_ENTRIES,
                 b->dac_bits);
    else if (rc == WDR_E_INVAL && timing == WDR_TIMING_UNIFORM)
        snprintf(err, (size_t)errlen, "uniform clock of %u entries is faster than the DAC timer (dac.timer_Hz = %g)",
                 entries, b->dac_timer_hz);
    else if (rc)
        snprintf(err, (size_t)errlen, "cannot quantise ramp: %s", wdr_strerror(rc));
    return rc;
}

int wdr_ramp_quantise(const wdr_ramp *r, const wdr_board *b, const wdr_operator *op, int timing, uint32_t entries,
                      uint8_t **out, size_t *out_len, char *err, int errlen)
{
    double tick_s = 1.0 / b->dac_timer_hz;
    uint32_t cap = WDR_LUT_MAX_ENTRIES;
    if (b->dac_bits < 4 || b->dac_bits > 16) { /* 1 << dac_bits below, and the LUT format's range */
        snprintf(err, (size_t)errlen, "dac.bits = %d is not 4..16", b->dac_bits);
        return WDR_E_INVAL;
    }
    int rc = check_dac_range(r, b, err, errlen);
    if (rc)
        return rc;
    lut_build lb = {malloc(cap * sizeof(uint32_t)), malloc(cap * sizeof(uint16_t)), 0, cap};
    if (!lb.ticks || !lb.codes)
        rc = WDR_E_NOMEM;
    if (!rc)
        rc = timing == WDR_TIMING_UNIFORM ? steps_uniform(r, b, entries, tick_s, &lb)
                                          : steps_stamped(r, b, op, tick_s, &lb);
    double t_int = timing == WDR_TIMING_UNIFORM ? r->t_end : r->t_end * (1.0 + 1e-6) + 2 * tick_s;
    if (!rc && t_int / tick_s >= 4294967295.0)
        rc = WDR_E_TOO_LARGE;
    if (!rc) {
        wdr_lut_header h;
        uint32_t t_int_ticks = (uint32_t)ceil(t_int / tick_s);
        if (t_int_ticks <= lb.ticks[lb.n - 1])
            t_int_ticks = lb.ticks[lb.n - 1] + 1;
        fill_header(&h, b, op, timing, lb.n, (uint32_t)llround(tick_s * 1e12), t_int_ticks);
        *out_len = wdr_lut_size(lb.n);
        *out = malloc(*out_len);
        if (*out)
            wdr_lut_encode(&h, lb.ticks, lb.codes, *out);
        else
            rc = WDR_E_NOMEM;
    }
    free(lb.ticks);
    free(lb.codes);
    return rc ? quantise_err(rc, b, timing, entries, err, errlen) : WDR_OK;
}

/* ---- the ideal pixel under a quantised LUT ---- */

static double lut_volts(const wdr_lut_view *lut, uint16_t code)
{
    double lo = lut->h.dac_lo_v, hi = lut->h.dac_hi_v;
    return lo + code * (hi - lo) / (double)((1u << lut->h.dac_bits) - 1u);
}

/* Per-step quantities of a LUT, computed once for many currents. Freed twice is harmless (a
 * failed init has freed them already). */
void wdr_lut_steps_free(wdr_lut_steps *s)
{
    free(s->t0);
    free(s->t1);
    free(s->v);
    free(s->need);
    memset(s, 0, sizeof *s);
}

int wdr_lut_steps_init(const wdr_ideal_pixel *px, const wdr_lut_view *lut, wdr_lut_steps *s)
{
    double tick = lut->h.tick_ps * 1e-12;
    s->n = lut->h.entry_count;
    s->t0 = malloc(s->n * sizeof(double));
    s->t1 = malloc(s->n * sizeof(double));
    s->v = malloc(s->n * sizeof(double));
    s->need = malloc(s->n * sizeof(double));
    if (!s->t0 || !s->t1 || !s->v || !s->need) {
        wdr_lut_steps_free(s);
        return WDR_E_NOMEM;
    }
    for (uint32_t k = 0; k < s->n; k++) {
        uint32_t t, t_next = lut->h.t_integration_ticks;
        uint16_t code, next_code;
        wdr_lut_entry(lut, k, &t, &code);
        if (k + 1 < s->n)
            wdr_lut_entry(lut, k + 1, &t_next, &next_code);
        s->t0[k] = t * tick;
        s->t1[k] = t_next * tick;
        s->v[k] = lut_volts(lut, code);
        s->need[k] = charge_needed(px, s->v[k]);
    }
    return WDR_OK;
}

/* Step k holds its code from its stamp to the next; M2 turns off in the first step by whose end
 * the current has removed the charge needed for that step's level. If the node was already below
 * that level when the step began, M2 only lets G rise to the follower level of the node. */
double wdr_lut_steps_response(const wdr_ideal_pixel *px, const wdr_lut_steps *s, double i)
{
    for (uint32_t k = 0; k < s->n; k++) {
        if (i * s->t1[k] < s->need[k])
            continue;
        if (i * s->t0[k] <= s->need[k])
            return s->v[k];
        double v_node = wdr_pixel_voltage(&px->dev, px->q_n0 - i * s->t0[k]);
        return fmin(s->v[k], follower_level(px, v_node));
    }
    return s->v[s->n - 1];
}

double wdr_ramp_lut_ideal_response(const wdr_ideal_pixel *px, const wdr_lut_view *lut, double i)
{
    wdr_lut_steps s;
    if (wdr_lut_steps_init(px, lut, &s))
        return NAN;
    double v = wdr_lut_steps_response(px, &s, i);
    wdr_lut_steps_free(&s);
    return v;
}

double wdr_ramp_lut_worst_error_lsb(const wdr_ideal_pixel *px, const wdr_operator *op, const wdr_lut_view *lut,
                               double i_min, double i_max, int n, double *worst_i)
{
    double lsb = (lut->h.dac_hi_v - lut->h.dac_lo_v) / (double)((1u << lut->h.dac_bits) - 1u), worst = 0;
    wdr_lut_steps s;
    if (wdr_lut_steps_init(px, lut, &s))
        return INFINITY;
    for (int j = 0; j < n; j++) {
        double i = exp(log(i_min) + (log(i_max) - log(i_min)) * j / (n - 1));
        double e = fabs(wdr_lut_steps_response(px, &s, i) - wdr_ideal_target(px, op, i)) / lsb;
        if (e > worst || !isfinite(e)) {
            worst = isfinite(e) ? e : INFINITY;
            if (worst_i)
                *worst_i = i;
        }
    }
    wdr_lut_steps_free(&s);
    return worst;
}
