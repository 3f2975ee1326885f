/* The calibration maths on exact synthetic data: closed forms, pivoted solvers, the stable
 * quadratic, the monotone curve, and the table format with its firmware kernel. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "cal_test_support.h"
#include "crc32.h"

static void simple3_closed_form_exact(void **state)
{
    (void)state;
    wdr_simple3 truth = {3100, 2600, 0.9, 0, 1e-11}, m = {.x_scale = 1e-11};
    double u[3] = {0.01, 1, 100}, y[3];
    for (int k = 0; k < 3; k++)
        y[k] = wdr_simple3_eval(&truth, u[k]);
    assert_int_equal(wdr_simple3_fit3(u, y, &m), WDR_FIT_OK);
    assert_double_equal(m.a, truth.a, 1e-8);
    assert_double_equal(m.b, truth.b, 1e-8);
    assert_double_equal(m.c, truth.c, 1e-12);
}

static void simple3_dark_parameter(void **state)
{
    (void)state;
    /* an exact model passes through the dark reading already: d = 0 and inversion is exact */
    wdr_simple3 truth = {3100, 2600, 0.9, 3e-5, 1e-11}, m = {.x_scale = 1e-11};
    double u[3] = {0.01, 1, 100}, y[3];
    for (int k = 0; k < 3; k++)
        y[k] = wdr_simple3_eval(&truth, u[k]);
    assert_int_equal(wdr_simple3_fit_dark(u, y, 0, wdr_simple3_eval(&truth, 0), &m), WDR_FIT_OK);
    assert_double_equal(m.d, 0, 1e-10);
    double back;
    assert_int_equal(wdr_simple3_invert(&m, wdr_simple3_eval(&truth, 0.002), 1e3, &back), WDR_FIT_OK);
    assert_double_equal(back, 0.002, 1e-9);
    /* a dark reading 1 code off moves the zero of the current scale by eq. 20 */
    assert_int_equal(wdr_simple3_fit_dark(u, y, 0, wdr_simple3_eval(&truth, 0) - 1, &m), WDR_FIT_OK);
    assert_double_equal(m.d, 1 / 2600.0, 1e-6);
    assert_int_equal(wdr_simple3_fit_dark(u, y, 0, y[0] - 1, &m), WDR_FIT_REVERSED);
}

static void complex4_linear_system_exact(void **state)
{
    (void)state;
    /* a, b, c, e -> P = a, Q = ac - b, R = be, S = c */
    double a = 3100, b = 2000, c = 0.8, e = 1e-4;
    wdr_complex4 truth = {a, a * c - b, b * e, c, 0, 1e-11, 0}, m = {.x_scale = 1e-11};
    double u[4] = {0.01, 0.3, 10, 300}, y[4];
    for (int k = 0; k < 4; k++)
        y[k] = wdr_complex4_eval(&truth, u[k]);
    assert_int_equal(wdr_complex4_fit4(u, y, &m), WDR_FIT_OK);
    assert_double_equal(m.p, truth.p, 1e-6);
    assert_double_equal(m.s, truth.s, 1e-9);
    for (double uu = 0.001; uu < 500; uu *= 3.7) {
        double back;
        int clamped;
        assert_int_equal(wdr_complex4_invert(&m, wdr_complex4_eval(&truth, uu), 1e6, &back, &clamped), WDR_FIT_OK);
        assert_false(clamped);
        assert_double_equal(back / uu, 1, 1e-7);
    }
}

static void lu_refuses_singular(void **state)
{
    (void)state;
    double a[9] = {1, 2, 3, 2, 4, 6, 1, 0, 1}, b[3] = {1, 2, 3}, x[3], rcond;
    assert_int_equal(wdr_lu_solve(a, b, 3, 0, x, &rcond), WDR_FIT_ILL_COND);
    double a2[9] = {0, 2, 1, 1, 0, 0, 0, 1, 3}, b2[3] = {5, 1, 7}; /* needs a row swap */
    assert_int_equal(wdr_lu_solve(a2, b2, 3, 0, x, &rcond), WDR_FIT_OK);
    assert_double_equal(x[0], 1, 1e-12);
    assert_double_equal(x[1], 1.6, 1e-12);
    assert_double_equal(x[2], 1.8, 1e-12);
}

