/* The firmware's per-pixel correction kernel: raw ADC codes in, output codes out, one branch-free
 * loop per form over the row so the compiler can vectorise it; flagged pixels are patched
 * afterwards, in a separate pass, because they are rare and a per-pixel test would slow every
 * good pixel down. One dispatch (kernel_for) picks the loop of a table's form and coefficient
 * count. The formulas live in correct_inline.h, shared with the host's float path. */
#include "correct.h"
#include "correct_inline.h"
#include "correct_v4.h"
#include "wdr_err.h"
#include <string.h>

typedef void row_fn(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out);

/* ---- IDENTITY and MOEBIUS ---- */

/* A power-of-two scale of at most 2^15 whose largest raw code fits: a shift, exact. */
static int identity_shift(const wdr_cal_view *cal)
{
    for (int k = 0; k <= 15; k++)
        if (cal->h.out_scale == (float)(1u << k))
            return ((uint32_t)cal->h.raw_max << k) <= cal->h.out_max ? k : -1;
    return -1;
}

static void identity_u16(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out)
{
    (void)row;
    const float s = cal->h.out_scale, m = (float)cal->h.out_max;
    const int w = cal->h.width, k = identity_shift(cal);
    const uint16_t top = cal->h.raw_max;
    if (k >= 0) { /* codes above raw_max cannot come from the ADC; clamp them anyway */
        for (int i = 0; i < w; i++)
            out[i] = (uint16_t)((raw[i] < top ? raw[i] : top) << k);
        return;
    }
    for (int i = 0; i < w; i++) /* w is a local: out (uint16_t) could alias the header's fields */
        out[i] = (uint16_t)(wdr_to_output((float)raw[i], s, m) + 0.5f);
}

static void moebius_u16(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out)
{
    const float *p = wdr_cal_row_coeffs(cal, row, 0), *q = wdr_cal_row_coeffs(cal, row, 1),
                *r = wdr_cal_row_coeffs(cal, row, 2);
    const float s = cal->h.out_scale, m = (float)cal->h.out_max;
    const int w = cal->h.width;
    for (int i = 0; i < w; i++)
        out[i] = (uint16_t)(wdr_to_output(wdr_moebius((float)raw[i], p[i], q[i], r[i]), s, m) + 0.5f);
}

/* ---- POLY ---- */

static inline void poly_u16_n(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out, const int n)
{
    const float *c[WDR_CAL_MAX_COEFFS];
    wdr_row_planes(cal, row, c, n);
    const float s = cal->h.out_scale, m = (float)cal->h.out_max, a = cal->h.in_scale, b = cal->h.in_offset;
    const int w = cal->h.width;
    for (int i = 0; i < w; i++)
        out[i] = (uint16_t)(wdr_to_output(wdr_poly(c, i, (float)raw[i] * a + b, n), s, m) + 0.5f);
}
WDR_CORRECT_BY_N(poly_by_n, poly_u16_n, uint16_t, uint16_t);

/* ---- BASIS, interpolating the shared block ---- */

#ifdef WDR_CORRECT_V4
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
#endif

static inline void basis_u16_n(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out, const int n)
{
    const float *c[WDR_CAL_MAX_COEFFS];
    wdr_row_planes(cal, row, c, n);
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
        int j = wdr_basis_point((float)raw[i], a, b, last, &f);
        out[i] = (uint16_t)(wdr_to_output(wdr_basis_sum(c, i, shared, j, f, n), s, m) + 0.5f);
    }
}
WDR_CORRECT_BY_N(basis_by_n, basis_u16_n, uint16_t, uint16_t);

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
    wdr_row_planes(cal, row, c, n);
    const float s = cal->h.out_scale, m = (float)cal->h.out_max, *points = cal->shared;
    const uint32_t top = cal->h.shared_points - 1u;
    const int w = cal->h.width;
    int i = 0;
#ifdef WDR_CORRECT_V4
    i = codes_u16_v4(c, points, top, s, m, w, raw, out, n);
#endif
    for (; i < w; i++)
        out[i] = (uint16_t)(wdr_to_output(code_dot(c, i, code_point(points, top, raw[i], n), n), s, m) + 0.5f);
}
WDR_CORRECT_BY_N(codes_by_n, codes_u16_n, uint16_t, uint16_t);

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
        const float *p0 = cal->shared + (size_t)wdr_basis_point((float)y, a, b, last, &f) * (size_t)n, *p1 = p0 + n;
        for (int k = 0; k < n; k++)
            points[(size_t)y * (size_t)n + (size_t)k] = p0[k] + f * (p1[k] - p0[k]);
    }
    cal->shared = points;
    cal->h.shared_points = codes;
    cal->h.in_scale = 1.0f;
    cal->h.in_offset = 0.0f;
    return WDR_OK;
}

/* ---- COMPACT: int16 coefficients, fixed-point points per code (correct_inline.h) ---- */

/* Output code of a pixel's value (wdr_compact_value): negative gives 0, then clamped to out_max.
 * bits (a literal): out_max is 2^bits - 1, one USAT does both clamps on the controller; 0: any. */
