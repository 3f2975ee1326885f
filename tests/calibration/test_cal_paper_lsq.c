/* The paper's models fitted by least squares through more levels than parameters
 * (wdr_simple3_fit_lsq, wdr_complex4_fit_lsq): exact on noiseless curves, the paper's exact fit
 * with 3 or 4 points, a true minimum of the code residuals, less error than the exact fit on
 * rounded codes, and a status (never NaN) on data no model should accept. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "cal_model.h"
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#define N_LEV 9
#define N_PIX 300
#define N_JUDGE 30

/* Six decades in scaled currents, as a calibration's u = x / x_scale (x_scale their centre). */
static void levels(double *u, int n)
{
    for (int k = 0; k < n; k++)
        u[k] = 1e-3 * pow(1e6, (double)k / (n - 1));
}

/* A deterministic normal deviate (LCG + Box-Muller): the pixels' spread. */
static double normal(uint64_t *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    double a = ((*s >> 11) + 0.5) / 9007199254740992.0;
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    double b = ((*s >> 11) + 0.5) / 9007199254740992.0;
    return sqrt(-2 * log(a)) * cos(6.283185307179586 * b);
}

static wdr_simple3 simple3_pixel(uint64_t *s)
{
    return (wdr_simple3){3100 + 30 * normal(s), 2600 * (1 + 0.01 * normal(s)), 0.9 * (1 + 0.02 * normal(s)), 0, 1};
}

/* a, b, c, e -> P = a, Q = ac - b, R = be, S = c (paper eq. 22-23) */
static wdr_complex4 complex4_pixel(uint64_t *s)
{
    double a = 3100 + 30 * normal(s), b = 2000 * (1 + 0.01 * normal(s)), c = 0.8 * (1 + 0.02 * normal(s)), e = 1e-4;
    return (wdr_complex4){a, a * c - b, b * e, c, 0, 1, 0};
}

static void simple3_recovers_exact_curve(void **state)
{
    (void)state;
    wdr_simple3 truth = {3100, 2600, 0.9, 0, 1}, m = {.x_scale = 1};
    double u[N_LEV], y[N_LEV];
    levels(u, N_LEV);
    for (int k = 0; k < N_LEV; k++)
        y[k] = wdr_simple3_eval(&truth, u[k]);
    assert_int_equal(wdr_simple3_fit_lsq(u, y, NULL, N_LEV, &m), WDR_FIT_OK);
    assert_true(fabs(m.a / truth.a - 1) < 1e-9 && fabs(m.b / truth.b - 1) < 1e-9 && fabs(m.c / truth.c - 1) < 1e-9);
    /* with the dark reference: d puts the dark reading at u0 = 0 (exact data: d = 0) */
    assert_int_equal(wdr_simple3_fit_lsq_dark(u, y, NULL, N_LEV, 0, wdr_simple3_eval(&truth, 0), &m), WDR_FIT_OK);
    assert_true(fabs(m.d) < 1e-9);
}

static void complex4_recovers_exact_curve(void **state)
{
    (void)state;
    uint64_t s = 7;
    wdr_complex4 truth = complex4_pixel(&s), m = {.x_scale = 1};
    double u[N_LEV], y[N_LEV];
    levels(u, N_LEV);
    for (int k = 0; k < N_LEV; k++)
        y[k] = wdr_complex4_eval(&truth, u[k]);
    assert_int_equal(wdr_complex4_fit_lsq(u, y, NULL, N_LEV, &m), WDR_FIT_OK);
    for (int j = 0; j < 13; j++) { /* u = 1e-3 * 2.9^j below 1e3: six decades */
        double uu = 1e-3 * pow(2.9, j);
        assert_true(fabs(wdr_complex4_eval(&m, uu) - wdr_complex4_eval(&truth, uu)) < 1e-6);
    }
    assert_true(fabs(m.s / truth.s - 1) < 1e-8);
    assert_int_equal(wdr_complex4_fit_lsq_dark(u, y, NULL, N_LEV, 0, wdr_complex4_eval(&truth, 0), &m), WDR_FIT_OK);
    assert_true(fabs(m.d) < 1e-9);
}

