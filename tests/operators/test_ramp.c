/* The ramp generator against closed forms and against the 1 LSB promise. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "test_support.h"
#include <math.h>
#include <string.h>

static wdr_operator op; /* large (user curve storage) */

/* Paper eq. 5: Reinhard simple with V_dark = V_N0' gives V_ref(t) = V_N0' - S + t I_ref / C,
 * where I_ref maps to L = 1. Exact for the first-order pixel (no body effect, constant C). */
static void reinhard_simple_is_a_straight_ramp(void **state)
{
    (void)state;
    wdr_board b;
    wdr_ideal_pixel px;
    wdr_ramp r;
    char err[256];
    load_test_board("ideal-linear", &b);
    assert_int_equal(init_default_op(&op, &b, "reinhard"), WDR_OK);
    wdr_ideal_pixel_init(&b, &px);
    assert_int_equal(wdr_ramp_build(&px, &op, b.i_min_a, b.i_max_a, 4096, WDR_RAMP_FAIL, &r, err, sizeof err), WDR_OK);
    double i_ref = op.stats.l_avg / (op.p[0] * b.lum_per_amp), slope = i_ref / b.c_pd_f;
    assert_double_equal(i_ref, b.i_center_a, 1e-20);
    for (int j = 0; j < r.n; j += 97)
        assert_double_equal(r.v[j], px.v_dark - b.swing_v + r.t[j] * slope, 1e-9);
    assert_double_equal(r.t_end, b.c_pd_f * b.swing_v / b.i_center_a * (1.0 / (1.0 + 1e-3)), 1e-6 * r.t_end);
    wdr_ramp_free(&r);
}

static double worst_lsb_for(const char *board, const char *name, int repair)
{
    wdr_board b;
    wdr_ideal_pixel px;
    wdr_ramp r;
    wdr_lut_view v;
    uint8_t *bytes;
    size_t len;
    char err[256];
    load_test_board(board, &b);
    if (strcmp(name, "user"))
        assert_int_equal(init_default_op(&op, &b, name), WDR_OK);
    wdr_ideal_pixel_init(&b, &px);
    assert_int_equal(wdr_ramp_build(&px, &op, b.i_min_a, b.i_max_a, 8192, repair, &r, err, sizeof err), WDR_OK);
    assert_int_equal(wdr_ramp_quantise(&r, &b, &op, WDR_TIMING_STAMPED, 0, &bytes, &len, err, sizeof err), WDR_OK);
    assert_int_equal(wdr_lut_parse(bytes, len, &v), WDR_OK);
    double worst = wdr_ramp_lut_worst_error_lsb(&px, &op, &v, b.i_min_a, b.i_max_a, 3001, NULL);
    printf("  %-18s on %-12s %5u entries, worst %.3f LSB\n", name, board, v.h.entry_count, worst);
    wdr_ramp_free(&r);
    free(bytes);
    return worst;
}

static void every_operator_within_one_lsb(void **state)
{
    (void)state;
    for (int id = 0; id < WDR_OP_COUNT; id++) {
        const char *name = wdr_operator_info_by_id(id)->name;
        if (id == WDR_OP_USER_CURVE || id == WDR_OP_LINEAR)
            continue;
        assert_true(worst_lsb_for("sim-vga", name, WDR_RAMP_FAIL) <= 1.0);
    }
    /* linear is exactly realisable only on the first-order pixel (one vertical step) */
    assert_true(worst_lsb_for("ideal-linear", "linear", WDR_RAMP_FAIL) <= 1.0);
}

static void user_curve_within_one_lsb(void **state)
{
    (void)state;
    char path[] = "/tmp/wdr_curveXXXXXX", err[256];
    int fd = mkstemp(path);
    FILE *f = fdopen(fd, "w");
    fprintf(f, "luminance,display\n");
    for (int k = -3; k <= 3; k++) /* a log-like curve over six decades, 7 knots */
        fprintf(f, "%g,%g\n", pow(10, k), pow((k + 4) / 7.0, 1.2));
    fclose(f);
    wdr_board b;
    load_test_board("sim-vga", &b);
    assert_int_equal(init_default_op(&op, &b, "user"), WDR_OK);
    assert_int_equal(wdr_operator_load_curve(&op, path, err, sizeof err), WDR_OK);
    assert_true(worst_lsb_for("sim-vga", "user", WDR_RAMP_FAIL) <= 1.0);
    remove(path);
}

