/* The per-pixel correction kernel. Each form has its own branch-free loop over the row so the
 * compiler can vectorise it; flagged pixels are patched afterwards, in a separate pass, because
 * they are rare and a per-pixel test would slow every good pixel down. float32 only. */
#include "correct.h"
#include "wdr_err.h"
#include <string.h>

/* Four pixels at a time where the target has 4-float vectors (SSE2, AArch64 NEON) and the
 * compiler has GCC/clang vector extensions; everywhere else (Cortex-M7: one FPU, no float
 * SIMD) the plain loop, which is the fastest there. WDR_CORRECT_SCALAR forces the plain loop
 * (a test runs it on the host, so the firmware's own loop is checked too). */
#if !defined(WDR_CORRECT_SCALAR) && defined(__has_builtin) && (defined(__SSE2__) || defined(__aarch64__))
#if __has_builtin(__builtin_shufflevector) && __has_builtin(__builtin_convertvector)
#define WDR_CORRECT_V4 1
#endif
#endif

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

/* ---- four pixels at a time (WDR_CORRECT_V4) ---- */

#ifdef WDR_CORRECT_V4
typedef float wdr_v4f __attribute__((vector_size(16)));
typedef int32_t wdr_v4i __attribute__((vector_size(16)));
typedef uint16_t wdr_v4u16 __attribute__((vector_size(8)));

/* m (a literal, 1..4) floats from p, the rest zero: the last group of n coefficients must not
 * read past the last code's point. */
static inline wdr_v4f v4_load(const float *p, const int m)
{
    wdr_v4f v = {0.0f, 0.0f, 0.0f, 0.0f};
    memcpy(&v, p, (size_t)m * sizeof(float));
    return v;
}

/* Four pixels' points (one per row of r) become four vectors of one basis function each
 * (lane = pixel), so the coefficient planes multiply them lane by lane. */
static inline void v4_transpose(wdr_v4f r[4])
{
    wdr_v4f t0 = __builtin_shufflevector(r[0], r[1], 0, 4, 1, 5), t1 = __builtin_shufflevector(r[0], r[1], 2, 6, 3, 7);
    wdr_v4f t2 = __builtin_shufflevector(r[2], r[3], 0, 4, 1, 5), t3 = __builtin_shufflevector(r[2], r[3], 2, 6, 3, 7);
    r[0] = __builtin_shufflevector(t0, t2, 0, 1, 4, 5), r[1] = __builtin_shufflevector(t0, t2, 2, 3, 6, 7);
    r[2] = __builtin_shufflevector(t1, t3, 0, 1, 4, 5), r[3] = __builtin_shufflevector(t1, t3, 2, 3, 6, 7);
}

/* Basis functions g..g+m-1 (m a literal, 1..4; g even) of four pixels whose points are p[0..3],
 * added to the even and odd sums in the order code_dot adds them. */
static inline void code_group4(wdr_v4f acc[2], const float *const *c, int i, const float *const p[4], const int g,
                               const int m)
{
    wdr_v4f r[4] = {v4_load(p[0] + g, m), v4_load(p[1] + g, m), v4_load(p[2] + g, m), v4_load(p[3] + g, m)};
    v4_transpose(r);
    for (int k = 0; k < m; k++)
        acc[k & 1] += v4_load(c[g + k] + i, 4) * r[k];
}

/* code_dot for pixels i..i+3, four lanes at once; n <= 8 is two groups at most, written out so
 * every load has a literal size. */
static inline wdr_v4f code_dot4(const float *const *c, int i, const float *const p[4], const int n)
{
    wdr_v4f acc[2] = {{0.0f, 0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f, 0.0f}};
    code_group4(acc, c, i, p, 0, n < 4 ? n : 4);
    if (n > 4)
        code_group4(acc, c, i, p, 4, n - 4);
    return acc[0] + acc[1];
}

