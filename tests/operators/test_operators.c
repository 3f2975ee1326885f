/* Operator curves, parameters and scene statistics: shapes, bounds and clear refusals. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "test_support.h"
#include <math.h>
#include <string.h>
#include <unistd.h>

static wdr_operator op;
static char err[512];

static void setup_op(const char *name)
{
    wdr_board b;
    load_test_board("sim-vga", &b);
    assert_int_equal(init_default_op(&op, &b, name), WDR_OK);
}

/* Every operator: T in [0,1], finite, non-decreasing over 8 decades around the range. */
static void curves_are_bounded_and_monotone(void **state)
{
    (void)state;
    for (int id = 0; id < WDR_OP_COUNT; id++) {
        if (id == WDR_OP_USER_CURVE)
            continue;
        setup_op(wdr_operator_info_by_id(id)->name);
        double prev = 0;
        for (int k = 0; k <= 800; k++) {
            double t = wdr_operator_eval(&op, pow(10, -4 + k / 100.0));
            assert_true(isfinite(t) && t >= 0 && t <= 1.0 + 1e-12);
            assert_true(t >= prev - 1e-12);
            prev = t;
        }
        assert_true(wdr_operator_eval(&op, 0) == 0 && wdr_operator_eval(&op, -1) == 0);
        assert_true(isfinite(wdr_operator_eval(&op, NAN)) && isfinite(wdr_operator_eval(&op, INFINITY)));
    }
}

static void known_values(void **state)
{
    (void)state;
    setup_op("reinhard");
    double l_w = op.stats.l_avg / 0.18; /* scaled L = 1 */
    assert_double_equal(wdr_operator_eval(&op, l_w), 0.5, 1e-12);
    setup_op("exponential");
    assert_double_equal(wdr_operator_eval(&op, op.stats.l_avg), 1 - exp(-1), 1e-12);
    setup_op("logarithmic");
    assert_double_equal(wdr_operator_eval(&op, op.stats.l_max), 1.0, 1e-12);
    setup_op("schlick");
    assert_double_equal(wdr_operator_eval(&op, op.stats.l_max), 1.0, 1e-12);
    setup_op("drago");
    assert_double_equal(wdr_operator_eval(&op, op.stats.l_max), 1.0, 1e-12);
    setup_op("reinhard_white");
    assert_double_equal(wdr_operator_eval(&op, op.stats.l_max), 1.0, 1e-12);
}

static void expect_param_error(const char *name, const char *kv, const char *needle)
{
    setup_op(name);
    assert_int_equal(wdr_operator_set_param(&op, kv, err, sizeof err), WDR_E_INVAL);
    if (!strstr(err, needle))
        fail_msg("message '%s' lacks '%s'", err, needle);
}

static void bad_parameters_are_named(void **state)
{
    (void)state;
    expect_param_error("reinhard", "key=-0.5", "key = -0.5");
    expect_param_error("schlick", "p=0.5", "p = 0.5");
    expect_param_error("reinhard", "key=nan", "key = nan");
    expect_param_error("reinhard", "key=inf", "key = inf");
    expect_param_error("drago", "bias=abc", "'abc' is not a number");
    expect_param_error("drago", "colour=1", "no parameter 'colour'");
    expect_param_error("drago", "bias", "expected key=value");
    wdr_lum_stats st = {1, 1, 1};
    assert_int_equal(wdr_operator_init(&op, "mantiuk", &st, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "unknown operator 'mantiuk'"));
    setup_op("reinhard");
    op.stats.l_avg = NAN;
    assert_int_equal(wdr_operator_validate(&op, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "L_avg"));
}

static int load_curve_text(const char *text)
{
    char path[] = "/tmp/wdr_curveXXXXXX";
    int fd = mkstemp(path);
    FILE *f = fdopen(fd, "w");
    fputs(text, f);
    fclose(f);
    setup_op("user");
    int rc = wdr_operator_load_curve(&op, path, err, sizeof err);
    remove(path);
    return rc;
}

