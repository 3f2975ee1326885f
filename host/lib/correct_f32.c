/* The host's float path of the correction (simulator studies, calibration metrics, reports):
 * wdr_correct_row_f32, the formulas of firmware/correct_inline.h on unquantised codes. The
 * controller only ever sees integer codes (firmware/correct.c). */
#include "correct.h"
#include "correct_inline.h"
#include "correct_v4.h"
#include "wdr_err.h"
#include <string.h>

typedef void row_f32_fn(const wdr_cal_view *cal, int row, const float *raw, float *out);

static void identity_f32(const wdr_cal_view *cal, int row, const float *raw, float *out)
{
    (void)row;
    const float s = cal->h.out_scale, m = (float)cal->h.out_max;
    const int w = cal->h.width;
    for (int i = 0; i < w; i++)
        out[i] = wdr_to_output(raw[i], s, m);
}

static void moebius_f32(const wdr_cal_view *cal, int row, const float *raw, float *out)
{
    const float *p = wdr_cal_row_coeffs(cal, row, 0), *q = wdr_cal_row_coeffs(cal, row, 1),
                *r = wdr_cal_row_coeffs(cal, row, 2);
    const float s = cal->h.out_scale, m = (float)cal->h.out_max;
    const int w = cal->h.width;
    for (int i = 0; i < w; i++)
        out[i] = wdr_to_output(wdr_moebius(raw[i], p[i], q[i], r[i]), s, m);
}

static inline void poly_f32_n(const wdr_cal_view *cal, int row, const float *raw, float *out, const int n)
{
    const float *c[WDR_CAL_MAX_COEFFS];
    wdr_row_planes(cal, row, c, n);
    const float s = cal->h.out_scale, m = (float)cal->h.out_max, a = cal->h.in_scale, b = cal->h.in_offset;
    const int w = cal->h.width;
    for (int i = 0; i < w; i++)
        out[i] = wdr_to_output(wdr_poly(c, i, raw[i] * a + b, n), s, m);
}
WDR_CORRECT_BY_N(poly_by_n, poly_f32_n, float, float);

#ifdef WDR_CORRECT_V4
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

/* The host's studies run this on whole frames, hence four pixels at a time where it can. */
static inline void basis_f32_n(const wdr_cal_view *cal, int row, const float *raw, float *out, const int n)
{
    const float *c[WDR_CAL_MAX_COEFFS];
    wdr_row_planes(cal, row, c, n);
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
        int j = wdr_basis_point(raw[i], a, b, last, &f);
        out[i] = wdr_to_output(wdr_basis_sum(c, i, shared, j, f, n), s, m);
    }
}
WDR_CORRECT_BY_N(basis_by_n, basis_f32_n, float, float);

/* COMPACT between codes: the controller's integer values at floor(y) and the code above, before
 * the rounding (int(y) + (dot - 2^(F-1)) 2^-F), interpolated in float; y is clamped to
 * [0, raw_max] first (NaN to 0). */
static float compact_exact(const uint32_t *c, const uint32_t *p, int32_t half, float unit)
{
    return (float)(int32_t)p[3] + (float)(wdr_compact_dot(c, p) - half) * unit;
}

static void compact_f32(const wdr_cal_view *cal, int row, const float *raw, float *out)
{
    const uint32_t *c = wdr_cal_row_compact(cal, row);
    const uint32_t shift = wdr_compact_shift(cal), top = cal->h.raw_max;
    const int32_t half = (int32_t)(1u << (shift - 1u));
    const float unit = 1.0f / (float)(1u << shift), m = (float)cal->h.out_max;
    float g[WDR_CAL_COMPACT_COEFFS];
    wdr_compact_gains(cal, shift, g);
    const uint8_t *b = cal->h.form == WDR_FORM_SHIFTED ? wdr_cal_row_flags(cal, row) : NULL;
    for (int i = 0; i < cal->h.width; i++) {
        float y = raw[i] > 0.0f ? raw[i] : 0.0f;
        y = y < (float)top ? y : (float)top;
        uint32_t y0 = (uint32_t)y, y1 = y0 < top ? y0 + 1u : top, p0[WDR_CAL_COMPACT_POINT_WORDS],
                 p1[WDR_CAL_COMPACT_POINT_WORDS];
        /* SHIFTED: both codes read through the pixel's shift, as the controller reads them */
        wdr_compact_point(cal, g, shift, b ? wdr_shifted_code(y0, b[i], top) : (int32_t)y0, p0);
        wdr_compact_point(cal, g, shift, b ? wdr_shifted_code(y1, b[i], top) : (int32_t)y1, p1);
        float a0 = compact_exact(c + 2 * i, p0, half, unit), a1 = compact_exact(c + 2 * i, p1, half, unit);
        out[i] = wdr_to_output(a0 + (y - (float)y0) * (a1 - a0), 1.0f, m);
    }
}

static void patch_f32(const uint8_t *f, int w, uint8_t mask, float *out)
{
    for (int s = 0; s < w; s++) {
        if (!(f[s] & mask))
            continue;
        int e = s;
        while (e < w && (f[e] & mask))
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

static row_f32_fn *kernel_for(const wdr_cal_view *cal)
{
    const int n = cal->h.n_coeffs - 2;
    switch (cal->h.form) {
    case WDR_FORM_IDENTITY: return identity_f32;
    case WDR_FORM_MOEBIUS: return moebius_f32;
    case WDR_FORM_POLY: return poly_by_n[n];
    case WDR_FORM_BASIS: return basis_by_n[n];
    default: return compact_f32; /* wdr_correct_row_ok admits no other form */
    }
}

int wdr_correct_row_f32(const wdr_cal_view *cal, int row, const float *raw, float *out)
{
    if (!wdr_correct_row_ok(cal, row, raw, out))
        return WDR_E_INVAL;
    kernel_for(cal)(cal, row, raw, out);
    if (cal->h.form != WDR_FORM_IDENTITY && cal->h.bad_pixels)
        patch_f32(wdr_cal_row_flags(cal, row), cal->h.width, wdr_cal_flag_mask(cal->h.form), out);
    return WDR_OK;
}