static void qr_least_squares_line(void **state)
{
    (void)state;
    /* y = 2 + 3 t with weights: exact data, any weights give the same line */
    double a[2 * 6], y[6], w[6], c[2], rcond;
    for (int i = 0; i < 6; i++) {
        a[2 * i] = 1, a[2 * i + 1] = i * 1e-3;
        y[i] = 2 + 3 * i * 1e-3;
        w[i] = 1.0 + i;
    }
    assert_int_equal(wdr_lsq_solve(a, y, w, 6, 2, c, &rcond), WDR_FIT_OK);
    assert_double_equal(c[0], 2, 1e-12);
    assert_double_equal(c[1], 3, 1e-9);
}

/* Columns 320 decades apart: their squares would underflow and overflow; the fit still finds the
 * line, since the columns are equilibrated before the reflections' plain sums of squares. */
static void qr_least_squares_extreme_columns(void **state)
{
    (void)state;
    double a[2 * 6], y[6], c[2], rcond;
    for (int i = 0; i < 6; i++) {
        a[2 * i] = 1e-160, a[2 * i + 1] = 1e160 * i * 1e-3;
        y[i] = 2 + 3 * i * 1e-3;
    }
    assert_int_equal(wdr_lsq_solve(a, y, NULL, 6, 2, c, &rcond), WDR_FIT_OK);
    assert_double_equal(c[0] / 2e160, 1, 1e-12);
    assert_double_equal(c[1] / 3e-160, 1, 1e-9);
}

static void quadratic_root_without_cancellation(void **state)
{
    (void)state;
    double t;
    int clamped;
    /* r tiny: the textbook formula loses every digit; the physical root is -c/b to first order */
    assert_int_equal(wdr_quadratic_root(1e-18, 1.0, -2.0, &t, &clamped), WDR_FIT_OK);
    assert_double_equal(t, 2.0 - 4e-18, 1e-15);
    /* r = 0 exactly: linear */
    assert_int_equal(wdr_quadratic_root(0, 4, -2, &t, &clamped), WDR_FIT_OK);
    assert_double_equal(t, 0.5, 0);
    /* negative discriminant: clamped and told */
    assert_int_equal(wdr_quadratic_root(1, 0.1, 1, &t, &clamped), WDR_FIT_OK);
    assert_true(clamped && isfinite(t));
    assert_int_equal(wdr_quadratic_root(0, 0, 1, &t, &clamped), WDR_FIT_FLAT);
}

static void monotone_curve_stays_monotone(void **state)
{
    (void)state;
    double lx[6] = {0, 1, 2, 3, 4, 5}, y[6] = {100, 99.9, 60, 10, 9.99, 9.98};
    wdr_pchip p;
    assert_int_equal(wdr_pchip_init(&p, lx, y, 6), WDR_OK);
    double prev = INFINITY;
    for (double t = -1; t <= 6; t += 0.01) {
        double v = wdr_pchip_eval(&p, t);
        assert_true(v < prev);
        prev = v;
        /* backward error at rounding level; forward error bounded where the tangent is flat */
        double back = wdr_pchip_invert(&p, v);
        assert_double_equal(wdr_pchip_eval(&p, back), v, 1e-12 * (1 + fabs(v)));
        assert_double_equal(back, t, 1e-6);
    }
}