/* With the paper's count the least-squares entry is the paper's exact fit, bit for bit. */
static void paper_count_is_the_exact_fit(void **state)
{
    (void)state;
    uint64_t s = 11;
    double u[4] = {1e-3, 0.1, 10, 1e3}, y3[3], y4[4];
    wdr_simple3 t3 = simple3_pixel(&s), a3 = {.x_scale = 1}, b3 = {.x_scale = 1};
    wdr_complex4 t4 = complex4_pixel(&s), a4 = {.x_scale = 1}, b4 = {.x_scale = 1};
    double u3[3] = {u[0], u[2], u[3]};
    for (int k = 0; k < 3; k++)
        y3[k] = round(wdr_simple3_eval(&t3, u3[k]));
    for (int k = 0; k < 4; k++)
        y4[k] = round(wdr_complex4_eval(&t4, u[k]));
    assert_int_equal(wdr_simple3_fit3(u3, y3, &a3), WDR_FIT_OK);
    assert_int_equal(wdr_simple3_fit_lsq(u3, y3, NULL, 3, &b3), WDR_FIT_OK);
    assert_memory_equal(&a3, &b3, sizeof a3);
    assert_int_equal(wdr_complex4_fit4(u, y4, &a4), WDR_FIT_OK);
    assert_int_equal(wdr_complex4_fit_lsq(u, y4, NULL, 4, &b4), WDR_FIT_OK);
    assert_memory_equal(&a4, &b4, sizeof a4);
}

/* ---- on rounded codes: a minimum, and less error than the exact fit ---- */

typedef double (*eval_fn)(const void *m, double u);
static double eval3(const void *m, double u) { return wdr_simple3_eval(m, u); }
static double eval4(const void *m, double u) { return wdr_complex4_eval(m, u); }

static double code_ss(eval_fn f, const void *m, const double *u, const double *y, int n)
{
    double ss = 0;
    for (int k = 0; k < n; k++)
        ss += (y[k] - f(m, u[k])) * (y[k] - f(m, u[k]));
    return ss;
}

/* A least-squares minimum: no parameter moved by +-1e-4 of itself (or of the largest, for
 * tiny ones) lowers the code residual. A fit that stopped at its starting point, or stepped
 * along a wrong gradient, fails this. */
static int is_minimum(eval_fn f, double *const *par, int np, const void *m, const double *u, const double *y, int n)
{
    double ss = code_ss(f, m, u, y, n), big = 0;
    for (int j = 0; j < np; j++)
        big = fmax(big, fabs(*par[j]));
    for (int j = 0; j < np; j++) {
        double keep = *par[j], h = 1e-4 * fmax(fabs(keep), 1e-6 * big);
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            *par[j] = keep + sgn * h;
            double moved = code_ss(f, m, u, y, n);
            *par[j] = keep;
            if (moved < ss * (1 - 1e-12))
                return 0;
        }
    }
    return 1;
}

/* Sum of ln(u_hat / u)^2 over the judging currents (between the levels) of one pixel, read without
 * rounding: the calibration's own error. */
static double sim3_err(const wdr_simple3 *fit, const wdr_simple3 *truth, double *sum2)
{
    for (int k = 0; k < N_JUDGE; k++) {
        double u = 1e-3 * pow(1e6, (k + 0.37) / N_JUDGE), back;
        if (wdr_simple3_invert(fit, wdr_simple3_eval(truth, u), 1e9, &back) || !(back > 0))
            return -1;
        *sum2 += log(back / u) * log(back / u);
    }
    return 0;
}

