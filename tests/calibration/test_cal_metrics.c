/* The figures of merit (host/cal/metrics/cal_metrics.h) on synthetic recovered currents whose answer is
 * known: contrast error as the spread of ln(x_hat/x) with the pixels past the curve counted and
 * clamps left out, total error split into FPN and temporal, display-space error and its pooling
 * per decade, the quantisation floor; and the display mapping through a response curve
 * (host/lib/tonemap.h). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "cal_test_support.h"
#include "tonemap.h"

#define N 20000

/* Deterministic standard normals (Box-Muller on a fixed LCG). */
static double normal(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    double u1 = ((*s >> 11) + 0.5) / 9007199254740992.0;
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    double u2 = ((*s >> 11) + 0.5) / 9007199254740992.0;
    return sqrt(-2 * log(u1)) * cos(6.283185307179586 * u2);
}

/* A pixel a factor of e^0.5 off contributes 50 % to the spread, not (e^0.5 - 1) = 65 %: the spread
 * is of ln(x_hat / x), exactly. */
static void contrast_is_the_spread_of_ln(void **state)
{
    (void)state;
    static double xh[4];
    const double x = 1e-11;
    xh[0] = x * exp(0.5), xh[1] = x * exp(-0.5), xh[2] = x * exp(0.5), xh[3] = x * exp(-0.5);
    wdr_contrast c;
    wdr_contrast_of(xh, 4, x, 1e-14, 1e-8, &c);
    assert_double_equal(c.sd_pct, 50.0, 1e-9);
    assert_double_equal(c.mean_pct, 0.0, 1e-9);
    assert_double_equal(c.max_abs_pct, 50.0, 1e-9);
    assert_int_equal(c.used, 4);
    assert_int_equal(c.beyond + c.unresolved + c.excluded, 0);
}

/* The raw frame at the bright end: a pixel whose code lies past the nominal curve is clamped at
 * 1e-2 A by the inverse. It must be counted as past the curve and left out of the spread, not
 * turn it into 1e7 %. A pixel just past the range is an extrapolation: in the spread, counted. */
static void clamps_are_counted_not_spread(void **state)
{
    (void)state;
    static double xh[N];
    const double x = 7e-9, lo = 1e-14, hi = 1e-8;
    uint64_t s = 1;
    for (int i = 0; i < N; i++)
        xh[i] = x * exp(0.02 * normal(&s));
    for (int i = 0; i < 100; i++)
        xh[i] = 1e-2;   /* clamped inverse */
    xh[100] = NAN;      /* flagged pixel */
    xh[101] = INFINITY; /* no inverse */
    xh[102] = 1.5e-8;   /* past the range, within a decade */
    wdr_contrast c;
    wdr_contrast_of(xh, N, x, lo, hi, &c);
    assert_int_equal(c.excluded, 1);
    assert_int_equal(c.unresolved, 101);
    assert_true(c.beyond >= 1);
    assert_true(c.sd_pct > 1.5 && c.sd_pct < 3.5); /* about 2 %, with the one extrapolated pixel */
    assert_double_equal(c.beyond_frac, (double)(c.beyond + 101) / (N - 1), 1e-12);
}

/* Two single frames with FPN f and temporal noise t per frame, and an average of m frames: the
 * split must give back sd(f) and sd(t), and the average's total sqrt(f^2 + t^2 / m). */
static void total_error_splits_fpn_and_temporal(void **state)
{
    (void)state;
    static double a[N], b[N], m4[N];
    const double x = 1e-12, f_sd = 0.01, t_sd = 0.02;
    const int m = 4;
    uint64_t s = 7;
    for (int i = 0; i < N; i++) {
        double f = f_sd * normal(&s), avg = 0;
        a[i] = x * exp(f + t_sd * normal(&s));
        b[i] = x * exp(f + t_sd * normal(&s));
        for (int k = 0; k < m; k++)
            avg += t_sd * normal(&s) / m;
        m4[i] = x * exp(f + avg);
    }
    wdr_total_error t;
    wdr_total_error_of(a, b, m4, N, m, x, 1e-14, 1e-8, &t);
    printf("  fpn %.4f %%, temporal %.4f %%, one frame %.4f %%, %d frames %.4f %%\n", t.fpn_pct, t.temporal_pct,
           t.total_1_pct, t.frames, t.total_m_pct);
    assert_double_equal(t.temporal_pct, 100 * t_sd, 0.05);
    assert_double_equal(t.fpn_pct, 100 * f_sd, 0.1);
    assert_double_equal(t.total_1_pct, 100 * hypot(f_sd, t_sd), 0.05);
    assert_double_equal(t.total_m_pct, 100 * hypot(f_sd, t_sd / sqrt(m)), 0.05);
    assert_int_equal(t.frames, m);
}

/* The current above x whose display level is `want` (bisection in ln x). */
static double current_at_level(const wdr_display_map *d, double x, double want)
{
    double lo = log(x), hi = log(x) + 5;
    for (int it = 0; it < 100; it++) {
        double mid = 0.5 * (lo + hi);
        if (wdr_display_level(d, exp(mid)) < want)
            lo = mid;
        else
            hi = mid;
    }
    return exp(lo);
}