/* A 4x3 MOEBIUS table with one flagged pixel. */
static uint8_t *small_table(size_t *len, uint8_t flag_pixel)
{
    float coeffs[3 * 12];
    uint8_t flags[12] = {0};
    for (int i = 0; i < 12; i++) {
        coeffs[i] = 1.0f + 0.01f * i;  /* p */
        coeffs[12 + i] = -2.0f;        /* q */
        coeffs[24 + i] = 1e-5f;        /* r */
    }
    flags[5] = flag_pixel;
    wdr_cal_header h = {.sensor_id = 7, .width = 4, .height = 3, .form = WDR_FORM_MOEBIUS, .n_coeffs = 3,
                        .model = WDR_MODEL_SIMPLE3, .in_scale = 1, .out_scale = 16, .out_max = 65535,
                        .raw_max = 4095, .bad_pixels = flag_pixel ? 1 : 0};
    *len = wdr_cal_size(4, 3, 3);
    uint8_t *buf = aligned_alloc(8, (*len + 7) & ~(size_t)7);
    wdr_cal_encode(&h, coeffs, flags, buf);
    return buf;
}

static void table_round_trip_and_kernel(void **state)
{
    (void)state;
    size_t len;
    uint8_t *buf = small_table(&len, WDR_PIX_DEAD);
    wdr_cal_view v;
    assert_int_equal(wdr_cal_parse(buf, len, &v), WDR_OK);
    assert_int_equal(wdr_cal_check_geometry(&v, 7, 4, 3), WDR_OK);
    assert_int_equal(wdr_cal_check_geometry(&v, 7, 4, 4), WDR_E_GEOMETRY);
    uint16_t raw[4] = {1000, 1000, 1000, 1000}, out[4];
    assert_int_equal(wdr_correct_row(&v, 1, raw, out), WDR_OK);
    /* pixel 4: (1.04*1000 - 2) / (1e-5*1000 + 1) * 16 */
    assert_int_equal(out[0], (uint16_t)((1.04f * 1000 - 2) / (1e-5f * 1000 + 1) * 16 + 0.5f));
    /* pixel 5 is flagged: mean of its neighbours 4 and 6 */
    assert_int_equal(out[1], (out[0] + out[2] + 1) / 2);
    float rawf[4] = {NAN, INFINITY, -5, 1e30f}, outf[4];
    assert_int_equal(wdr_correct_row_f32(&v, 0, rawf, outf), WDR_OK);
    for (int i = 0; i < 4; i++)
        assert_true(isfinite(outf[i]) && outf[i] >= 0 && outf[i] <= 65535);
    assert_int_equal(wdr_correct_row(&v, 3, raw, out), WDR_E_INVAL);
    free(buf);
}

static void table_damage_refused(void **state)
{
    (void)state;
    size_t len;
    wdr_cal_view v;
    uint8_t *buf = small_table(&len, 0);
    assert_int_equal(wdr_cal_parse(buf, len - 1, &v), WDR_E_TRUNCATED);
    assert_int_equal(wdr_cal_parse(buf, 10, &v), WDR_E_TRUNCATED);
    assert_int_equal(wdr_cal_parse(buf + 1, len - 1, &v), WDR_E_INVAL); /* misaligned */
    buf[WDR_CAL_HEADER_SIZE + 3] ^= 0x40;
    assert_int_equal(wdr_cal_parse(buf, len, &v), WDR_E_CORRUPT);
    free(buf);
    buf = small_table(&len, 0);
    buf[4] = 9; /* major version; header CRC recomputed so only the version is wrong */
    wdr_put_u32(buf + 60, wdr_crc32(0, buf, 60));
    assert_int_equal(wdr_cal_parse(buf, len, &v), WDR_E_VERSION);
    free(buf);
}

/* A NaN or a vanishing Moebius denominator is refused even with good CRCs. */
static void table_bad_numbers_refused(void **state)
{
    (void)state;
    float coeffs[3 * 2] = {1, 1, 0, 0, 0, -1.0f / 1000};
    uint8_t flags[2] = {0};
    wdr_cal_header h = {.sensor_id = 1, .width = 2, .height = 1, .form = WDR_FORM_MOEBIUS, .n_coeffs = 3,
                        .in_scale = 1, .out_scale = 1, .out_max = 65535, .raw_max = 4095};
    size_t len = wdr_cal_size(2, 1, 3);
    uint8_t *buf = aligned_alloc(8, (len + 7) & ~(size_t)7);
    wdr_cal_view v;
    wdr_cal_encode(&h, coeffs, flags, buf);
    assert_int_equal(wdr_cal_parse(buf, len, &v), WDR_E_NUMERIC); /* r*y+1 = 0 at y = 1000 */
    coeffs[5] = 0;
    coeffs[0] = NAN;
    wdr_cal_encode(&h, coeffs, flags, buf);
    assert_int_equal(wdr_cal_parse(buf, len, &v), WDR_E_NUMERIC);
    free(buf);
}

