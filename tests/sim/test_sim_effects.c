/* Each effect alone moves the output the way the physics says, by the size it says:
 * shot noise (variance in electrons = electrons collected), kTC (charge sigma sqrt(kTC)),
 * read noise, hold-node leakage against the row's read time, V_T mismatch sigmas (Pelgrom),
 * dark current, DAC steps and clipping. */
#include "sim_test.h"

#define W 64
#define H 64
#define N ((long)W * H)
#define Q_E 1.602176634e-19
#define K_B 1.380649e-23

typedef struct fixture {
    wdr_board b;
    test_chip tc;
    wdr_ideal_pixel px;
    wdr_operator op;
} fixture;

static int setup(void **state)
{
    fixture *f = calloc(1, sizeof *f);
    wdr_lum_stats st;
    char err[256];
    test_board(&f->b, W, H);
    test_chip_open(&f->tc, &f->b, "reinhard", 11);
    wdr_ideal_pixel_init(&f->b, &f->px);
    wdr_lum_stats_default(f->b.i_min_a, f->b.i_center_a, f->b.i_max_a, f->b.lum_per_amp, 0.18, &st);
    assert_int_equal(wdr_operator_init(&f->op, "reinhard", &st, err, sizeof err), WDR_OK);
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fixture *f = *state;
    test_chip_close(&f->tc);
    free(f);
    return 0;
}

static double frame_mean(wdr_sim *s, double amps)
{
    double m, v;
    float *fr = uniform_frame(s, amps, 1);
    frame_stats(fr, N, &m, &v);
    free(fr);
    return m;
}

/* Output slope d code / d ln I of the noiseless continuous response. */
static double slope_ln_i(wdr_sim *s, double amps)
{
    const double eps = 0.02;
    return (frame_mean(s, amps * (1 + eps)) - frame_mean(s, amps * (1 - eps))) / (2 * eps);
}

/* Charge an ideal pixel collects before M2 turns off at current amps (continuous ramp). */
static double collected_charge(const fixture *f, double amps)
{
    return amps * wdr_ideal_cross_time(&f->px, amps, wdr_ideal_target(&f->px, &f->op, amps));
}

static double noise_var(wdr_sim *s, double amps)
{
    double m, v;
    float *fr = uniform_frame(s, amps, 5);
    frame_stats(fr, N, &m, &v);
    free(fr);
    return v;
}

static void shot_variance_is_electron_count(void **state)
{
    fixture *f = *state;
    const double currents[] = {1e-13, 1e-12, 1e-11, 1e-10};
    double prev = 0;
    for (int k = 0; k < 4; k++) {
        only_effects(f->tc.s, -1);
        double s = slope_ln_i(f->tc.s, currents[k]);
        only_effects(f->tc.s, WDR_FX_SHOT, -1);
        /* a relative charge error x moves the output as a relative current error x would */
        double electrons_var = s * s / noise_var(f->tc.s, currents[k]);
        double electrons = collected_charge(f, currents[k]) / Q_E;
        printf("I = %.0e A: shot variance %.4g e^2, electrons collected %.4g (ratio %.3f)\n", currents[k],
               electrons_var, electrons, electrons_var / electrons);
        assert_true(fabs(electrons_var / electrons - 1) < 0.12);
        assert_true(electrons_var > prev); /* grows with the photocurrent */
        prev = electrons_var;
    }
}

static void ktc_charge_sigma(void **state)
{
    fixture *f = *state;
    const double amps = 1e-12, dv = 1e-4;
    only_effects(f->tc.s, -1);
    double s = slope_ln_i(f->tc.s, amps);
    only_effects(f->tc.s, WDR_FX_KTC, -1);
    double sigma_q = collected_charge(f, amps) * sqrt(noise_var(f->tc.s, amps)) / fabs(s);
    double c = (wdr_pixel_charge(&f->px.dev, f->px.v_n0 + dv) - wdr_pixel_charge(&f->px.dev, f->px.v_n0 - dv)) / (2 * dv);
    double want = sqrt(K_B * f->b.temperature_k * c);
    printf("kTC: charge sigma %.4g C (%.1f e), sqrt(kT C) = %.4g C\n", sigma_q, sigma_q / Q_E, want);
    assert_true(fabs(sigma_q / want - 1) < 0.1);
}

static void read_noise_sigma(void **state)
{
    fixture *f = *state;
    only_effects(f->tc.s, WDR_FX_READ, -1);
    double sigma = sqrt(noise_var(f->tc.s, 0.0));
    double want = test_adc_code(&f->b, f->b.read_noise_v) - test_adc_code(&f->b, 0);
    printf("read noise: %.4f LSB, expected %.4f LSB\n", sigma, want);
    assert_true(fabs(sigma / want - 1) < 0.06);
}

