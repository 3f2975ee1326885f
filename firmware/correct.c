/* The per-pixel correction kernel. Each form has its own branch-free loop over the row so the
 * compiler can vectorise it; flagged pixels are patched afterwards, in a separate pass, because
 * they are rare and a per-pixel test would slow every good pixel down. float32 only. */
#include "correct.h"
#include "wdr_err.h"
#include <string.h>

/* Scale to output codes and clamp: the comparisons also map NaN to 0, so nothing non-finite
 * leaves the kernel whatever the input. */
static inline float to_output(float v, float out_scale, float out_max)
{
    v *= out_scale;
    v = v > 0.0f ? v : 0.0f;
    return v < out_max ? v : out_max;
}

static inline float moebius(float y, float p, float q, float r) { return (p * y + q) / (r * y + 1.0f); }

/* Horner over n coefficients; n is a literal at every call so the loop unrolls. */
static inline float poly(const float *const *c, int i, float u, const int n)
{
    float v = c[n - 1][i];
    for (int k = n - 2; k >= 0; k--)
        v = v * u + c[k][i];
    return v;
}

/* BASIS: the shared table's position of code y, clamped to [0, K-1] (comparisons: NaN goes to
 * 0), split into a point index below K-1 and a fraction; the last point is reached with f = 1. */
static inline int basis_point(float y, float a, float b, float last, float *f)
{
    float t = y * a + b;
    t = t > 0.0f ? t : 0.0f;
    t = t < last ? t : last;
    int j = (int)t;
    j = j < (int)last ? j : (int)last - 1;
    *f = t - (float)j;
    return j;
}

/* sum_k c_k B_k(t), each B_k linear between points j and j+1 (point-major: one cache line):
 * the sums at both points, then one interpolation. Four partial sums, so the multiply-adds do
 * not wait on each other. */
static inline float basis_sum(const float *const *c, int i, const float *shared, int j, float f, const int n)
{
    const float *p0 = shared + j * n, *p1 = p0 + n;
    float a0 = 0.0f, a1 = 0.0f, b0 = 0.0f, b1 = 0.0f;
    int k = 0;
    for (; k + 1 < n; k += 2) {
        float ck = c[k][i], cl = c[k + 1][i];
        a0 += ck * p0[k], a1 += cl * p0[k + 1];
        b0 += ck * p1[k], b1 += cl * p1[k + 1];
    }
    if (k < n) {
        a0 += c[k][i] * p0[k];
        b0 += c[k][i] * p1[k];
    }
    float a = a0 + a1, b = b0 + b1;
    return a + f * (b - a);
}

/* ---- one loop per form and input type ---- */

/* A power-of-two scale of at most 2^15 whose largest raw code fits: a shift, exact. */
static int identity_shift(const wdr_cal_view *cal)
{
    for (int k = 0; k <= 15; k++)
        if (cal->h.out_scale == (float)(1u << k))
            return ((uint32_t)cal->h.raw_max << k) <= cal->h.out_max ? k : -1;
    return -1;
}

static void identity_u16(const wdr_cal_view *cal, const uint16_t *raw, uint16_t *out)
{
    const float s = cal->h.out_scale, m = (float)cal->h.out_max;
    const int w = cal->h.width, k = identity_shift(cal);
    const uint16_t top = cal->h.raw_max;
    if (k >= 0) { /* codes above raw_max cannot come from the ADC; clamp them anyway */
        for (int i = 0; i < w; i++)
            out[i] = (uint16_t)((raw[i] < top ? raw[i] : top) << k);
        return;
    }
    for (int i = 0; i < w; i++) /* w is a local: out (uint16_t) could alias the header's fields */
        out[i] = (uint16_t)(to_output((float)raw[i], s, m) + 0.5f);
}

static void moebius_u16(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out)
{
    const float *p = wdr_cal_row_coeffs(cal, row, 0), *q = wdr_cal_row_coeffs(cal, row, 1),
                *r = wdr_cal_row_coeffs(cal, row, 2);
    const float s = cal->h.out_scale, m = (float)cal->h.out_max;
    const int w = cal->h.width;
    for (int i = 0; i < w; i++)
        out[i] = (uint16_t)(to_output(moebius((float)raw[i], p[i], q[i], r[i]), s, m) + 0.5f);
}