/* A 3x1 BASIS table over K = 3 points at codes 0, 1000, 2000 (in_scale 1e-3): B0 = 1, 2, 4 and
 * B1 = 0, 10, 0, so v = c0 B0(t) + c1 B1(t) is known by hand at every code. */
static uint8_t *basis_table(size_t *len, const float *shared, uint32_t points)
{
    float coeffs[2 * 3] = {100, 200, 300, 1, 2, 3};
    uint8_t flags[3] = {0};
    wdr_cal_header h = {.sensor_id = 3, .width = 3, .height = 1, .form = WDR_FORM_BASIS, .n_coeffs = 2,
                        .model = WDR_MODEL_SPLINE, .in_scale = 1e-3f, .in_offset = 0, .out_scale = 1,
                        .out_max = 65535, .raw_max = 4095, .shared_points = points};
    *len = wdr_cal_size_basis(3, 1, 2, points);
    uint8_t *buf = aligned_alloc(8, (*len + 7) & ~(size_t)7);
    wdr_cal_encode_basis(&h, shared, coeffs, flags, buf);
    return buf;
}

static void basis_table_round_trip_and_kernel(void **state)
{
    (void)state;
    static const float shared[3 * 2] = {1, 0, 2, 10, 4, 0}; /* point-major: (B0, B1) per point */
    size_t len;
    wdr_cal_view v;
    uint8_t *buf = basis_table(&len, shared, 3);
    assert_int_equal(wdr_get_u16(buf + 6), 1); /* the minor version that added the form */
    assert_int_equal(wdr_cal_parse(buf, len, &v), WDR_OK);
    assert_non_null(v.shared);
    assert_int_equal(v.h.shared_points, 3);
    uint16_t raw[3] = {500, 1000, 4000}, out[3];
    assert_int_equal(wdr_correct_row(&v, 0, raw, out), WDR_OK);
    assert_int_equal(out[0], 100 * 1.5 + 1 * 5);   /* halfway between points 0 and 1 */
    assert_int_equal(out[1], 200 * 2 + 2 * 10);    /* on point 1 */
    assert_int_equal(out[2], 300 * 4 + 3 * 0);     /* beyond the last point: clamped to it */
    float rawf[3] = {NAN, -INFINITY, 1500}, outf[3];
    assert_int_equal(wdr_correct_row_f32(&v, 0, rawf, outf), WDR_OK);
    assert_double_equal(outf[0], 100 * 1, 1e-3); /* NaN lands on point 0 */
    assert_double_equal(outf[1], 200 * 1, 1e-3);
    assert_double_equal(outf[2], 300 * 3 + 3 * 5, 1e-3);
    free(buf);
}

/* NaN or Inf in the shared block, a basis function zero everywhere, or a point count out of
 * range is refused with good CRCs; so is a shared count on another form. */
