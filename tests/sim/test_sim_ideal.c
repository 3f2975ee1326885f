/* With every effect off the simulator is the ideal pixel of the operators issue: the stepped
 * LUT gives wdr_ramp_lut_ideal_response exactly, the continuous ramp gives the operator's curve,
 * both seen through the source follower and the ADC. */
#include "sim_test.h"

#define N_CURRENTS 61

static double current_at(int j) { return 1e-14 * pow(1e6, (double)j / (N_CURRENTS - 1)); }

/* Ideal pixel through the nominal source follower into (unrounded) ADC codes. */
static double ideal_code(const wdr_board *b, const wdr_ideal_pixel *px, double v_g)
{
    return test_adc_code(b, wdr_pixel_sf_out(&px->dev, v_g));
}

static void stepped_matches_lut_response(const char *op, int timing, uint32_t entries)
{
    wdr_board b;
    test_chip tc;
    wdr_ideal_pixel px;
    test_board(&b, 4, 2);
    b.dac_timing = timing;
    b.dac_uniform_entries = entries;
    test_chip_open(&tc, &b, op, 1);
    wdr_ideal_pixel_init(&b, &px);
    only_effects(tc.s, WDR_FX_DAC_QUANT, -1);
    double worst = 0;
    for (int j = 0; j < N_CURRENTS; j++) {
        float *f = uniform_frame(tc.s, current_at(j), 1);
        double want = ideal_code(&b, &px, wdr_ramp_lut_ideal_response(&px, &tc.lut, current_at(j)));
        worst = fmax(worst, fabs(f[0] - want));
        free(f);
    }
    printf("%s, %s LUT of %u entries: worst |sim - ideal response| = %.2e ADC LSB\n", op,
           timing == WDR_TIMING_UNIFORM ? "uniform-clock" : "stamped", tc.lut.h.entry_count, worst);
    assert_true(worst < 2e-3); /* float storage of the held voltage: ~1e-4 LSB */
    test_chip_close(&tc);
}

static void stepped_reinhard(void **state)
{
    (void)state;
    stepped_matches_lut_response("reinhard", WDR_TIMING_STAMPED, 0);
}

static void stepped_logarithmic(void **state)
{
    (void)state;
    stepped_matches_lut_response("logarithmic", WDR_TIMING_STAMPED, 0);
}

static void stepped_schlick(void **state)
{
    (void)state;
    stepped_matches_lut_response("schlick", WDR_TIMING_STAMPED, 0);
}

/* A coarse uniform clock: big voltage jumps, where G stops between two codes (M2 turns off
 * during the jump) and the simulator solves the node level exactly. */
static void stepped_uniform_clock(void **state)
{
    (void)state;
    stepped_matches_lut_response("reinhard", WDR_TIMING_UNIFORM, 256);
}

/* DAC quantisation off: the continuous ramp of the ramp generator. The pixel then holds the
 * operator's target g(I) itself; against the stepped LUT it differs by at most a DAC step. */
static void continuous_matches_operator(void **state)
{
    (void)state;
    wdr_board b;
    test_chip tc;
    wdr_ideal_pixel px;
    wdr_operator op;
    wdr_lum_stats st;
    char err[256];
    test_board(&b, 4, 2);
    test_chip_open(&tc, &b, "reinhard", 1);
    wdr_ideal_pixel_init(&b, &px);
    wdr_lum_stats_default(b.i_min_a, b.i_center_a, b.i_max_a, b.lum_per_amp, 0.18, &st);
    assert_int_equal(wdr_operator_init(&op, "reinhard", &st, err, sizeof err), WDR_OK);
    only_effects(tc.s, -1);
    double dac_lsb_codes = test_adc_code(&b, 0.85 * (b.dac_hi_v - b.dac_lo_v) / 4095) - test_adc_code(&b, 0);
    double worst_target = 0, worst_lut = 0;
    for (int j = 0; j < N_CURRENTS; j++) {
        float *f = uniform_frame(tc.s, current_at(j), 1);
        double i = current_at(j);
        worst_target = fmax(worst_target, fabs(f[0] - ideal_code(&b, &px, wdr_ideal_target(&px, &op, i))));
        worst_lut = fmax(worst_lut, fabs(f[0] - ideal_code(&b, &px, wdr_ramp_lut_ideal_response(&px, &tc.lut, i))));
        free(f);
    }
    printf("continuous ramp: worst |sim - g(I)| = %.3g ADC LSB, |sim - LUT response| = %.3g ADC LSB "
           "(one DAC step = %.3g ADC LSB)\n", worst_target, worst_lut, dac_lsb_codes);
    assert_true(worst_target < 0.05);
    assert_true(worst_lut < 1.5 * dac_lsb_codes);
    test_chip_close(&tc);
}

/* ADC on: the integer frame is the rounded ideal code. */
static void adc_rounds_ideal_code(void **state)
{
    (void)state;
    wdr_board b;
    test_chip tc;
    wdr_ideal_pixel px;
    uint16_t frame[8];
    test_board(&b, 4, 2);
    test_chip_open(&tc, &b, "reinhard", 1);
    wdr_ideal_pixel_init(&b, &px);
    only_effects(tc.s, WDR_FX_DAC_QUANT, WDR_FX_ADC_QUANT, WDR_FX_CLIPPING, -1);
    for (int j = 0; j < N_CURRENTS; j++) {
        assert_int_equal(wdr_sim_set_uniform(tc.s, current_at(j)), WDR_OK);
        assert_int_equal(wdr_sim_render(tc.s, 1, frame), WDR_OK);
        double want = ideal_code(&b, &px, wdr_ramp_lut_ideal_response(&px, &tc.lut, current_at(j)));
        assert_true(fabs(frame[0] - want) <= 0.5 + 2e-3);
        assert_int_equal(frame[0], frame[7]);
    }
    test_chip_close(&tc);
}

/* The simulator's closed forms are the device equations of pixel.h: check them through a
 * pixel that never crosses (it holds the ramp's last value) on the body-effect board. */
static void dark_pixel_holds_last_code(void **state)
{
    (void)state;
    wdr_board b;
    test_chip tc;
    wdr_ideal_pixel px;
    test_board(&b, 4, 2);
    test_chip_open(&tc, &b, "reinhard", 1);
    wdr_ideal_pixel_init(&b, &px);
    only_effects(tc.s, WDR_FX_DAC_QUANT, -1);
    uint32_t t;
    uint16_t code;
    wdr_lut_entry(&tc.lut, tc.lut.h.entry_count - 1, &t, &code);
    double v_last = tc.lut.h.dac_lo_v + code * ((double)tc.lut.h.dac_hi_v - tc.lut.h.dac_lo_v) / 4095.0;
    float *f = uniform_frame(tc.s, 0.0, 1);
    assert_near(f[0], ideal_code(&b, &px, v_last), 2e-3);
    free(f);
    test_chip_close(&tc);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(stepped_reinhard),
        cmocka_unit_test(stepped_logarithmic),
        cmocka_unit_test(stepped_schlick),
        cmocka_unit_test(stepped_uniform_clock),
        cmocka_unit_test(continuous_matches_operator),
        cmocka_unit_test(adc_rounds_ideal_code),
        cmocka_unit_test(dark_pixel_holds_last_code),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