static inline uint16_t compact_output(int32_t v, int32_t out_max, const int bits)
{
#if defined(__ARM_FEATURE_SAT)
    if (bits == 12)
        return (uint16_t)__usat(v, 12);
    if (bits == 16)
        return (uint16_t)__usat(v, 16);
#endif
    (void)bits;
    v &= ~(v >> 31); /* negative: 0 (one BIC) */
    return (uint16_t)(v < out_max ? v : out_max);
}

/* The controller's loop: a load of the code, its point (16 bytes), the pixel's two words, two
 * SMLAD, a shift and a saturation. Pointers walk the row so nothing is re-read from the view. */
static inline void compact_codes_bits(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out,
                                      const int bits)
{
    const uint32_t *c = wdr_cal_row_compact(cal, row), *points = cal->code_q;
    const uint32_t top = cal->h.raw_max, shift = cal->code_shift;
    const int32_t m = cal->h.out_max;
    for (const uint16_t *end = raw + cal->h.width; raw < end; c += 2) {
        uint32_t y = *raw++;
        y = y < top ? y : top;
        *out++ = compact_output(wdr_compact_value(c, points + WDR_CAL_COMPACT_POINT_WORDS * y, shift), m, bits);
    }
}

static void compact_codes_u16(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out)
{
    if (cal->h.out_max == 4095u)
        compact_codes_bits(cal, row, raw, out, 12);
    else if (cal->h.out_max == 65535u)
        compact_codes_bits(cal, row, raw, out, 16);
    else
        compact_codes_bits(cal, row, raw, out, 0);
}

/* SHIFTED: the same loop, each pixel reading its own shifted code (its byte after the words): the
 * raw code needs no clamp of its own (y + b is clamped once), and the points are addressed from
 * WDR_CAL_SHIFT_ZERO codes below code 0, so the shift costs one byte load and one add. */
/* The shifted code's clamp: sat (a literal) 13 is one USAT to 2^13 - 1 on the controller, the points
 * beyond raw_max + 64 being copies of the last; 0 a compare with top. */
static inline uint32_t shifted_clamp(uint32_t u, uint32_t top, const int sat)
{
#if defined(__ARM_FEATURE_SAT)
    if (sat == 13)
        return (uint32_t)__usat((int32_t)u, 13);
#endif
    if (sat == 13)
        return u < (1u << 13) - 1u ? u : (1u << 13) - 1u;
    return u < top ? u : top;
}

static inline void shifted_codes_bits(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out,
                                      const int bits, const int sat)
{
    const uint32_t *c = wdr_cal_row_compact(cal, row);
    const uint32_t *points = cal->code_q - WDR_CAL_COMPACT_POINT_WORDS * WDR_CAL_SHIFT_ZERO;
#if defined(__GNUC__)
    __asm__("" : "+r"(points)); /* GCC folds the offset back into every pixel's index: keep it here */
#endif
    const uint8_t *b = wdr_cal_row_flags(cal, row);
    const uint32_t top = (uint32_t)cal->h.raw_max + WDR_CAL_SHIFT_ZERO, shift = cal->code_shift;
    const int32_t m = cal->h.out_max;
    for (const uint16_t *end = raw + cal->h.width; raw < end; c += 2) {
        uint32_t u = shifted_clamp((uint32_t)*raw++ + *b++, top, sat);
        *out++ = compact_output(wdr_compact_value(c, points + WDR_CAL_COMPACT_POINT_WORDS * u, shift), m, bits);
    }
}

static void shifted_codes_u16(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out)
{
    if (cal->code_sat == WDR_CAL_SHIFT_SAT_BITS && cal->h.out_max == 4095u)
        shifted_codes_bits(cal, row, raw, out, 12, 13);
    else if (cal->code_sat == WDR_CAL_SHIFT_SAT_BITS)
        shifted_codes_bits(cal, row, raw, out, 0, 13);
    else if (cal->h.out_max == 4095u)
        shifted_codes_bits(cal, row, raw, out, 12, 0);
    else
        shifted_codes_bits(cal, row, raw, out, 0, 0);
}

/* Without the per-code points (an ADC wider than the buffer, host tools): each pixel's point is
 * computed as wdr_correct_per_code_compact would have tabulated it, so the bits are the same. */
static void compact_u16(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out)
{
    const uint32_t *c = wdr_cal_row_compact(cal, row);
    const uint32_t top = cal->h.raw_max, shift = wdr_compact_shift(cal);
    const int32_t m = cal->h.out_max;
    float g[WDR_CAL_COMPACT_COEFFS];
    wdr_compact_gains(cal, shift, g);
    const uint8_t *b = cal->h.form == WDR_FORM_SHIFTED ? wdr_cal_row_flags(cal, row) : NULL;
    for (int i = 0; i < cal->h.width; i++) {
        uint32_t p[WDR_CAL_COMPACT_POINT_WORDS], y = raw[i] < top ? raw[i] : top;
        wdr_compact_point(cal, g, shift, b ? wdr_shifted_code(raw[i], b[i], top) : (int32_t)y, p);
        out[i] = compact_output(wdr_compact_value(c + 2 * i, p, shift), m, 0);
    }
}