/* G droops by I_leak t / C_hold, t running to the row's read; seen through the follower. */
static void leakage_grows_with_row(void **state)
{
    fixture *f = *state;
    const double dv = 1e-3;
    only_effects(f->tc.s, WDR_FX_LEAKAGE, -1);
    float *fr = uniform_frame(f->tc.s, 1e-11, 1);
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (int r = 0; r < H; r++) {
        double m = 0;
        for (int x = 0; x < W; x++)
            m += fr[(long)r * W + x] / W;
        sx += r, sy += m, sxx += (double)r * r, sxy += r * m;
    }
    double slope = (H * sxy - sx * sy) / (H * sxx - sx * sx);
    double v_g = wdr_ideal_target(&f->px, &f->op, 1e-11);
    double gain = (wdr_pixel_sf_out(&f->px.dev, v_g + dv) - wdr_pixel_sf_out(&f->px.dev, v_g - dv)) / (2 * dv);
    double want = -f->b.hold_leak_a / f->b.c_hold_f * f->b.row_time_s * gain *
                  (test_adc_code(&f->b, 1) - test_adc_code(&f->b, 0));
    printf("leakage: %.5f LSB per row, expected %.5f\n", slope, want);
    assert_true(slope < 0 && fabs(slope / want - 1) < 0.03);
    free(fr);
}

/* The same through expose + read_row: a row read 10 ms later has drooped 10 ms more. */
static void leakage_by_read_time(void **state)
{
    fixture *f = *state;
    uint16_t early[W], late[W];
    only_effects(f->tc.s, WDR_FX_LEAKAGE, -1);
    assert_int_equal(wdr_sim_set_uniform(f->tc.s, 1e-11), WDR_OK);
    assert_int_equal(wdr_sim_expose(f->tc.s, 1), WDR_OK);
    assert_int_equal(wdr_sim_read_row(f->tc.s, 3, 0.0, early), WDR_OK);
    assert_int_equal(wdr_sim_read_row(f->tc.s, 3, 10e-3, late), WDR_OK);
    double want = f->b.hold_leak_a / f->b.c_hold_f * 10e-3 * 0.85 * 4095 / 2.0; /* ~3.5 LSB */
    double drop = 0;
    for (int x = 0; x < W; x++)
        drop += (double)(early[x] - late[x]) / W;
    printf("leakage over 10 ms: %.2f LSB (about %.2f expected)\n", drop, want);
    assert_true(drop > 0.7 * want && drop < 1.3 * want);
    assert_int_equal(wdr_sim_read_row(f->tc.s, H, 0.0, early), WDR_E_INVAL);
}

static double std_of(const double *v, long n)
{
    double m = 0, s = 0;
    for (long i = 0; i < n; i++)
        m += v[i] / n;
    for (long i = 0; i < n; i++)
        s += (v[i] - m) * (v[i] - m);
    return sqrt(s / (n - 1));
}

/* Drawn thresholds follow Pelgrom: sigma = A_VT / sqrt(W L) for M1 (via the reset charge),
 * M2 and M3; and a dark pixel's output spread is M3's sigma through the follower. */
static void vt_mismatch_matches_sigmas(void **state)
{
    (void)state;
    wdr_board b;
    test_chip tc;
    wdr_ideal_pixel px;
    test_board(&b, W, H);
    b.abeta_pct_um = 0, b.c_pd_sigma_pct = 0, b.dark_sigma_ln = 0;
    test_chip_open(&tc, &b, "reinhard", 3);
    wdr_ideal_pixel_init(&b, &px);
    double *dq0 = malloc(N * sizeof *dq0), *dvt2 = malloc(N * sizeof *dvt2), *sfk = malloc(N * sizeof *sfk);
    for (long i = 0; i < N; i++) {
        wdr_sim_pixel_truth t;
        assert_int_equal(wdr_sim_pixel_devices(tc.s, (int)(i % W), (int)(i / W), &t), WDR_OK);
        dq0[i] = t.dq0_c, dvt2[i] = t.dvt2_v, sfk[i] = t.sf_k_v;
    }
    double s1 = 9.5e-3 / sqrt(1.0 * 0.7), s23 = 9.5e-3 / sqrt(2.0 * 0.7), dv = 1e-4;
    double c = (wdr_pixel_charge(&px.dev, px.v_n0 + dv) - wdr_pixel_charge(&px.dev, px.v_n0 - dv)) / (2 * dv);
    double reset_gain = 1 / (1 + b.gamma_sqrt_v / (2 * sqrt(b.phi2f_v + px.v_n0)));
    printf("sigma M1 %.3f mV (want %.3f), M2 %.3f mV, M3 %.3f mV (want %.3f)\n",
           1e3 * std_of(dq0, N) / (c * reset_gain), 1e3 * s1, 1e3 * std_of(dvt2, N), 1e3 * std_of(sfk, N), 1e3 * s23);
    assert_true(fabs(std_of(dq0, N) / (c * reset_gain * s1) - 1) < 0.05);
    assert_true(fabs(std_of(dvt2, N) / s23 - 1) < 0.05);
    assert_true(fabs(std_of(sfk, N) / s23 - 1) < 0.05);
    free(dq0), free(dvt2), free(sfk);
    test_chip_close(&tc);
}