static inline void poly_u16_n(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out, const int n)
{
    const float *c[WDR_CAL_MAX_COEFFS];
    for (int k = 0; k < n; k++)
        c[k] = wdr_cal_row_coeffs(cal, row, k);
    const float s = cal->h.out_scale, m = (float)cal->h.out_max, a = cal->h.in_scale, b = cal->h.in_offset;
    const int w = cal->h.width;
    for (int i = 0; i < w; i++)
        out[i] = (uint16_t)(to_output(poly(c, i, (float)raw[i] * a + b, n), s, m) + 0.5f);
}

static void poly_u16(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out)
{
    switch (cal->h.n_coeffs) {
    case 2: poly_u16_n(cal, row, raw, out, 2); break;
    case 3: poly_u16_n(cal, row, raw, out, 3); break;
    case 4: poly_u16_n(cal, row, raw, out, 4); break;
    case 5: poly_u16_n(cal, row, raw, out, 5); break;
    case 6: poly_u16_n(cal, row, raw, out, 6); break;
    case 7: poly_u16_n(cal, row, raw, out, 7); break;
    default: poly_u16_n(cal, row, raw, out, 8); break;
    }
}

static inline void basis_u16_n(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out, const int n)
{
    const float *c[WDR_CAL_MAX_COEFFS];
    for (int k = 0; k < n; k++)
        c[k] = wdr_cal_row_coeffs(cal, row, k);
    const float s = cal->h.out_scale, m = (float)cal->h.out_max, a = cal->h.in_scale, b = cal->h.in_offset;
    const float last = (float)(cal->h.shared_points - 1u);
    const float *shared = cal->shared;
    const int w = cal->h.width;
    for (int i = 0; i < w; i++) {
        float f;
        int j = basis_point((float)raw[i], a, b, last, &f);
        out[i] = (uint16_t)(to_output(basis_sum(c, i, shared, j, f, n), s, m) + 0.5f);
    }
}

static void basis_u16(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out)
{
    switch (cal->h.n_coeffs) {
    case 2: basis_u16_n(cal, row, raw, out, 2); break;
    case 3: basis_u16_n(cal, row, raw, out, 3); break;
    case 4: basis_u16_n(cal, row, raw, out, 4); break;
    case 5: basis_u16_n(cal, row, raw, out, 5); break;
    case 6: basis_u16_n(cal, row, raw, out, 6); break;
    case 7: basis_u16_n(cal, row, raw, out, 7); break;
    default: basis_u16_n(cal, row, raw, out, 8); break;
    }
}

static void basis_f32(const wdr_cal_view *cal, int row, const float *raw, float *out)
{
    const int n = cal->h.n_coeffs;
    const float *c[WDR_CAL_MAX_COEFFS];
    for (int k = 0; k < n; k++)
        c[k] = wdr_cal_row_coeffs(cal, row, k);
    const float s = cal->h.out_scale, m = (float)cal->h.out_max, a = cal->h.in_scale, b = cal->h.in_offset;
    const float last = (float)(cal->h.shared_points - 1u);
    const int w = cal->h.width;
    for (int i = 0; i < w; i++) {
        float f;
        int j = basis_point(raw[i], a, b, last, &f);
        out[i] = to_output(basis_sum(c, i, cal->shared, j, f, n), s, m);
    }
}

static void identity_f32(const wdr_cal_view *cal, const float *raw, float *out)
{
    const float s = cal->h.out_scale, m = (float)cal->h.out_max;
    const int w = cal->h.width;
    for (int i = 0; i < w; i++)
        out[i] = to_output(raw[i], s, m);
}

static void moebius_f32(const wdr_cal_view *cal, int row, const float *raw, float *out)
{
    const float *p = wdr_cal_row_coeffs(cal, row, 0), *q = wdr_cal_row_coeffs(cal, row, 1),
                *r = wdr_cal_row_coeffs(cal, row, 2);
    const float s = cal->h.out_scale, m = (float)cal->h.out_max;
    const int w = cal->h.width;
    for (int i = 0; i < w; i++)
        out[i] = to_output(moebius(raw[i], p[i], q[i], r[i]), s, m);
}