static void basis_table_bad_shared_refused(void **state)
{
    (void)state;
    float shared[3 * 2] = {1, 0, 2, 10, 4, 0};
    size_t len;
    wdr_cal_view v;
    uint8_t *buf;
    shared[3] = NAN;
    buf = basis_table(&len, shared, 3);
    assert_int_equal(wdr_cal_parse(buf, len, &v), WDR_E_NUMERIC);
    free(buf);
    shared[3] = INFINITY;
    buf = basis_table(&len, shared, 3);
    assert_int_equal(wdr_cal_parse(buf, len, &v), WDR_E_NUMERIC);
    free(buf);
    shared[3] = 0; /* B1 = 0, 0, 0: degenerate */
    buf = basis_table(&len, shared, 3);
    assert_int_equal(wdr_cal_parse(buf, len, &v), WDR_E_NUMERIC);
    free(buf);
    shared[3] = 10;
    buf = basis_table(&len, shared, 1); /* one point: no interval to interpolate in */
    assert_int_equal(wdr_cal_parse(buf, len, &v), WDR_E_INVAL);
    free(buf);
    float *big = calloc(2 * 2049, sizeof(float));
    for (int j = 0; j < 2 * 2049; j++)
        big[j] = 1;
    buf = basis_table(&len, big, 2049); /* 4098 floats: above the 16 KiB a firmware holds */
    assert_int_equal(wdr_cal_parse(buf, len, &v), WDR_E_INVAL);
    free(buf);
    free(big);
    buf = small_table(&len, 0); /* a Moebius table naming shared points */
    wdr_put_u32(buf + 44, 3);
    wdr_put_u32(buf + 60, wdr_crc32(0, buf, 60));
    assert_int_equal(wdr_cal_parse(buf, len, &v), WDR_E_INVAL);
    free(buf);
}

static void identity_without_table(void **state)
{
    (void)state;
    wdr_cal_view v;
    assert_int_equal(wdr_cal_identity(&v, 1, 3, 2, 16.0f, 4095, 65535), WDR_OK);
    uint16_t raw[3] = {0, 1000, 4095}, out[3];
    assert_int_equal(wdr_correct_row(&v, 1, raw, out), WDR_OK);
    assert_int_equal(out[0], 0);
    assert_int_equal(out[1], 16000);
    assert_int_equal(out[2], 65520);
    assert_int_equal(wdr_cal_identity(&v, 1, 0, 2, 16.0f, 4095, 65535), WDR_E_INVAL);
    assert_int_equal(wdr_cal_identity(&v, 1, 3, 2, NAN, 4095, 65535), WDR_E_INVAL);
}

/* A source whose frame k holds k + pixel index: the engine must average frames per level. */
static int counting_capture(void *ctx, double amps, int frame_no, float *frame)
{
    int *calls = ctx;
    (*calls)++;
    for (int i = 0; i < 6; i++)
        frame[i] = (float)(frame_no + i + (amps > 0 ? 1000 : 0));
    return WDR_OK;
}

static void engine_averages_each_level(void **state)
{
    (void)state;
    int calls = 0;
    wdr_cal_source src = {3, 2, counting_capture, &calls};
    double amps[2] = {1e-12, 1e-10};
    wdr_cal_levels lv;
    char err[256];
    assert_int_equal(wdr_cal_acquire(&src, amps, 2, 4, 1, NULL, NULL, &lv, err, sizeof err), WDR_OK);
    assert_int_equal(calls, 12);
    /* dark: frames 0..3, level 0: frames 4..7, level 1: frames 8..11 */
    assert_double_equal(lv.dark[0], 1.5, 1e-6);
    assert_double_equal(lv.frames[0], 1000 + 5.5, 1e-6);
    assert_double_equal(lv.frames[6 + 5], 1000 + 9.5 + 5, 1e-6);
    wdr_cal_levels_free(&lv);
    double bad[2] = {1e-10, 1e-12};
    assert_int_equal(wdr_cal_acquire(&src, bad, 2, 4, 1, NULL, NULL, &lv, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "above the one before"));
}

