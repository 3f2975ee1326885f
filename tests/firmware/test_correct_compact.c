/* The COMPACT form (format 1.2) against its documented formula (firmware/SPEC.md): the encoder's
 * int16 quantisation, the fixed-point kernel with and without its per-code points (same bits),
 * the host's float path between codes, and tables crafted to the limits (coefficients of -32768,
 * huge scales) that must stay inside int32 (UBSan) and inside [0, out_max]. */
#include "correct.h"
#include "crc32.h"
#include "wdr_lut.h"
#include "wdr_cal.h"
#include "wdr_err.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define W 37
#define H 3
#define K 256u
#define RAW_MAX 4095u

typedef struct table {
    uint8_t *buf;
    size_t len;
    wdr_cal_view v;
    float shared[K * 4], coeffs[4 * W * H];
    uint8_t flags[W * H];
} table;

/* B0 the identity in codes, B1..B3 smooth bends; c0 about 1, the others a few codes. form SHIFTED:
 * the pixel bytes give every shift from -64 to 63 across the table, and pixel 5 is flagged. */
static void build_form(table *t, float out_scale, uint16_t out_max, uint16_t form)
{
    for (uint32_t j = 0; j < K; j++)
        for (int k = 0; k < 4; k++) {
            float x = (float)j / (K - 1);
            t->shared[j * 4 + k] = k == 0 ? x * RAW_MAX : 20.0f * sinf(3.0f * k * x);
        }
    for (int i = 0; i < W * H; i++) {
        t->flags[i] = form == WDR_FORM_SHIFTED ? (uint8_t)(i == 5 ? WDR_CAL_SHIFT_FLAGGED | WDR_PIX_HOT : (unsigned)(i * 23) % 128u)
                                               : 0;
        for (int k = 0; k < 4; k++)
            t->coeffs[k * W * H + i] = k == 0 ? 0.97f + 0.0013f * (float)i : 0.5f * (float)((i * (k + 3)) % 11) - 2.0f;
    }
    wdr_cal_header h = {.sensor_id = 7,
                        .width = W,
                        .height = H,
                        .model = WDR_MODEL_SPLINE,
                        .in_scale = (float)(K - 1) / RAW_MAX,
                        .out_scale = out_scale,
                        .out_max = out_max,
                        .raw_max = RAW_MAX,
                        .form = form,
                        .bad_pixels = form == WDR_FORM_SHIFTED,
                        .shared_points = K};
    t->len = wdr_cal_size_compact(W, H, K);
    t->buf = aligned_alloc(8, (t->len + 7) & ~(size_t)7);
    wdr_cal_encode_compact(&h, t->shared, t->coeffs, t->flags, t->buf);
    assert_int_equal(wdr_cal_parse(t->buf, t->len, &t->v), WDR_OK);
    assert_int_equal(t->v.h.version_minor, form == WDR_FORM_SHIFTED ? 3 : 2);
    assert_int_equal(t->v.h.form, form);
}

static void build(table *t, float out_scale, uint16_t out_max)
{
    build_form(t, out_scale, out_max, WDR_FORM_COMPACT);
}

/* v of SPEC.md in double, from the table's own int16, scales and offsets. */
static double formula(const wdr_cal_view *v, int row, int col, double y)
{
    const float *s = wdr_cal_compact_scales(v), *o = s + 4;
    const int16_t *q = (const int16_t *)(const void *)wdr_cal_row_compact(v, row) + 4 * col;
    double t = fmin(fmax(y * v->h.in_scale + v->h.in_offset, 0), v->h.shared_points - 1.0);
    int j = (int)t < (int)v->h.shared_points - 1 ? (int)t : (int)v->h.shared_points - 2;
    double f = t - j, sum = 0;
    for (int k = 0; k < 4; k++) {
        double b = v->shared[j * 4 + k] + f * (v->shared[(j + 1) * 4 + k] - v->shared[j * 4 + k]);
        sum += ((double)o[k] + q[k] * (double)s[k]) * b;
    }
    return sum * v->h.out_scale;
}

