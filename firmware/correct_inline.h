/* The per-pixel formulas of every table form, as static inline functions, shared by the firmware
 * kernel (correct.c, integer codes in) and the host's float path (host/lib/correct_f32.c), so the
 * two cannot drift apart: same operations in the same order, same bits. float32 and integers only. */
#ifndef WDR_CORRECT_INLINE_H
#define WDR_CORRECT_INLINE_H
#include "wdr_cal.h"
#include <stddef.h>
#include <stdint.h>
#if defined(__ARM_FEATURE_DSP)
#include <arm_acle.h> /* __smlad: compiler intrinsic, no library */
#endif

/* One dispatch over the coefficient count: fn(cal, row, raw, out, n) with n a literal (so every
 * loop unrolls), instantiated once per n, in a table indexed by n - 2 (wdr_cal_form_coeffs_ok
 * has checked 2..8 before). */
/* clang-format off */
#define WDR_CORRECT_BY_N(table, fn, raw_t, out_t)                                                          \
    static void fn##_2(const wdr_cal_view *c, int r, const raw_t *x, out_t *o) { fn(c, r, x, o, 2); }      \
    static void fn##_3(const wdr_cal_view *c, int r, const raw_t *x, out_t *o) { fn(c, r, x, o, 3); }      \
    static void fn##_4(const wdr_cal_view *c, int r, const raw_t *x, out_t *o) { fn(c, r, x, o, 4); }      \
    static void fn##_5(const wdr_cal_view *c, int r, const raw_t *x, out_t *o) { fn(c, r, x, o, 5); }      \
    static void fn##_6(const wdr_cal_view *c, int r, const raw_t *x, out_t *o) { fn(c, r, x, o, 6); }      \
    static void fn##_7(const wdr_cal_view *c, int r, const raw_t *x, out_t *o) { fn(c, r, x, o, 7); }      \
    static void fn##_8(const wdr_cal_view *c, int r, const raw_t *x, out_t *o) { fn(c, r, x, o, 8); }      \
    static void (*const table[7])(const wdr_cal_view *, int, const raw_t *, out_t *) = {                   \
        fn##_2, fn##_3, fn##_4, fn##_5, fn##_6, fn##_7, fn##_8}
/* clang-format on */

/* Scale to output codes and clamp: the comparisons also map NaN to 0, so nothing non-finite
 * leaves the kernel whatever the input. */
static inline float wdr_to_output(float v, float out_scale, float out_max)
{
    v *= out_scale;
    v = v > 0.0f ? v : 0.0f;
    return v < out_max ? v : out_max;
}

static inline float wdr_moebius(float y, float p, float q, float r)
{
    return (p * y + q) / (r * y + 1.0f);
}

/* Horner over n coefficients; n is a literal at every call so the loop unrolls. */
static inline float wdr_poly(const float *const *c, int i, float u, const int n)
{
    float v = c[n - 1][i];
    for (int k = n - 2; k >= 0; k--)
        v = v * u + c[k][i];
    return v;
}

/* BASIS: the shared table's position of code y, clamped to [0, K-1] (comparisons: NaN goes to
 * 0), split into a point index below K-1 and a fraction; the last point is reached with f = 1. */
static inline int wdr_basis_point(float y, float a, float b, float last, float *f)
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
static inline float wdr_basis_sum(const float *const *c, int i, const float *shared, int j, float f, const int n)
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

/* The coefficient planes of one row of a float form. */
static inline void wdr_row_planes(const wdr_cal_view *cal, int row, const float **c, const int n)
{
    for (int k = 0; k < n; k++)
        c[k] = wdr_cal_row_coeffs(cal, row, k);
}

/* ---- COMPACT: fixed point. Per raw code y the kernel tabulates what every pixel shares,
 * base(y) = out_scale sum_k offset_k B_k(t(y)), as an integer part (output codes) and a fraction
 * in 2^-F codes that also holds the rounding half; and P_k(y) = round(scale_k out_scale 2^F
 * B_k(t(y))) as int16. A pixel is int(y) + ((frac(y) + sum_k q_k P_k(y)) >> F): two SMLAD in
 * int32, so F only has to serve the pixels' spread, not the whole output range. The bounds keep
 * the sum inside int32: 4 * 32768 * 16128 + 1.5 * 2^24 < 2^31. ---- */

#define WDR_CAL_COMPACT_P_MAX 16128.0f
#define WDR_CAL_COMPACT_BASE_MAX 1073741824.0f /* 2^30 output codes: any out_max fits */
#define WDR_CAL_COMPACT_MAX_SHIFT 24u
#define WDR_CAL_COMPACT_POINT_WORDS 4u /* frac, P0|P1, P2|P3, int: 16 bytes, one shift to address */

static inline const float *wdr_compact_offsets(const wdr_cal_view *cal)
{
    return wdr_cal_compact_scales(cal) + WDR_CAL_COMPACT_COEFFS;
}

/* sum_k offset_k B_k at one point, in the order the kernel adds. */
static inline float wdr_compact_base_at(const float *point, const float *offset)
{
    return ((point[0] * offset[0] + point[1] * offset[1]) + point[2] * offset[2]) + point[3] * offset[3];
}

/* F: the largest shift in 1..24 that keeps every |P| within WDR_CAL_COMPACT_P_MAX at the shared
 * points (the codes interpolate between them; rounding past the bound is clamped). */
static inline uint32_t wdr_compact_shift(const wdr_cal_view *cal)
{
    const float *scale = wdr_cal_compact_scales(cal);
    float top = 0.0f;
    for (uint32_t j = 0; j < cal->h.shared_points; j++)
        for (uint32_t k = 0; k < WDR_CAL_COMPACT_COEFFS; k++) {
            float v = cal->shared[j * WDR_CAL_COMPACT_COEFFS + k] * scale[k] * cal->h.out_scale;
            v = v < 0.0f ? -v : v;
            top = v > top ? v : top;
        }
    uint32_t f = 1;
    while (f < WDR_CAL_COMPACT_MAX_SHIFT && top * (float)(1u << (f + 1u)) <= WDR_CAL_COMPACT_P_MAX)
        f++;
    return f;
}

/* g_k = scale_k out_scale 2^F: P_k(y) = round(g_k B_k(t(y))). */
static inline void wdr_compact_gains(const wdr_cal_view *cal, uint32_t shift, float g[WDR_CAL_COMPACT_COEFFS])
{
    const float *scale = wdr_cal_compact_scales(cal);
    for (uint32_t k = 0; k < WDR_CAL_COMPACT_COEFFS; k++)
        g[k] = scale[k] * cal->h.out_scale * (float)(1u << shift);
}

static inline float wdr_clampf(float x, float top)
{
    return x < top ? (x > -top ? x : -top) : top;
}

static inline int32_t wdr_round_i32(float x)
{
    return (int32_t)(x < 0.0f ? x - 0.5f : x + 0.5f);
}

static inline int32_t wdr_floor_i32(float x)
{
    int32_t i = (int32_t)x;
    return (float)i > x ? i - 1 : i;
}

/* The words of code y (SHIFTED: down to -WDR_CAL_SHIFT_PAD): frac(y) 2^F + 2^(F-1), P0 | P1 << 16, P2 | P3 << 16, int(y). */
static inline void wdr_compact_point(const wdr_cal_view *cal, const float g[WDR_CAL_COMPACT_COEFFS], uint32_t shift,
                                     int32_t y, uint32_t out[WDR_CAL_COMPACT_POINT_WORDS])
{
    const uint32_t n = WDR_CAL_COMPACT_COEFFS;
    float f, b[WDR_CAL_COMPACT_COEFFS] = {0}; /* all set below; zeroed for gcc -fanalyzer, which loses the count */
    const float *p0 = cal->shared + (size_t)wdr_basis_point((float)y, cal->h.in_scale, cal->h.in_offset,
                                                            (float)(cal->h.shared_points - 1u), &f) *
                                        n;
    const float *p1 = p0 + n;
    uint32_t q[WDR_CAL_COMPACT_COEFFS] = {0};
    for (uint32_t k = 0; k < n; k++) {
        b[k] = p0[k] + f * (p1[k] - p0[k]);
        q[k] = (uint16_t)(int16_t)wdr_round_i32(wdr_clampf(b[k] * g[k], WDR_CAL_COMPACT_P_MAX));
    }
    float base =
        wdr_clampf(wdr_compact_base_at(b, wdr_compact_offsets(cal)) * cal->h.out_scale, WDR_CAL_COMPACT_BASE_MAX);
    int32_t whole = wdr_floor_i32(base);
    float frac = (base - (float)whole) * (float)(1u << shift); /* [0, 2^F], exact scaling */
    out[0] = (uint32_t)(wdr_round_i32(frac) + (int32_t)(1u << (shift - 1u)));
    out[1] = q[0] | q[1] << 16;
    out[2] = q[2] | q[3] << 16;
    out[3] = (uint32_t)whole;
}

/* SHIFTED: the code a pixel with byte b reads for raw code y, min(y + b, raw_max + 64) - 64, in
 * [-WDR_CAL_SHIFT_PAD, raw_max] for any y (no clamp of y first): one add and one clamp on the
 * controller. */
static inline int32_t wdr_shifted_code(uint32_t y, uint32_t b, uint32_t raw_max)
{
    uint32_t u = y + b, top = raw_max + WDR_CAL_SHIFT_ZERO;
    return (int32_t)(u < top ? u : top) - (int32_t)WDR_CAL_SHIFT_ZERO;
}

/* acc + lo(a) lo(b) + hi(a) hi(b), signed 16-bit halves: one SMLAD on a DSP core. */
static inline int32_t wdr_smlad(uint32_t a, uint32_t b, int32_t acc)
{
#if defined(__ARM_FEATURE_DSP)
    return __smlad(a, b, acc);
#else
    return acc + (int32_t)(int16_t)a * (int16_t)b + (int32_t)(int16_t)(a >> 16) * (int16_t)(b >> 16);
#endif
}

/* frac(y) + sum_k q_k P_k(y) of a pixel's two coefficient words c and its code's point p. */
static inline int32_t wdr_compact_dot(const uint32_t *c, const uint32_t *p)
{
    return wdr_smlad(c[0], p[1], wdr_smlad(c[1], p[2], (int32_t)p[0]));
}

/* The output before clamping: int(y) + (dot >> F) (arithmetic shift, GCC and clang). */
static inline int32_t wdr_compact_value(const uint32_t *c, const uint32_t *p, uint32_t shift)
{
    return (int32_t)p[3] + (wdr_compact_dot(c, p) >> shift);
}

#endif