/* A linear response has t* constant: the ramp collapses to one step, an ordinary pixel. */
static void linear_collapses_to_one_step(void **state)
{
    (void)state;
    wdr_board b;
    wdr_ideal_pixel px;
    wdr_ramp r;
    wdr_lut_view v;
    uint8_t *bytes;
    size_t len;
    char err[256];
    load_test_board("ideal-linear", &b);
    assert_int_equal(init_default_op(&op, &b, "linear"), WDR_OK);
    wdr_ideal_pixel_init(&b, &px);
    assert_int_equal(wdr_ramp_build(&px, &op, b.i_min_a, b.i_max_a, 1024, WDR_RAMP_FAIL, &r, err, sizeof err), WDR_OK);
    assert_int_equal(wdr_ramp_quantise(&r, &b, &op, WDR_TIMING_STAMPED, 0, &bytes, &len, err, sizeof err), WDR_OK);
    assert_int_equal(wdr_lut_parse(bytes, len, &v), WDR_OK);
    assert_int_equal(v.h.entry_count, 2);
    wdr_ramp_free(&r);
    free(bytes);
}

static int build_status(const char *name, const char *param, double l_avg, int policy, wdr_ramp *r, char *err)
{
    wdr_board b;
    wdr_ideal_pixel px;
    load_test_board("sim-vga", &b);
    assert_int_equal(init_default_op(&op, &b, name), WDR_OK);
    if (l_avg > 0)
        op.stats.l_avg = l_avg;
    if (param)
        assert_int_equal(wdr_operator_set_param(&op, param, err, 256), WDR_OK);
    wdr_ideal_pixel_init(&b, &px);
    return wdr_ramp_build(&px, &op, b.i_min_a, b.i_max_a, 4096, policy, r, err, 256);
}

/* Drago (bias 0.85) turns down before L_max once L_max/L_avg exceeds ~2e5. */
static void drago_high_range_fails_or_repairs_visibly(void **state)
{
    (void)state;
    wdr_ramp r;
    char err[256];
    assert_int_equal(build_status("drago", NULL, 1000.0 / 1e5, WDR_RAMP_FAIL, &r, err), WDR_OK);
    wdr_ramp_free(&r);
    assert_int_equal(build_status("drago", NULL, 1000.0 / 1e6, WDR_RAMP_FAIL, &r, err), WDR_E_UNREALISABLE);
    assert_non_null(strstr(err, "drago is not realisable for photocurrents"));
    assert_int_equal(build_status("drago", NULL, 1000.0 / 1e6, WDR_RAMP_REPAIR, &r, err), WDR_OK);
    assert_true(r.repaired && r.bad_i_lo > 1e-10 && r.bad_i_hi <= 1e-8 && r.repair_max_dev_v > 0);
    for (int j = 1; j < r.n; j++)
        assert_true(r.t[j] >= r.t[j - 1] && r.v[j] >= r.v[j - 1]);
    wdr_ramp_free(&r);
}

/* Tumblin-Rushmeier: exponent > 1 when the world adaptation exceeds the display's. */
static void tumblin_rushmeier_expanding_fails(void **state)
{
    (void)state;
    wdr_ramp r;
    char err[256];
    assert_int_equal(build_status("tumblin_rushmeier", "l_wa=1", 0, WDR_RAMP_FAIL, &r, err), WDR_OK);
    wdr_ramp_free(&r);
    assert_int_equal(build_status("tumblin_rushmeier", "l_wa=100", 0, WDR_RAMP_FAIL, &r, err), WDR_E_UNREALISABLE);
    assert_non_null(strstr(err, "t*(I) rises"));
}

static void uniform_clock_error_falls_with_entries(void **state)
{
    (void)state;
    wdr_board b;
    wdr_ideal_pixel px;
    wdr_ramp r;
    char err[256];
    double prev = INFINITY;
    load_test_board("sim-vga", &b);
    assert_int_equal(init_default_op(&op, &b, "reinhard"), WDR_OK);
    wdr_ideal_pixel_init(&b, &px);
    assert_int_equal(wdr_ramp_build(&px, &op, b.i_min_a, b.i_max_a, 8192, WDR_RAMP_FAIL, &r, err, sizeof err), WDR_OK);
    for (uint32_t n = 256; n <= 65536; n *= 4) {
        uint8_t *bytes;
        size_t len;
        wdr_lut_view v;
        assert_int_equal(wdr_ramp_quantise(&r, &b, &op, WDR_TIMING_UNIFORM, n, &bytes, &len, err, sizeof err), WDR_OK);
        assert_int_equal(wdr_lut_parse(bytes, len, &v), WDR_OK);
        double w = wdr_ramp_lut_worst_error_lsb(&px, &op, &v, b.i_min_a, b.i_max_a, 1001, NULL);
        printf("  uniform %6u entries: worst %.2f LSB\n", n, w);
        assert_true(w < prev);
        prev = w;
        free(bytes);
    }
    wdr_ramp_free(&r);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(reinhard_simple_is_a_straight_ramp),
        cmocka_unit_test(every_operator_within_one_lsb),
        cmocka_unit_test(user_curve_within_one_lsb),
        cmocka_unit_test(linear_collapses_to_one_step),
        cmocka_unit_test(drago_high_range_fails_or_repairs_visibly),
        cmocka_unit_test(tumblin_rushmeier_expanding_fails),
        cmocka_unit_test(uniform_clock_error_falls_with_entries),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