/* The calibration margin continues the ramp past its last code, one entry per code. */
static void lut_margin_extends_the_ramp(void **state)
{
    (void)state;
    uint32_t ticks[20];
    uint16_t codes[20];
    for (int i = 0; i < 20; i++)
        ticks[i] = (uint32_t)(i * 100), codes[i] = (uint16_t)(1000 + i);
    wdr_lut_header h = {.operator_id = WDR_OP_REINHARD, .dac_bits = 12, .timing = WDR_TIMING_STAMPED,
                        .entry_count = 20, .tick_ps = 1000, .t_integration_ticks = 2000, .dac_lo_v = 0,
                        .dac_hi_v = 4.095f};
    size_t len = wdr_lut_size(20), out_len;
    uint8_t *buf = malloc(len), *out;
    wdr_lut_encode(&h, ticks, codes, buf);
    double added, done;
    char err[256];
    assert_int_equal(wdr_cal_lut_extend(buf, len, 0.010, 1.0, &out, &out_len, &added, &done, err, sizeof err),
                     WDR_OK);
    wdr_lut_view v;
    assert_int_equal(wdr_lut_parse(out, out_len, &v), WDR_OK);
    assert_int_equal(v.h.entry_count, 30); /* 10 mV at 1 mV per code */
    assert_double_equal(done, 0.010, 1e-6);
    uint32_t t;
    uint16_t c;
    wdr_lut_entry(&v, 29, &t, &c);
    assert_int_equal(c, 1029);
    assert_int_equal(t, 2900);
    assert_true(added > 0);
    free(out);
    /* a flat end cannot be continued */
    for (int i = 0; i < 20; i++)
        codes[i] = 1000;
    wdr_lut_encode(&h, ticks, codes, buf);
    assert_int_equal(wdr_cal_lut_extend(buf, len, 0.010, 1.0, &out, &out_len, &added, &done, err, sizeof err),
                     WDR_E_INVAL);
    free(buf);
}

/* Pool-adjacent-violators on a falling sequence: reversals pooled into their weighted mean, a
 * falling sequence untouched; the tolerance from measured noise: tie + k sigma sqrt(2/M). */
static void isotonic_pools_reversals(void **state)
{
    (void)state;
    double y[6] = {10, 6, 7, 2, 3, 1}, w[6] = {1, 1, 1, 1, 3, 1}, out[6];
    wdr_cal_isotonic_falling(y, w, 6, out);
    double want[6] = {10, 6.5, 6.5, 2.75, 2.75, 1};
    for (int k = 0; k < 6; k++)
        assert_double_equal(out[k], want[k], 1e-12);
    double f[4] = {9, 5, 5, 1}, g[4];
    wdr_cal_isotonic_falling(f, w, 4, g);
    for (int k = 0; k < 4; k++)
        assert_double_equal(g[k], f[k], 0);
    wdr_cal_levels lv = {.n = 2, .amps = {1e-12, 2e-12}, .noise = {1.0, 1.0}, .m_avg = 4};
    wdr_cal_config cfg;
    wdr_cal_config_defaults(&cfg, WDR_MODEL_SPLINE);
    assert_double_equal(wdr_cal_tie_tolerance(&lv, &cfg, 1), 0.5 + 5 * sqrt(2.0 / 4), 1e-12);
    lv.m_avg = 0; /* not measured: the quantisation tie alone */
    assert_double_equal(wdr_cal_tie_tolerance(&lv, &cfg, 1), 0.5, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(isotonic_pools_reversals),
        cmocka_unit_test(simple3_closed_form_exact),   cmocka_unit_test(simple3_dark_parameter),
        cmocka_unit_test(complex4_linear_system_exact), cmocka_unit_test(lu_refuses_singular),
        cmocka_unit_test(qr_least_squares_line),       cmocka_unit_test(qr_least_squares_extreme_columns),
        cmocka_unit_test(quadratic_root_without_cancellation),
        cmocka_unit_test(monotone_curve_stays_monotone), cmocka_unit_test(table_round_trip_and_kernel),
        cmocka_unit_test(table_damage_refused),        cmocka_unit_test(table_bad_numbers_refused),
        cmocka_unit_test(basis_table_round_trip_and_kernel), cmocka_unit_test(basis_table_bad_shared_refused),
        cmocka_unit_test(identity_without_table),      cmocka_unit_test(engine_averages_each_level),
        cmocka_unit_test(lut_margin_extends_the_ramp),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