/* to_output of four lanes; the masks map NaN to 0 as the comparisons do. */
static inline wdr_v4f v4_output(wdr_v4f v, float s, float m)
{
    const wdr_v4f zero = {0.0f, 0.0f, 0.0f, 0.0f}, top = {m, m, m, m};
    v *= (wdr_v4f){s, s, s, s};
    v = (wdr_v4f)((wdr_v4i)v & (v > zero));
    wdr_v4i below = v < top;
    return (wdr_v4f)(((wdr_v4i)v & below) | ((wdr_v4i)top & ~below));
}

/* to_output and the rounding of four lanes. */
static inline void v4_store_u16(wdr_v4f v, float s, float m, uint16_t *out)
{
    const wdr_v4f half = {0.5f, 0.5f, 0.5f, 0.5f};
    wdr_v4u16 q = __builtin_convertvector(__builtin_convertvector(v4_output(v, s, m) + half, wdr_v4i), wdr_v4u16);
    memcpy(out, &q, sizeof q);
}
#endif

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

#ifdef WDR_CORRECT_V4
/* basis_point for four codes: the same float operations lane by lane, so the same points and
 * fractions; computed in lanes because four scalar fractions stored and reloaded as one vector
 * stall the load. */
static inline wdr_v4f basis_point4(wdr_v4f y, float a, float b, float last, wdr_v4i *j)
{
    const wdr_v4f zero = {0.0f, 0.0f, 0.0f, 0.0f}, top = {last, last, last, last};
    const wdr_v4i below_top = {(int)last - 1, (int)last - 1, (int)last - 1, (int)last - 1};
    wdr_v4f t = y * (wdr_v4f){a, a, a, a} + (wdr_v4f){b, b, b, b};
    t = (wdr_v4f)((wdr_v4i)t & (t > zero));
    wdr_v4i in = t < top;
    t = (wdr_v4f)(((wdr_v4i)t & in) | ((wdr_v4i)top & ~in));
    wdr_v4i p = __builtin_convertvector(t, wdr_v4i), low = p < below_top;
    *j = (p & low) | (below_top & ~low);
    return t - __builtin_convertvector(*j, wdr_v4f);
}

/* basis_sum for four pixels at codes y: both points' sums by code_dot4 (the order basis_sum
 * adds in), then the same interpolation per lane, so the results are basis_sum's to the bit. */
static inline wdr_v4f basis_sum4(const float *const *c, int i, const float *shared, wdr_v4f y, float a, float b,
                                 float last, const int n)
{
    wdr_v4i j;
    wdr_v4f f = basis_point4(y, a, b, last, &j);
    const float *p0[4] = {shared + j[0] * n, shared + j[1] * n, shared + j[2] * n, shared + j[3] * n};
    const float *p1[4] = {p0[0] + n, p0[1] + n, p0[2] + n, p0[3] + n};
    wdr_v4f at0 = code_dot4(c, i, p0, n), at1 = code_dot4(c, i, p1, n);
    return at0 + f * (at1 - at0);
}

/* Pixels from 0 in blocks of four; returns where the plain loop takes over. */
static inline int basis_u16_v4(const float *const *c, const float *shared, float a, float b, float last, float s,
                               float m, int w, const uint16_t *raw, uint16_t *out, const int n)
{
    int i = 0;
    for (; i + 4 <= w; i += 4) {
        wdr_v4f y = __builtin_convertvector(((wdr_v4i){raw[i], raw[i + 1], raw[i + 2], raw[i + 3]}), wdr_v4f);
        v4_store_u16(basis_sum4(c, i, shared, y, a, b, last, n), s, m, out + i);
    }
    return i;
}

static inline int basis_f32_v4(const float *const *c, const float *shared, float a, float b, float last, float s,
                               float m, int w, const float *raw, float *out, const int n)
{
    int i = 0;
    for (; i + 4 <= w; i += 4) {
        wdr_v4f v = v4_output(basis_sum4(c, i, shared, v4_load(raw + i, 4), a, b, last, n), s, m);
        memcpy(out + i, &v, sizeof v);
    }
    return i;
}
#endif