static double sim4_err(const wdr_complex4 *fit, const wdr_complex4 *truth, double *sum2)
{
    for (int k = 0; k < N_JUDGE; k++) {
        double u = 1e-3 * pow(1e6, (k + 0.37) / N_JUDGE), back;
        int clamped;
        if (wdr_complex4_invert(fit, wdr_complex4_eval(truth, u), 1e9, &back, &clamped) || !(back > 0))
            return -1;
        *sum2 += log(back / u) * log(back / u);
    }
    return 0;
}

static void simple3_averages_rounding(void **state)
{
    (void)state;
    uint64_t s = 1;
    double u[N_LEV], y[N_LEV], e_exact = 0, e_lsq = 0;
    levels(u, N_LEV);
    for (int i = 0; i < N_PIX; i++) {
        wdr_simple3 t = simple3_pixel(&s), ex = {.x_scale = 1}, ls = {.x_scale = 1};
        for (int k = 0; k < N_LEV; k++)
            y[k] = round(wdr_simple3_eval(&t, u[k]));
        double u3[3] = {u[0], u[N_LEV / 2], u[N_LEV - 1]}, y3[3] = {y[0], y[N_LEV / 2], y[N_LEV - 1]};
        assert_int_equal(wdr_simple3_fit3(u3, y3, &ex), WDR_FIT_OK);
        assert_int_equal(wdr_simple3_fit_lsq(u, y, NULL, N_LEV, &ls), WDR_FIT_OK);
        double *par[3] = {&ls.a, &ls.b, &ls.c};
        assert_true(is_minimum(eval3, par, 3, &ls, u, y, N_LEV));
        assert_int_equal(sim3_err(&ex, &t, &e_exact), 0);
        assert_int_equal(sim3_err(&ls, &t, &e_lsq), 0);
    }
    e_exact = 100 * sqrt(e_exact / (N_PIX * N_JUDGE)), e_lsq = 100 * sqrt(e_lsq / (N_PIX * N_JUDGE));
    printf("  simple3 on rounded codes: calibration's rms contrast error %.3f %% (exact through 3 of %d levels), %.3f %% "
           "(least squares through all)\n",
           e_exact, N_LEV, e_lsq);
    assert_true(e_lsq < 0.8 * e_exact);
}

static void complex4_averages_rounding(void **state)
{
    (void)state;
    uint64_t s = 2;
    double u[N_LEV], y[N_LEV], e_exact = 0, e_lsq = 0;
    static const int pick[4] = {0, 3, 5, N_LEV - 1};
    levels(u, N_LEV);
    for (int i = 0; i < N_PIX; i++) {
        wdr_complex4 t = complex4_pixel(&s), ex = {.x_scale = 1}, ls = {.x_scale = 1};
        double u4[4], y4[4];
        for (int k = 0; k < N_LEV; k++)
            y[k] = round(wdr_complex4_eval(&t, u[k]));
        for (int k = 0; k < 4; k++)
            u4[k] = u[pick[k]], y4[k] = y[pick[k]];
        assert_int_equal(wdr_complex4_fit4(u4, y4, &ex), WDR_FIT_OK);
        assert_int_equal(wdr_complex4_fit_lsq(u, y, NULL, N_LEV, &ls), WDR_FIT_OK);
        double *par[4] = {&ls.p, &ls.q, &ls.r, &ls.s};
        assert_true(is_minimum(eval4, par, 4, &ls, u, y, N_LEV));
        assert_int_equal(sim4_err(&ex, &t, &e_exact), 0);
        assert_int_equal(sim4_err(&ls, &t, &e_lsq), 0);
    }
    e_exact = 100 * sqrt(e_exact / (N_PIX * N_JUDGE)), e_lsq = 100 * sqrt(e_lsq / (N_PIX * N_JUDGE));
    printf("  complex4 on rounded codes: calibration's rms contrast error %.3f %% (exact through 4 of %d levels), %.3f %% "
           "(least squares through all)\n",
           e_exact, N_LEV, e_lsq);
    assert_true(e_lsq < 0.8 * e_exact);
}

/* ---- refused, with a status and finite outputs ---- */