static void kernel_follows_the_formula(void **state)
{
    (void)state;
    static const struct {
        float scale;
        uint16_t max;
    } outs[] = {{1.0f, 4095}, {16.0f, 65535}, {3.3f, 20000}};
    for (size_t o = 0; o < sizeof outs / sizeof outs[0]; o++) {
        table t;
        build(&t, outs[o].scale, outs[o].max);
        static uint32_t points[4 * (RAW_MAX + 1)];
        wdr_cal_view pc = t.v;
        assert_int_equal(wdr_correct_per_code_compact(&pc, points, 4 * RAW_MAX), WDR_E_TOO_LARGE);
        assert_int_equal(wdr_correct_per_code_compact(&pc, points, sizeof points / sizeof points[0]), WDR_OK);
        double worst = 0, worst_f32 = 0;
        for (int r = 0; r < H; r++)
            for (uint32_t y0 = 0; y0 <= RAW_MAX + 7; y0 += W) {
                uint16_t raw[W], slow[W], fast[W];
                float rawf[W], outf[W];
                for (int c = 0; c < W; c++)
                    raw[c] = (uint16_t)(y0 + (uint32_t)c), rawf[c] = (float)raw[c] + 0.25f;
                assert_int_equal(wdr_correct_row(&t.v, r, raw, slow), WDR_OK);
                assert_int_equal(wdr_correct_row(&pc, r, raw, fast), WDR_OK);
                assert_memory_equal(slow, fast, sizeof slow); /* per-code points: the same bits */
                assert_int_equal(wdr_correct_row_f32(&t.v, r, rawf, outf), WDR_OK);
                for (int c = 0; c < W; c++) {
                    double y = raw[c] > RAW_MAX ? RAW_MAX : raw[c];
                    double want = fmin(fmax(formula(&t.v, r, c, y), 0), outs[o].max);
                    worst = fmax(worst, fabs(fast[c] - want));
                    double yf = fmin(rawf[c], RAW_MAX);
                    double want_f = fmin(fmax(formula(&t.v, r, c, yf), 0), outs[o].max);
                    worst_f32 = fmax(worst_f32, fabs(outf[c] - want_f));
                }
            }
        /* rounding to a code (0.5), plus the fixed point: each P_k is rounded to 2^-F, a term errs by at
         * most |q| 2^-(F+1) <= 2^14 2^-F, and F leaves at least 2^13 steps to the largest |P|, here
         * about 0.01 codes a term (out_scale codes per raw code) */
        printf("  out_scale %g: worst |kernel - formula| %.4f codes, float path %.4f\n", (double)outs[o].scale, worst,
               worst_f32);
        assert_true(worst <= 0.5 + 0.05 * outs[o].scale);
        assert_true(worst_f32 <= 0.05 * outs[o].scale);
        free(t.buf);
    }
}

/* SHIFTED: pixel i reads code min(y + b_i, raw_max + 64) - 64 of the same formula, with and without
 * the per-code points (same bits, the points reaching 64 codes below 0); the float path reads both
 * codes around y through the shift; the flagged pixel takes its neighbours' mean. */