static inline void basis_u16_n(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out, const int n)
{
    const float *c[WDR_CAL_MAX_COEFFS];
    for (int k = 0; k < n; k++)
        c[k] = wdr_cal_row_coeffs(cal, row, k);
    const float s = cal->h.out_scale, m = (float)cal->h.out_max, a = cal->h.in_scale, b = cal->h.in_offset;
    const float last = (float)(cal->h.shared_points - 1u);
    const float *shared = cal->shared;
    const int w = cal->h.width;
    int i = 0;
#ifdef WDR_CORRECT_V4
    i = basis_u16_v4(c, shared, a, b, last, s, m, w, raw, out, n);
#endif
    for (; i < w; i++) {
        float f;
        int j = basis_point((float)raw[i], a, b, last, &f);
        out[i] = (uint16_t)(to_output(basis_sum(c, i, shared, j, f, n), s, m) + 0.5f);
    }
}

/* ---- BASIS with one shared point per raw code (wdr_correct_per_code): t(y) = y, so a pixel is
 * one dot product of its coefficients with its code's point, no position, no interpolation ---- */

/* The view came from wdr_correct_per_code, or any BASIS table whose points are the raw codes:
 * then t(y) is the integer y clamped to [0, K-1] and the kernel only has to pick the point. */
static int points_are_codes(const wdr_cal_view *cal)
{
    return cal->h.in_scale == 1.0f && cal->h.in_offset == 0.0f;
}

/* The point of code y: codes above the last point (not from this ADC) take the last one, as the
 * interpolating path clamps t. */
static inline const float *code_point(const float *points, uint32_t top, uint16_t y, const int n)
{
    return points + (size_t)(y < top ? y : top) * (size_t)n;
}

/* Even and odd k in two sums, so the multiply-adds do not all wait on one another; both loops
 * below add in exactly this order, so a host and the controller agree to the bit. */
static inline float code_dot(const float *const *c, int i, const float *p, const int n)
{
    float even = 0.0f, odd = 0.0f;
    for (int k = 0; k + 1 < n; k += 2) {
        even += c[k][i] * p[k];
        odd += c[k + 1][i] * p[k + 1];
    }
    if (n & 1)
        even += c[n - 1][i] * p[n - 1];
    return even + odd;
}

#ifdef WDR_CORRECT_V4
/* Pixels from 0 in blocks of four; returns where the plain loop takes over. Everything read in
 * the loop is a local: a store to out (uint16_t) could otherwise alias the view's fields. */
static inline int codes_u16_v4(const float *const *c, const float *points, uint32_t top, float s, float m, int w,
                               const uint16_t *raw, uint16_t *out, const int n)
{
    int i = 0;
    for (; i + 4 <= w; i += 4) {
        const float *p[4] = {code_point(points, top, raw[i], n), code_point(points, top, raw[i + 1], n),
                             code_point(points, top, raw[i + 2], n), code_point(points, top, raw[i + 3], n)};
        v4_store_u16(code_dot4(c, i, p, n), s, m, out + i);
    }
    return i;
}
#endif

static inline void codes_u16_n(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out, const int n)
{
    const float *c[WDR_CAL_MAX_COEFFS];
    for (int k = 0; k < n; k++)
        c[k] = wdr_cal_row_coeffs(cal, row, k);
    const float s = cal->h.out_scale, m = (float)cal->h.out_max, *points = cal->shared;
    const uint32_t top = cal->h.shared_points - 1u;
    const int w = cal->h.width;
    int i = 0;
#ifdef WDR_CORRECT_V4
    i = codes_u16_v4(c, points, top, s, m, w, raw, out, n);
#endif
    for (; i < w; i++)
        out[i] = (uint16_t)(to_output(code_dot(c, i, code_point(points, top, raw[i], n), n), s, m) + 0.5f);
}