/* An unlit pixel holds the lower of the ramp's end and its own dark level, which M1 and M2
 * move; with those two made huge (sigma ~ 0) the output spread is M3's through the follower. */
static void m3_mismatch_through_follower(void **state)
{
    (void)state;
    wdr_board b;
    test_chip tc;
    wdr_ideal_pixel px;
    test_board(&b, W, H);
    b.abeta_pct_um = 0, b.c_pd_sigma_pct = 0, b.dark_sigma_ln = 0;
    b.m1 = (wdr_mos){1000, 1000}, b.m2 = (wdr_mos){1000, 1000};
    test_chip_open(&tc, &b, "reinhard", 3);
    wdr_ideal_pixel_init(&b, &px);
    only_effects(tc.s, WDR_FX_MISMATCH, -1);
    double m, var, s23 = 9.5e-3 / sqrt(2.0 * 0.7);
    float *fr = uniform_frame(tc.s, 0.0, 1);
    frame_stats(fr, N, &m, &var);
    wdr_pixel_dev d = px.dev;
    double vg = 2.3, v0 = wdr_pixel_sf_out(&d, vg);
    d.vt0_m3 += 1e-3;
    double dvo = (wdr_pixel_sf_out(&d, vg) - v0) / 1e-3;
    double want = fabs(dvo) * s23 * (test_adc_code(&b, 1) - test_adc_code(&b, 0));
    printf("dark-pixel output spread %.3f LSB, M3 sigma through the follower %.3f LSB\n", sqrt(var), want);
    assert_true(fabs(sqrt(var) / want - 1) < 0.06);
    free(fr);
    test_chip_close(&tc);
}

/* Dark current is light the pixel cannot tell apart: the output moves as for I + I_dark. */
static void dark_current_adds_to_light(void **state)
{
    fixture *f = *state;
    const double amps = 1e-14;
    only_effects(f->tc.s, WDR_FX_DARK, -1);
    double with_dark = frame_mean(f->tc.s, amps);
    only_effects(f->tc.s, -1);
    double without = frame_mean(f->tc.s, amps), as_light = frame_mean(f->tc.s, amps + f->b.dark_current_a);
    printf("dark current at 1e-14 A: output %.4f -> %.4f LSB (as extra light: %.4f)\n", without, with_dark, as_light);
    assert_true(with_dark < without);
    assert_near(with_dark, as_light, 1e-3);
}

/* Stepped against continuous: they differ, by at most one DAC step through the follower. */
static void dac_steps_bounded(void **state)
{
    fixture *f = *state;
    double worst = 0;
    for (double amps = 1e-14; amps < 1e-8; amps *= 1.37) {
        only_effects(f->tc.s, WDR_FX_DAC_QUANT, -1);
        double stepped = frame_mean(f->tc.s, amps);
        only_effects(f->tc.s, -1);
        worst = fmax(worst, fabs(stepped - frame_mean(f->tc.s, amps)));
    }
    double step = test_adc_code(&f->b, 3.3 / 4095) - test_adc_code(&f->b, 0);
    printf("DAC steps: worst shift %.3f LSB, one DAC code %.3f LSB\n", worst, step);
    assert_true(worst > 0.05 && worst <= step);
}

static void clipping_at_adc_rails(void **state)
{
    (void)state;
    wdr_board b;
    test_chip tc;
    test_board(&b, 4, 4);
    b.adc_hi_v = 1.0; /* dark pixels' follower output is far above this */
    test_chip_open(&tc, &b, "reinhard", 1);
    only_effects(tc.s, -1);
    float *open = uniform_frame(tc.s, 1e-14, 1);
    only_effects(tc.s, WDR_FX_CLIPPING, -1);
    float *clipped = uniform_frame(tc.s, 1e-14, 1);
    printf("clipping: %.1f LSB without, %.1f LSB with\n", open[0], clipped[0]);
    assert_true(open[0] > 4095 && clipped[0] == 4095);
    free(open), free(clipped);
    test_chip_close(&tc);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(shot_variance_is_electron_count),
        cmocka_unit_test(ktc_charge_sigma),
        cmocka_unit_test(read_noise_sigma),
        cmocka_unit_test(leakage_grows_with_row),
        cmocka_unit_test(leakage_by_read_time),
        cmocka_unit_test(vt_mismatch_matches_sigmas),
        cmocka_unit_test(m3_mismatch_through_follower),
        cmocka_unit_test(dark_current_adds_to_light),
        cmocka_unit_test(dac_steps_bounded),
        cmocka_unit_test(clipping_at_adc_rails),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