static void shifted_kernel_follows_the_formula(void **state)
{
    (void)state;
    table t;
    build_form(&t, 1.0f, 4095, WDR_FORM_SHIFTED);
    static uint32_t points[4 * 8192], points_cmp[4 * (RAW_MAX + 1 + WDR_CAL_SHIFT_PAD)];
    wdr_cal_view pc = t.v, pc_cmp = t.v; /* points to 2^13 codes (one USAT), and just enough (a compare) */
    assert_int_equal(wdr_correct_per_code_compact(&pc, points, 4 * (RAW_MAX + 1)), WDR_E_TOO_LARGE);
    assert_int_equal(wdr_correct_per_code_compact(&pc, points, sizeof points / sizeof points[0]), WDR_OK);
    assert_int_equal(pc.code_sat, 13);
    assert_int_equal(wdr_correct_per_code_compact(&pc_cmp, points_cmp, sizeof points_cmp / sizeof points_cmp[0]),
                     WDR_OK);
    assert_int_equal(pc_cmp.code_sat, 0);
    double worst = 0, worst_f32 = 0;
    for (int r = 0; r < H; r++) {
        const uint8_t *b = wdr_cal_row_flags(&t.v, r);
        for (uint32_t y0 = 0; y0 <= RAW_MAX + 7; y0 += W) {
            uint16_t raw[W], slow[W], fast[W], cmp[W];
            float rawf[W], outf[W];
            for (int c = 0; c < W; c++) /* the last rows: raw codes far past raw_max (8191 and beyond) */
                raw[c] = (uint16_t)(y0 + (uint32_t)c + (y0 > RAW_MAX - W ? 4000u * (uint32_t)r : 0u)),
                rawf[c] = (float)raw[c] + 0.25f;
            assert_int_equal(wdr_correct_row(&t.v, r, raw, slow), WDR_OK);
            assert_int_equal(wdr_correct_row(&pc, r, raw, fast), WDR_OK);
            assert_int_equal(wdr_correct_row(&pc_cmp, r, raw, cmp), WDR_OK);
            assert_memory_equal(slow, fast, sizeof slow);
            assert_memory_equal(slow, cmp, sizeof slow);
            assert_int_equal(wdr_correct_row_f32(&t.v, r, rawf, outf), WDR_OK);
            for (int c = 0; c < W; c++) {
                if (b[c] & WDR_CAL_SHIFT_FLAGGED) {
                    assert_int_equal(fast[c], (fast[c - 1] + fast[c + 1] + 1) / 2);
                    continue;
                }
                double u = fmin((double)raw[c] + b[c], RAW_MAX + 64.0) - 64.0; /* raw not clamped first */
                worst = fmax(worst, fabs(fast[c] - fmin(fmax(formula(&t.v, r, c, u), 0), 4095)));
                if (u + 1 <= RAW_MAX && rawf[c] < RAW_MAX) {
                    double want_f = fmin(fmax(formula(&t.v, r, c, u + 0.25), 0), 4095);
                    worst_f32 = fmax(worst_f32, fabs(outf[c] - want_f));
                }
            }
        }
    }
    printf("  shifted: worst |kernel - formula| %.4f codes, float path %.4f\n", worst, worst_f32);
    assert_true(worst <= 0.55);
    assert_true(worst_f32 <= 0.05);
    /* a flag count that ignores the shift bytes' meaning is refused: count 0 against 1 flagged */
    wdr_put_u32(t.buf + 40, 0);
    wdr_put_u32(t.buf + 60, wdr_crc32(0, t.buf, WDR_CAL_HEADER_SIZE - 4));
    assert_int_equal(wdr_cal_parse(t.buf, t.len, &pc), WDR_E_INVAL);
    free(t.buf);
}

/* The encoder keeps the spread: a pixel's dequantised coefficient is within half a step. */
static void quantisation_within_half_a_step(void **state)
{
    (void)state;
    table t;
    build(&t, 1.0f, 4095);
    const float *s = wdr_cal_compact_scales(&t.v), *o = s + 4;
    for (int r = 0; r < H; r++) {
        const int16_t *q = (const int16_t *)(const void *)wdr_cal_row_compact(&t.v, r);
        for (int c = 0; c < W; c++)
            for (int k = 0; k < 4; k++) {
                double c_k = t.coeffs[k * W * H + r * W + c], back = o[k] + q[4 * c + k] * (double)s[k];
                assert_true(fabs(back - c_k) <= 0.5 * s[k] * 1.001 + 1e-6 * fabs(c_k));
            }
    }
    free(t.buf);
}

