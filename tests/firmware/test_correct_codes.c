/* The BASIS kernel with one point per raw code (wdr_correct_per_code), as the firmware activates
 * it: its points are the shared block interpolated at each code, every pixel is exactly the
 * documented dot product (even k, then odd k, summed), and the frame matches the interpolating
 * kernel within the output rounding, flagged pixels and codes above raw_max included; the
 * interpolating kernel is exactly its own documented formula too. Built twice: with the host's
 * four-lane loops, and with WDR_CORRECT_SCALAR (the Cortex-M7's loops), so both agree to the bit. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "correct.h"
#include "wdr_err.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define W 1027 /* not a multiple of four: the plain loop finishes every row */
#define H 5
#define K 50   /* shared points: t(0) < 0 clamps, t(raw_max) just below the last point, so the
                  codes above raw_max are clamped by the per-code kernel alone */
#define RAW_MAX 4095u
#define CODES (RAW_MAX + 1u)

static uint32_t lcg_state;
static float lcg(float lo, float hi)
{
    lcg_state = lcg_state * 1664525u + 1013904223u;
    return lo + (hi - lo) * (float)(lcg_state >> 8) / 16777216.0f;
}

typedef struct table {
    uint8_t *buf;
    size_t len;
    wdr_cal_view v;
    float shared[K * WDR_CAL_MAX_COEFFS];
} table;

/* A BASIS table of n coefficients with arbitrary basis values and coefficients; pixel flags on a
 * few pixels, one of them at the row start (patched from the right only). */
static void make_basis(table *t, int n)
{
    float *coeffs = malloc(sizeof(float) * (size_t)n * W * H);
    uint8_t *flags = calloc((size_t)W * H, 1);
    assert_non_null(coeffs);
    assert_non_null(flags);
    lcg_state = 12345u + (uint32_t)n;
    for (int j = 0; j < K * n; j++)
        t->shared[j] = lcg(-2.0f, 3.0f);
    for (int j = 0; j < n * W * H; j++)
        coeffs[j] = lcg(0.0f, 40.0f);
    flags[0] = flags[W + 500] = flags[W + 501] = flags[3 * W + W - 1] = WDR_PIX_DEAD;
    wdr_cal_header hd = {.sensor_id = 7, .width = W, .height = H, .form = WDR_FORM_BASIS, .n_coeffs = (uint16_t)n,
                         .model = WDR_MODEL_SPLINE, .in_scale = (K - 1 + 2.49f) / (float)RAW_MAX, .in_offset = -2.5f,
                         .out_scale = 16.0f, .out_max = 65535, .raw_max = RAW_MAX, .bad_pixels = 4, .shared_points = K};
    t->len = wdr_cal_size_basis(W, H, (uint16_t)n, K);
    t->buf = aligned_alloc(64, (t->len + 63) & ~(size_t)63);
    assert_non_null(t->buf);
    wdr_cal_encode_basis(&hd, t->shared, coeffs, flags, t->buf);
    assert_int_equal(wdr_cal_parse(t->buf, t->len, &t->v), WDR_OK);
    free(coeffs);
    free(flags);
}

/* Row r's codes: every code over the rows, some above raw_max (no ADC makes them; the per-code
 * kernel gives them raw_max's value). */
static void raw_row(int r, uint16_t *raw)
{
    for (int i = 0; i < W; i++)
        raw[i] = (uint16_t)((i * 4 + r) % (CODES + 8u));
    raw[7] = 65535;
}

/* B_k(t(y)) in double, from the stored block, as wdr_cal.h defines it. */
static double basis_at(const table *t, int n, int k, uint32_t y)
{
    double pos = (double)y * t->v.h.in_scale + t->v.h.in_offset;
    pos = fmin(fmax(pos, 0.0), K - 1);
    int j = (int)fmin(floor(pos), K - 2);
    double f = pos - j;
    return t->shared[j * n + k] + f * (t->shared[(j + 1) * n + k] - t->shared[j * n + k]);
}

static void points_are_interpolated_basis(const table *t, const wdr_cal_view *pc, int n)
{
    assert_int_equal(pc->h.shared_points, CODES);
    assert_true(pc->h.in_scale == 1.0f && pc->h.in_offset == 0.0f);
    for (uint32_t y = 0; y < CODES; y++)
        for (int k = 0; k < n; k++)
            assert_true(fabs(pc->shared[y * (uint32_t)n + (uint32_t)k] - basis_at(t, n, k, y)) < 1e-5);
}