int wdr_correct_per_code_compact(wdr_cal_view *cal, uint32_t *points, size_t capacity)
{
    if (!cal || !points || !wdr_cal_form_compact(cal->h.form) || !cal->shared || cal->h.shared_points < 2 ||
        cal->h.n_coeffs != WDR_CAL_COMPACT_COEFFS || cal->h.raw_max == 0)
        return WDR_E_INVAL;
    const int32_t pad = cal->h.form == WDR_FORM_SHIFTED ? (int32_t)WDR_CAL_SHIFT_PAD : 0;
    const uint32_t codes = (uint32_t)cal->h.raw_max + 1u + (uint32_t)pad, sat_codes = 1u << WDR_CAL_SHIFT_SAT_BITS;
    if ((size_t)codes * WDR_CAL_COMPACT_POINT_WORDS > capacity)
        return WDR_E_TOO_LARGE;
    /* SHIFTED with room: points up to 2^13 codes, those past the last code copies of it */
    const int sat = pad && codes <= sat_codes && (size_t)sat_codes * WDR_CAL_COMPACT_POINT_WORDS <= capacity;
    const uint32_t shift = wdr_compact_shift(cal);
    float g[WDR_CAL_COMPACT_COEFFS];
    wdr_compact_gains(cal, shift, g);
    for (uint32_t j = 0; j < codes; j++)
        wdr_compact_point(cal, g, shift, (int32_t)j - pad, points + WDR_CAL_COMPACT_POINT_WORDS * j);
    for (uint32_t j = codes; sat && j < sat_codes; j++)
        for (uint32_t w = 0; w < WDR_CAL_COMPACT_POINT_WORDS; w++)
            points[WDR_CAL_COMPACT_POINT_WORDS * j + w] = points[WDR_CAL_COMPACT_POINT_WORDS * (codes - 1u) + w];
    cal->code_q = points + WDR_CAL_COMPACT_POINT_WORDS * (uint32_t)pad; /* code 0 */
    cal->code_sat = sat ? WDR_CAL_SHIFT_SAT_BITS : 0u;
    cal->code_shift = shift;
    return WDR_OK;
}

/* ---- bad pixels: each run of flagged pixels takes the mean of the good pixels around it ---- */

/* mask: the bits of a byte that mean flagged (wdr_cal_flag_mask). */
static int next_flagged(const uint8_t *f, int i, int w, uint8_t mask)
{
    const uint64_t wide = mask * 0x0101010101010101ull;
    while (i + 8 <= w) { /* most rows have no flags: skip eight at a time */
        uint64_t word;
        __builtin_memcpy(&word, f + i, 8); /* the builtin: -ffreestanding makes memcpy a call */
        if (word & wide)
            break;
        i += 8;
    }
    while (i < w && !(f[i] & mask))
        i++;
    return i;
}

static void patch_u16(const uint8_t *f, int w, uint8_t mask, uint16_t *out)
{
    for (int s = next_flagged(f, 0, w, mask); s < w; s = next_flagged(f, s, w, mask)) {
        int e = s;
        while (e < w && (f[e] & mask))
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

/* ---- the one dispatch over forms ---- */

int wdr_correct_row_ok(const wdr_cal_view *cal, int row, const void *raw, const void *out)
{
    if (!cal || !raw || !out || row < 0 || row >= cal->h.height ||
        !wdr_cal_form_coeffs_ok(cal->h.form, cal->h.n_coeffs))
        return 0;
    if (cal->h.form == WDR_FORM_IDENTITY)
        return 1;
    int shared = cal->h.form == WDR_FORM_BASIS || wdr_cal_form_compact(cal->h.form);
    return cal->payload && (!shared || (cal->shared && cal->h.shared_points >= 2));
}

static row_fn *kernel_for(const wdr_cal_view *cal)
{
    const int n = cal->h.n_coeffs - 2;
    switch (cal->h.form) {
    case WDR_FORM_IDENTITY: return identity_u16;
    case WDR_FORM_MOEBIUS: return moebius_u16;
    case WDR_FORM_POLY: return poly_by_n[n];
    case WDR_FORM_BASIS: return points_are_codes(cal) ? codes_by_n[n] : basis_by_n[n];
    case WDR_FORM_SHIFTED: return cal->code_q ? shifted_codes_u16 : compact_u16;
    default: return cal->code_q ? compact_codes_u16 : compact_u16; /* COMPACT: _ok admits no other form */
    }
}

int wdr_correct_row(const wdr_cal_view *cal, int row, const uint16_t *raw, uint16_t *out)
{
    if (!wdr_correct_row_ok(cal, row, raw, out))
        return WDR_E_INVAL;
    kernel_for(cal)(cal, row, raw, out);
    if (cal->h.form != WDR_FORM_IDENTITY && cal->h.bad_pixels)
        patch_u16(wdr_cal_row_flags(cal, row), cal->h.width, wdr_cal_flag_mask(cal->h.form), out);
    return WDR_OK;
}
