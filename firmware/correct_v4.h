/* Four pixels at a time, for hosts with 4-float vectors (SSE2, AArch64 NEON) and GCC/clang vector
 * extensions: the simulated board's firmware (correct.c) and the host's float path
 * (host/lib/correct_f32.c). The Cortex-M7 has one FPU and no float SIMD, so it never compiles
 * this: WDR_CORRECT_V4 stays undefined there and the plain loops run. Every lane does the plain
 * loop's float operations in its order, so both give the same bits. WDR_CORRECT_SCALAR forces the
 * plain loops (a test runs them on the host, so the controller's own loops are checked too). */
#ifndef WDR_CORRECT_V4_H
#define WDR_CORRECT_V4_H
#include "correct_inline.h"
#include <string.h>

#if !defined(WDR_CORRECT_SCALAR) && defined(__has_builtin) && (defined(__SSE2__) || defined(__aarch64__))
#if __has_builtin(__builtin_shufflevector) && __has_builtin(__builtin_convertvector)
#define WDR_CORRECT_V4 1
#endif
#endif

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

/* wdr_to_output of four lanes; the masks map NaN to 0 as the comparisons do. */
static inline wdr_v4f v4_output(wdr_v4f v, float s, float m)
{
    const wdr_v4f zero = {0.0f, 0.0f, 0.0f, 0.0f}, top = {m, m, m, m};
    v *= (wdr_v4f){s, s, s, s};
    v = (wdr_v4f)((wdr_v4i)v & (v > zero));
    wdr_v4i below = v < top;
    return (wdr_v4f)(((wdr_v4i)v & below) | ((wdr_v4i)top & ~below));
}

/* wdr_to_output and the rounding of four lanes. */
static inline void v4_store_u16(wdr_v4f v, float s, float m, uint16_t *out)
{
    const wdr_v4f half = {0.5f, 0.5f, 0.5f, 0.5f};
    wdr_v4u16 q = __builtin_convertvector(__builtin_convertvector(v4_output(v, s, m) + half, wdr_v4i), wdr_v4u16);
    memcpy(out, &q, sizeof q);
}

/* wdr_basis_point for four codes: the same float operations lane by lane, so the same points and
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

/* wdr_basis_sum for four pixels at codes y: both points' sums by code_dot4 (the order
 * wdr_basis_sum adds in), then the same interpolation per lane, so the results are its to the bit. */
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
#endif

#endif