/* sum_k c_k p_k as correct.c adds it: even k, odd k, then their sum. */
static float dot(const wdr_cal_view *v, int row, int i, const float *p)
{
    float even = 0.0f, odd = 0.0f;
    for (int k = 0; k < v->h.n_coeffs; k++) {
        float term = wdr_cal_row_coeffs(v, row, k)[i] * p[k];
        if (k & 1)
            odd += term;
        else
            even += term;
    }
    return even + odd;
}

static uint16_t to_code(const wdr_cal_view *v, float x)
{
    x *= v->h.out_scale;
    x = x > 0.0f ? x : 0.0f;
    x = x < (float)v->h.out_max ? x : (float)v->h.out_max;
    return (uint16_t)(x + 0.5f);
}

/* The per-code kernel's pixel: the code's point (codes above raw_max take raw_max's); the same
 * float operations as correct.c, so equality is exact. */
static uint16_t dot_pixel(const wdr_cal_view *pc, int row, int i, uint16_t y)
{
    return to_code(pc, dot(pc, row, i, pc->shared + (y < RAW_MAX ? y : RAW_MAX) * (uint32_t)pc->h.n_coeffs));
}

/* The interpolating kernel's pixel (wdr_cal.h): t clamped to [0, K-1], the sums at the two
 * points around it, then the interpolation; the same float operations as correct.c. */
static uint16_t interp_pixel(const wdr_cal_view *v, int row, int i, uint16_t y)
{
    const float last = (float)(v->h.shared_points - 1u);
    float t = (float)y * v->h.in_scale + v->h.in_offset;
    t = t > 0.0f ? t : 0.0f;
    t = t < last ? t : last;
    int j = (int)t;
    j = j < (int)last ? j : (int)last - 1;
    float f = t - (float)j;
    const float *p0 = v->shared + j * v->h.n_coeffs;
    float a = dot(v, row, i, p0), b = dot(v, row, i, p0 + v->h.n_coeffs);
    return to_code(v, a + f * (b - a));
}

/* wdr_correct_row_f32's pixel (unflagged): the same formula without the rounding to a code. */
static float interp_value(const wdr_cal_view *v, int row, int i, float y)
{
    const float last = (float)(v->h.shared_points - 1u);
    float t = y * v->h.in_scale + v->h.in_offset;
    t = t > 0.0f ? t : 0.0f; /* NaN goes to 0 here */
    t = t < last ? t : last;
    int j = (int)t;
    j = j < (int)last ? j : (int)last - 1;
    float f = t - (float)j;
    const float *p0 = v->shared + j * v->h.n_coeffs;
    float a = dot(v, row, i, p0), b = dot(v, row, i, p0 + v->h.n_coeffs), x = (a + f * (b - a)) * v->h.out_scale;
    x = x > 0.0f ? x : 0.0f;
    return x < (float)v->h.out_max ? x : (float)v->h.out_max;
}

/* Unquantised codes (host studies): fractions, negatives, NaN and Inf; every n, exact. */
static void f32_kernel_is_its_formula(void **state)
{
    (void)state;
    static float raw[W], out[W];
    for (int n = 2; n <= (int)WDR_CAL_MAX_COEFFS; n++) {
        static table t;
        make_basis(&t, n);
        for (int r = 0; r < H; r++) {
            for (int i = 0; i < W; i++)
                raw[i] = (float)((i * 4 + r) % (CODES + 8u)) + 0.37f * (float)(i % 3);
            raw[5] = -3.0f, raw[9] = NAN, raw[10] = INFINITY, raw[11] = -INFINITY;
            assert_int_equal(wdr_correct_row_f32(&t.v, r, raw, out), WDR_OK);
            const uint8_t *fl = wdr_cal_row_flags(&t.v, r);
            for (int i = 0; i < W; i++)
                if (!fl[i])
                    assert_true(out[i] == interp_value(&t.v, r, i, raw[i]));
        }
        free(t.buf);
    }
}