static void codes_u16(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out)
{
    switch (cal->h.n_coeffs) {
    case 2: codes_u16_n(cal, row, raw, out, 2); break;
    case 3: codes_u16_n(cal, row, raw, out, 3); break;
    case 4: codes_u16_n(cal, row, raw, out, 4); break;
    case 5: codes_u16_n(cal, row, raw, out, 5); break;
    case 6: codes_u16_n(cal, row, raw, out, 6); break;
    case 7: codes_u16_n(cal, row, raw, out, 7); break;
    default: codes_u16_n(cal, row, raw, out, 8); break;
    }
}

/* B_k at every raw code, interpolated once here instead of once per pixel; float only, as the
 * kernel would have computed it. */
int wdr_correct_per_code(wdr_cal_view *cal, float *points, size_t capacity)
{
    if (!cal || !points || cal->h.form != WDR_FORM_BASIS || !cal->shared || cal->h.shared_points < 2 ||
        !wdr_cal_form_coeffs_ok(cal->h.form, cal->h.n_coeffs) || cal->h.raw_max == 0)
        return WDR_E_INVAL;
    const int n = cal->h.n_coeffs;
    const uint32_t codes = (uint32_t)cal->h.raw_max + 1u;
    if ((size_t)codes * (size_t)n > capacity)
        return WDR_E_TOO_LARGE;
    const float a = cal->h.in_scale, b = cal->h.in_offset, last = (float)(cal->h.shared_points - 1u);
    for (uint32_t y = 0; y < codes; y++) {
        float f;
        const float *p0 = cal->shared + (size_t)basis_point((float)y, a, b, last, &f) * (size_t)n, *p1 = p0 + n;
        for (int k = 0; k < n; k++)
            points[(size_t)y * (size_t)n + (size_t)k] = p0[k] + f * (p1[k] - p0[k]);
    }
    cal->shared = points;
    cal->h.shared_points = codes;
    cal->h.in_scale = 1.0f;
    cal->h.in_offset = 0.0f;
    return WDR_OK;
}

static void basis_u16(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out)
{
    if (points_are_codes(cal)) {
        codes_u16(cal, row, raw, out);
        return;
    }
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

static inline void basis_f32_n(const wdr_cal_view *cal, int row, const float *raw, float *out, const int n)
{
    const float *c[WDR_CAL_MAX_COEFFS];
    for (int k = 0; k < n; k++)
        c[k] = wdr_cal_row_coeffs(cal, row, k);
    const float s = cal->h.out_scale, m = (float)cal->h.out_max, a = cal->h.in_scale, b = cal->h.in_offset;
    const float last = (float)(cal->h.shared_points - 1u);
    const float *shared = cal->shared;
    const int w = cal->h.width;
    int i = 0;
#ifdef WDR_CORRECT_V4
    i = basis_f32_v4(c, shared, a, b, last, s, m, w, raw, out, n);
#endif
    for (; i < w; i++) {
        float f;
        int j = basis_point(raw[i], a, b, last, &f);
        out[i] = to_output(basis_sum(c, i, shared, j, f, n), s, m);
    }
}

/* n a literal in each copy, as for basis_u16: the host's studies run this on whole frames. */
static void basis_f32(const wdr_cal_view *cal, int row, const float *raw, float *out)
{
    switch (cal->h.n_coeffs) {
    case 2: basis_f32_n(cal, row, raw, out, 2); break;
    case 3: basis_f32_n(cal, row, raw, out, 3); break;
    case 4: basis_f32_n(cal, row, raw, out, 4); break;
    case 5: basis_f32_n(cal, row, raw, out, 5); break;
    case 6: basis_f32_n(cal, row, raw, out, 6); break;
    case 7: basis_f32_n(cal, row, raw, out, 7); break;
    default: basis_f32_n(cal, row, raw, out, 8); break;
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
    /* n_coeffs sizes the kernels' coefficient arrays: a view not made by wdr_cal_parse (a
     * firmware's own, a fuzzed one) must still have a count its form allows. */
    return cal && raw && out && row >= 0 && row < cal->h.height &&
           wdr_cal_form_coeffs_ok(cal->h.form, cal->h.n_coeffs) &&
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