static void poly_f32(const wdr_cal_view *cal, int row, const float *raw, float *out)
{
    const int n = cal->h.n_coeffs;
    const float *c[WDR_CAL_MAX_COEFFS];
    for (int k = 0; k < n; k++)
        c[k] = wdr_cal_row_coeffs(cal, row, k);
    const float s = cal->h.out_scale, m = (float)cal->h.out_max, a = cal->h.in_scale, b = cal->h.in_offset;
    const int w = cal->h.width;
    for (int i = 0; i < w; i++) {
        float u = raw[i] * a + b, v = c[n - 1][i];
        for (int k = n - 2; k >= 0; k--)
            v = v * u + c[k][i];
        out[i] = to_output(v, s, m);
    }
}

/* ---- bad pixels: each run of flagged pixels takes the mean of the good pixels around it ---- */

static int next_flagged(const uint8_t *f, int i, int w)
{
    while (i + 8 <= w) { /* most rows have no flags: skip eight at a time */
        uint64_t word;
        memcpy(&word, f + i, 8);
        if (word)
            break;
        i += 8;
    }
    while (i < w && !f[i])
        i++;
    return i;
}

static void patch_u16(const uint8_t *f, int w, uint16_t *out)
{
    for (int s = next_flagged(f, 0, w); s < w; s = next_flagged(f, s, w)) {
        int e = s;
        while (e < w && f[e])
            e++;
        uint32_t fill;
        if (s > 0 && e < w)
            fill = ((uint32_t)out[s - 1] + out[e] + 1u) / 2u;
        else if (s > 0)
            fill = out[s - 1];
        else if (e < w)
            fill = out[e];
        else
            return; /* no good pixel in the row: leave the clamped values */
        for (int i = s; i < e; i++)
            out[i] = (uint16_t)fill;
        s = e;
    }
}

static void patch_f32(const uint8_t *f, int w, float *out)
{
    for (int s = next_flagged(f, 0, w); s < w; s = next_flagged(f, s, w)) {
        int e = s;
        while (e < w && f[e])
            e++;
        float fill;
        if (s > 0 && e < w)
            fill = 0.5f * (out[s - 1] + out[e]);
        else if (s > 0)
            fill = out[s - 1];
        else if (e < w)
            fill = out[e];
        else
            return;
        for (int i = s; i < e; i++)
            out[i] = fill;
        s = e;
    }
}

static int row_ok(const wdr_cal_view *cal, int row, const void *raw, const void *out)
{
    return cal && raw && out && row >= 0 && row < cal->h.height &&
           (cal->h.form == WDR_FORM_IDENTITY || cal->payload) &&
           (cal->h.form != WDR_FORM_BASIS || (cal->shared && cal->h.shared_points >= 2));
}

int wdr_correct_row(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out)
{
    if (!row_ok(cal, row, raw, out))
        return WDR_E_INVAL;
    switch (cal->h.form) {
    case WDR_FORM_IDENTITY:
        identity_u16(cal, raw, out);
        return WDR_OK;
    case WDR_FORM_MOEBIUS:
        moebius_u16(cal, row, raw, out);
        break;
    case WDR_FORM_POLY:
        poly_u16(cal, row, raw, out);
        break;
    case WDR_FORM_BASIS:
        basis_u16(cal, row, raw, out);
        break;
    default:
        return WDR_E_INVAL;
    }
    if (cal->h.bad_pixels)
        patch_u16(wdr_cal_row_flags(cal, row), cal->h.width, out);
    return WDR_OK;
}

int wdr_correct_row_f32(const wdr_cal_view *cal, int row, const float *raw, float *out)
{
    if (!row_ok(cal, row, raw, out))
        return WDR_E_INVAL;
    switch (cal->h.form) {
    case WDR_FORM_IDENTITY:
        identity_f32(cal, raw, out);
        return WDR_OK;
    case WDR_FORM_MOEBIUS:
        moebius_f32(cal, row, raw, out);
        break;
    case WDR_FORM_POLY:
        poly_f32(cal, row, raw, out);
        break;
    case WDR_FORM_BASIS:
        basis_f32(cal, row, raw, out);
        break;
    default:
        return WDR_E_INVAL;
    }
    if (cal->h.bad_pixels)
        patch_f32(wdr_cal_row_flags(cal, row), cal->h.width, out);
    return WDR_OK;
}