static void per_code_matches_the_interpolating_kernel(void **state)
{
    (void)state;
    static uint16_t raw[W], clamped[W], slow[W], fast[W];
    static float points[CODES * WDR_CAL_MAX_COEFFS];
    for (int n = 2; n <= (int)WDR_CAL_MAX_COEFFS; n++) {
        static table t;
        make_basis(&t, n);
        wdr_cal_view pc = t.v;
        assert_int_equal(wdr_correct_per_code(&pc, points, CODES * (size_t)n), WDR_OK);
        points_are_interpolated_basis(&t, &pc, n);
        int differ = 0;
        for (int r = 0; r < H; r++) {
            raw_row(r, raw);
            for (int i = 0; i < W; i++) /* the interpolating kernel would carry t past raw_max */
                clamped[i] = raw[i] < RAW_MAX ? raw[i] : (uint16_t)RAW_MAX;
            assert_int_equal(wdr_correct_row(&t.v, r, clamped, slow), WDR_OK);
            assert_int_equal(wdr_correct_row(&pc, r, raw, fast), WDR_OK);
            const uint8_t *fl = wdr_cal_row_flags(&pc, r);
            for (int i = 0; i < W; i++) {
                if (!fl[i]) {
                    assert_int_equal(fast[i], dot_pixel(&pc, r, i, raw[i]));
                    assert_int_equal(slow[i], interp_pixel(&t.v, r, i, clamped[i]));
                }
                assert_true(abs((int)fast[i] - (int)slow[i]) <= 1); /* float rounding, then to a code */
                differ += fast[i] != slow[i];
            }
        }
        assert_true(differ < W * H / 100); /* off by one only where the rounding splits */
        free(t.buf);
    }
}

/* Flagged pixels take their neighbours' corrected values: a run and a row end are patched
 * from the per-code results exactly as the interpolating kernel patches its own. */
static void per_code_patches_flagged_pixels(void **state)
{
    (void)state;
    static uint16_t raw[W], out[W];
    static float points[CODES * WDR_CAL_MAX_COEFFS];
    static table t;
    make_basis(&t, 8);
    wdr_cal_view pc = t.v;
    assert_int_equal(wdr_correct_per_code(&pc, points, sizeof points / sizeof points[0]), WDR_OK);
    raw_row(1, raw);
    assert_int_equal(wdr_correct_row(&pc, 1, raw, out), WDR_OK);
    uint16_t fill = (uint16_t)(((uint32_t)dot_pixel(&pc, 1, 499, raw[499]) + dot_pixel(&pc, 1, 502, raw[502]) + 1u) / 2u);
    assert_int_equal(out[500], fill);
    assert_int_equal(out[501], fill);
    raw_row(0, raw);
    assert_int_equal(wdr_correct_row(&pc, 0, raw, out), WDR_OK);
    assert_int_equal(out[0], dot_pixel(&pc, 0, 1, raw[1]));
    raw_row(3, raw);
    assert_int_equal(wdr_correct_row(&pc, 3, raw, out), WDR_OK);
    assert_int_equal(out[W - 1], dot_pixel(&pc, 3, W - 2, raw[W - 2]));
    free(t.buf);
}

/* Too small a buffer or another form leaves the view as it was, still interpolating. */
static void per_code_refusals_leave_the_view(void **state)
{
    (void)state;
    static float points[CODES * 4];
    static table t;
    make_basis(&t, 4);
    wdr_cal_view pc = t.v;
    assert_int_equal(wdr_correct_per_code(&pc, points, CODES * 4 - 1), WDR_E_TOO_LARGE);
    assert_memory_equal(&pc, &t.v, sizeof pc);
    assert_int_equal(wdr_correct_per_code(&pc, NULL, CODES * 4), WDR_E_INVAL);
    assert_int_equal(wdr_correct_per_code(NULL, points, CODES * 4), WDR_E_INVAL);
    wdr_cal_view id;
    assert_int_equal(wdr_cal_identity(&id, 7, W, H, 16.0f, RAW_MAX, 65535), WDR_OK);
    wdr_cal_view id0 = id;
    assert_int_equal(wdr_correct_per_code(&id, points, CODES * 4), WDR_E_INVAL);
    assert_memory_equal(&id, &id0, sizeof id);
    pc.h.raw_max = 0; /* a one-code ADC has no second point */
    assert_int_equal(wdr_correct_per_code(&pc, points, CODES * 4), WDR_E_INVAL);
    assert_ptr_equal(pc.shared, t.v.shared);
    free(t.buf);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(per_code_matches_the_interpolating_kernel),
        cmocka_unit_test(per_code_patches_flagged_pixels),
        cmocka_unit_test(per_code_refusals_leave_the_view),
        cmocka_unit_test(f32_kernel_is_its_formula),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