static void display_error_in_levels(void **state)
{
    (void)state;
    wdr_board b;
    wdr_display_map d;
    char err[256];
    static double xh[1000];
    wdr_board_defaults(&b);
    assert_int_equal(wdr_display_map_init(&d, &b, "reinhard", err, sizeof err), WDR_OK);
    const double x = 1e-12;
    double level = wdr_display_level(&d, x);
    assert_true(level > 0 && level < 255);
    /* the level of the operator and the display gamma, continuous */
    double t = wdr_operator_eval(&d.op, d.lum_per_amp * x);
    assert_double_equal(level, 255 * pow(t, 1 / 2.2), 1e-9);
    /* 800 pixels exact, 100 at the current shown 3 levels higher, 100 at 0.7 levels higher */
    double x3 = current_at_level(&d, x, level + 3), x07 = current_at_level(&d, x, level + 0.7);
    for (int i = 0; i < 1000; i++)
        xh[i] = i < 100 ? x3 : i < 200 ? x07 : x;
    wdr_display_error e;
    wdr_display_error_of(xh, 1000, x, &d, &e);
    assert_int_equal(e.used, 1000);
    assert_double_equal(e.mean_levels, 0.37, 1e-6);
    assert_double_equal(e.mean_abs_levels, 0.37, 1e-6);
    assert_double_equal(e.rms_levels, sqrt(0.1 * 9 + 0.1 * 0.49), 1e-6);
    assert_double_equal(e.frac_over_1, 0.1, 1e-12);
    /* pooling per decade: two currents of 1e-12..1e-11 weighted by their pixels, one of the next */
    wdr_display_error per[3] = {e, e, e}, dec[3];
    per[0].x_lo = per[0].x_hi = 2e-12, per[0].used = 1000;
    per[1].x_lo = per[1].x_hi = 5e-12, per[1].used = 3000, per[1].mean_levels = -0.1, per[1].frac_over_1 = 0;
    per[2].x_lo = per[2].x_hi = 2e-11;
    assert_int_equal(wdr_display_by_decade(per, 3, dec, 3), 2);
    assert_double_equal(dec[0].x_lo, 1e-12, 1e-24);
    assert_double_equal(dec[0].x_hi, 1e-11, 1e-23);
    assert_double_equal(dec[0].mean_levels, (0.37 * 1000 - 0.1 * 3000) / 4000, 1e-9);
    assert_double_equal(dec[0].frac_over_1, 0.1 * 1000 / 4000, 1e-12);
    assert_int_equal(dec[0].used, 4000);
    assert_double_equal(dec[1].x_lo, 1e-11, 1e-23);
}

/* 100 sqrt(2 (1 + s^2) / 12) / slope: the ADC's rounding and a DAC step of s codes, in the frame and
 * in the levels. */
static void quantisation_floor(void **state)
{
    (void)state;
    assert_double_equal(wdr_quant_floor_pct(100, 1), 100 * sqrt(4.0 / 12) / 100, 1e-12);
    assert_double_equal(wdr_quant_floor_pct(-3.19, 0), 100 * sqrt(2.0 / 12) / 3.19, 1e-12);
}

/* Corrected codes to the current they stand for on a curve: exact where the curve is linear in
 * ln x, clamped at its ends; to display through the operator. */
static void response_curve_inverse(void **state)
{
    (void)state;
    double lx[5], code[5];
    for (int k = 0; k < 5; k++)
        lx[k] = log(1e-14) + k * 3.0, code[k] = 4000 - 700.0 * k;
    wdr_response_curve c = {5, lx, code};
    assert_double_equal(log(wdr_response_current(&c, 4000 - 700 * 1.5)), log(1e-14) + 4.5, 1e-12);
    assert_double_equal(log(wdr_response_current(&c, 4000)), lx[0], 1e-12);
    assert_double_equal(log(wdr_response_current(&c, 4095)), lx[0], 1e-12); /* darker than the curve */
    assert_double_equal(log(wdr_response_current(&c, 0)), lx[4], 1e-12);    /* brighter */
    assert_double_equal(log(wdr_response_current(&c, NAN)), lx[0], 1e-12);
    wdr_board b;
    wdr_display_map d;
    char err[256];
    wdr_board_defaults(&b);
    assert_int_equal(wdr_display_map_init(&d, &b, "reinhard", err, sizeof err), WDR_OK);
    double x = wdr_response_current(&c, 2000);
    assert_double_equal(wdr_code_to_display_curve(&c, &d.op, d.lum_per_amp, 2000),
                        wdr_operator_eval(&d.op, d.lum_per_amp * x), 1e-12);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(contrast_is_the_spread_of_ln),
        cmocka_unit_test(clamps_are_counted_not_spread),
        cmocka_unit_test(total_error_splits_fpn_and_temporal),
        cmocka_unit_test(display_error_in_levels),
        cmocka_unit_test(quantisation_floor),
        cmocka_unit_test(response_curve_inverse),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