static void bad_user_curves_are_refused(void **state)
{
    (void)state;
    assert_int_equal(load_curve_text(""), WDR_E_INVAL);
    assert_non_null(strstr(err, "at least 2 rows"));
    assert_int_equal(load_curve_text("luminance,display\n1,0.1\n0.5,0.2\n"), WDR_E_INVAL);
    assert_non_null(strstr(err, "not monotone"));
    assert_int_equal(load_curve_text("luminance,display\n1,0.5\n2,0.4\n"), WDR_E_INVAL);
    assert_non_null(strstr(err, "not monotone"));
    assert_int_equal(load_curve_text("luminance,display\n1,nan\n2,0.4\n"), WDR_E_INVAL);
    assert_non_null(strstr(err, ":2: field 'display'"));
    assert_int_equal(load_curve_text("luminance,display\n1,0.1\n2,1.5\n"), WDR_E_INVAL);
    assert_int_equal(load_curve_text("luminance,display\n-1,0.1\n2,0.5\n"), WDR_E_INVAL);
    assert_non_null(strstr(err, "field 'luminance'"));
    assert_int_equal(load_curve_text("luminance,display\n1,0.2\n10,0.2\n"), WDR_E_INVAL);
    assert_int_equal(load_curve_text("luminance,display\n1,0.1\n10,0.6\n100,0.9\n"), WDR_OK);
    assert_double_equal(wdr_operator_eval(&op, sqrt(10)), 0.35, 1e-12); /* linear in ln L */
    setup_op("user");
    assert_int_equal(wdr_operator_validate(&op, err, sizeof err), WDR_E_INVAL);
    assert_int_equal(wdr_operator_load_curve(&op, "/nonexistent/curve.csv", err, sizeof err), WDR_E_IO);
    assert_non_null(strstr(err, "/nonexistent/curve.csv"));
}

/* Log-average with the guard: zero, negative and non-finite pixels do not poison it. */
static void scene_stats_are_guarded(void **state)
{
    (void)state;
    wdr_lum_stats s;
    float lum[6] = {1.0f, 100.0f, 0.0f, -0.01f, NAN, INFINITY};
    assert_int_equal(wdr_lum_stats_measure(lum, 6, &s), 4);
    assert_true(isfinite(s.l_avg) && s.l_avg > 0 && s.l_max == 100.0 && s.l_min > 0);
    float flat[3] = {2, 2, 2};
    assert_int_equal(wdr_lum_stats_measure(flat, 3, &s), 3);
    assert_double_equal(s.l_avg, 2.0, 1e-9);
    float dark[2] = {0, -1};
    assert_int_equal(wdr_lum_stats_measure(dark, 2, &s), WDR_E_INVAL);
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    fputs(text, f);
    fclose(f);
}

static void bad_board_fields_are_named(void **state)
{
    (void)state;
    wdr_board b;
    char path[] = "/tmp/wdr_boardXXXXXX";
    close(mkstemp(path));
    write_text(path, "{\"photodiode\": {\"c_pd_F\": 0}}");
    wdr_board_defaults(&b);
    assert_int_equal(wdr_board_load(path, &b, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "photodiode.c_pd_F"));
    assert_non_null(strstr(err, "value 0"));
    write_text(path, "{\"photodiode\": {\"c_pd_F\": -1e-15}}");
    assert_int_equal(wdr_board_load(path, &b, err, sizeof err), WDR_E_INVAL);
    write_text(path, "{\"dac\": {\"bitz\": 12}}");
    assert_int_equal(wdr_board_load(path, &b, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "dac.bitz': unknown field"));
    write_text(path, "{\"dac\": {\"timing\": \"fast\"}}");
    assert_int_equal(wdr_board_load(path, &b, err, sizeof err), WDR_E_INVAL);
    write_text(path, "{\"geometry\": {\"width\": 10.5}}");
    assert_int_equal(wdr_board_load(path, &b, err, sizeof err), WDR_E_INVAL);
    write_text(path, "{ not json");
    assert_int_equal(wdr_board_load(path, &b, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, path));
    remove(path);
    assert_int_equal(wdr_board_load(path, &b, err, sizeof err), WDR_E_IO);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(curves_are_bounded_and_monotone), cmocka_unit_test(known_values),
        cmocka_unit_test(bad_parameters_are_named),        cmocka_unit_test(bad_user_curves_are_refused),
        cmocka_unit_test(scene_stats_are_guarded),         cmocka_unit_test(bad_board_fields_are_named),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