static void both_refuse(const double *u, const double *y, int n, int want)
{
    wdr_simple3 m3 = {.x_scale = 1};
    wdr_complex4 m4 = {.x_scale = 1};
    assert_int_equal(wdr_simple3_fit_lsq(u, y, NULL, n, &m3), want);
    assert_int_equal(wdr_complex4_fit_lsq(u, y, NULL, n, &m4), want);
}

static void bad_data_refused(void **state)
{
    (void)state;
    double u[N_LEV], y[N_LEV];
    levels(u, N_LEV);
    for (int k = 0; k < N_LEV; k++)
        y[k] = 2000; /* flat */
    both_refuse(u, y, N_LEV, WDR_FIT_FLAT);
    for (int k = 0; k < N_LEV; k++)
        y[k] = 1000 + 100 * k; /* rising: reversed */
    both_refuse(u, y, N_LEV, WDR_FIT_REVERSED);
    for (int k = 0; k < N_LEV; k++)
        y[k] = 3000 - 100 * k;
    y[4] = NAN;
    both_refuse(u, y, N_LEV, WDR_FIT_NONFINITE);
    y[4] = 2600, u[2] = NAN;
    both_refuse(u, y, N_LEV, WDR_FIT_NONFINITE);
    levels(u, N_LEV);
    u[3] = u[2];
    both_refuse(u, y, N_LEV, WDR_FIT_CLOSE_CURRENTS);
    /* currents 1e-7 apart: every column of the system nearly the same */
    for (int k = 0; k < N_LEV; k++)
        u[k] = 1 + 1e-7 * k;
    both_refuse(u, y, N_LEV, WDR_FIT_ILL_COND);
    levels(u, N_LEV);
    both_refuse(u, y, 2, WDR_FIT_ILL_COND); /* fewer points than parameters */
    both_refuse(u, y, 65, WDR_FIT_ILL_COND);
}

/* Falling codes on the far branch of a pole (y = 3000 + 1000 u / (u - 1), u = 2..10: the
 * denominator 1 - u is negative at every level) are refused, not fitted. Codes falling into a
 * pole between two levels (y = 3000 - 1000 u / (1 - 0.1 u) up to u = 8.5, then one code lower
 * at 9.9): complex4 would follow them through the pole and is refused; simple3 cannot (its curve
 * jumps up across a pole), so it may answer only with a curve whose denominator stays positive. */
static void pole_inside_range_refused(void **state)
{
    (void)state;
    double u[8], y[8];
    for (int k = 0; k < 8; k++)
        u[k] = 2 + k, y[k] = 3000 + 1000 * u[k] / (u[k] - 1);
    both_refuse(u, y, 8, WDR_FIT_POLE);
    for (int k = 0; k < 8; k++) {
        u[k] = 0.1 + 1.4 * k;
        y[k] = k < 7 ? 3000 - 1000 * u[k] / (1 - 0.1 * u[k]) : y[k - 1] - 1;
    }
    wdr_complex4 m4 = {.x_scale = 1};
    assert_int_equal(wdr_complex4_fit_lsq(u, y, NULL, 8, &m4), WDR_FIT_POLE);
    wdr_simple3 m3 = {.x_scale = 1};
    int st = wdr_simple3_fit_lsq(u, y, NULL, 8, &m3);
    assert_true(st == WDR_FIT_POLE || st == WDR_FIT_OK);
    for (int k = 0; st == WDR_FIT_OK && k < 8; k++)
        assert_true(1 + m3.c * u[k] > 0 && isfinite(wdr_simple3_eval(&m3, u[k])));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(simple3_recovers_exact_curve), cmocka_unit_test(complex4_recovers_exact_curve),
        cmocka_unit_test(paper_count_is_the_exact_fit), cmocka_unit_test(simple3_averages_rounding),
        cmocka_unit_test(complex4_averages_rounding),   cmocka_unit_test(bad_data_refused),
        cmocka_unit_test(pole_inside_range_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