/* Every stored int16 at -32768 and scales far too large: outputs clamp, nothing overflows. */
static void extremes_stay_in_range(void **state)
{
    (void)state;
    table t;
    build(&t, 16.0f, 65535);
    float *s = (float *)(void *)(t.buf + WDR_CAL_HEADER_SIZE) + K * 4;
    for (int k = 0; k < 4; k++)
        s[k] = 1e30f, s[4 + k] = -1e30f; /* scales, offsets: parse would refuse the CRC, so use the view */
    uint8_t *rows = t.buf + WDR_CAL_HEADER_SIZE + (K * 4 + 8) * 4;
    for (int r = 0; r < H; r++)
        for (int i = 0; i < 8 * W; i += 2)
            rows[r * t.v.row_stride + i] = 0x00, rows[r * t.v.row_stride + i + 1] = 0x80;
    t.v.shared = (const float *)(const void *)(t.buf + WDR_CAL_HEADER_SIZE);
    static uint32_t points[4 * (RAW_MAX + 1)];
    wdr_cal_view pc = t.v;
    assert_int_equal(wdr_correct_per_code_compact(&pc, points, sizeof points / sizeof points[0]), WDR_OK);
    uint16_t raw[W], a[W], b[W];
    float rawf[W], outf[W];
    for (uint32_t y0 = 0; y0 <= RAW_MAX; y0 += 97) {
        for (int c = 0; c < W; c++)
            raw[c] = (uint16_t)(y0 + (uint32_t)c * 3), rawf[c] = (float)raw[c];
        assert_int_equal(wdr_correct_row(&t.v, 1, raw, a), WDR_OK);
        assert_int_equal(wdr_correct_row(&pc, 1, raw, b), WDR_OK);
        assert_memory_equal(a, b, sizeof a);
        assert_int_equal(wdr_correct_row_f32(&t.v, 1, rawf, outf), WDR_OK);
        for (int c = 0; c < W; c++)
            assert_true(outf[c] >= 0 && outf[c] <= 65535);
    }
    free(t.buf);
}

/* A changed payload sealed again (payload CRC at 56, header CRC at 60), as a buggy builder would. */
static void reseal(uint8_t *buf)
{
    wdr_put_u32(buf + 56, wdr_crc32(0, buf + WDR_CAL_HEADER_SIZE, wdr_get_u32(buf + 52)));
    wdr_put_u32(buf + 60, wdr_crc32(0, buf, WDR_CAL_HEADER_SIZE - 4));
}

/* The parser's checks for the form: a zero, negative or NaN scale and a NaN offset
 * (WDR_E_NUMERIC), a coefficient count other than 4 and shared points beyond 1024 (WDR_E_INVAL). */
static void parser_refuses_bad_compact_tables(void **state)
{
    (void)state;
    table t;
    build(&t, 1.0f, 4095);
    wdr_cal_view v;
    float *extra = (float *)(void *)(t.buf + WDR_CAL_HEADER_SIZE) + K * 4;
    const float bad[] = {0.0f, -1.0f, NAN};
    for (int i = 0; i < 4; i++) {
        float keep = extra[i == 3 ? 5 : 1];
        extra[i == 3 ? 5 : 1] = i == 3 ? NAN : bad[i];
        reseal(t.buf);
        assert_int_equal(wdr_cal_parse(t.buf, t.len, &v), WDR_E_NUMERIC);
        extra[i == 3 ? 5 : 1] = keep;
    }
    reseal(t.buf);
    assert_int_equal(wdr_cal_parse(t.buf, t.len, &v), WDR_OK);
    wdr_put_u16(t.buf + 18, 5); /* n_coeffs */
    reseal(t.buf);
    assert_int_equal(wdr_cal_parse(t.buf, t.len, &v), WDR_E_INVAL);
    wdr_put_u16(t.buf + 18, 4);
    wdr_put_u32(t.buf + 44, 1025); /* shared_points: 1025 * 4 floats exceed the 16 KiB block */
    reseal(t.buf);
    assert_int_equal(wdr_cal_parse(t.buf, t.len, &v), WDR_E_INVAL);
    free(t.buf);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(kernel_follows_the_formula),
        cmocka_unit_test(quantisation_within_half_a_step),
        cmocka_unit_test(extremes_stay_in_range),
        cmocka_unit_test(parser_refuses_bad_compact_tables),
        cmocka_unit_test(shifted_kernel_follows_the_formula),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
