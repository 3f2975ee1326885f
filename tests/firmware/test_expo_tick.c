/* Auto exposure plays its tick to 1/65536 ps, and STATUS says which limit holds it.
 * A LUT at a 1000 ps tick whose exposure table reads a constant ln(I / key) makes the loop push
 * the gain frame after frame (the error never falls: the table is not physics), so it crosses the
 * 10-60 ps ticks bright scenes want and stops at a limit:
 * - every frame's integration equals the LUT's at its own tick times e^(-gain/256), within 0.05 %
 *   (in whole picoseconds a 17.x ps tick was up to 6 % off its gain, and the key settled 9 % off:
 *   Schlick's bright scene on sim-qvga);
 * - a scene too bright stops where a DAC step would be shorter than WDR_FW_DAC_MIN_UPDATE_PS,
 *   and exposure_flags says WDR_EXPO_HELD_DAC_RATE; a scene too dark stops at the longest
 *   integration with WDR_EXPO_HELD_INTEGRATION; fixed exposure says neither. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "harness.h"
#include "wdr_lut.h"
#include <math.h>
#include <string.h>

#define ENTRIES 16
#define STEP_TICKS 100u /* the shortest step: the DAC's 1000 ps at a 10 ps tick */
#define OWN_PS 1000u
#define OWN_TICKS 1000000u /* 1 ms: whole nanoseconds of integration are finer than 0.01 % at 1-20 ps */

static wdr_fw fw;
static uint8_t lut[WDR_LUT_HEADER_SIZE + ENTRIES * WDR_LUT_ENTRY_SIZE + WDR_LUT_EXPO_SIZE];

static size_t crafted_lut(int16_t ln_q8)
{
    uint32_t t[ENTRIES];
    uint16_t codes[ENTRIES];
    wdr_lut_header h;
    memset(&h, 0, sizeof h);
    h.operator_id = WDR_OP_REINHARD;
    h.dac_bits = FB_DAC_BITS;
    h.timing = WDR_TIMING_STAMPED;
    h.entry_count = ENTRIES;
    h.tick_ps = OWN_PS;
    h.t_integration_ticks = OWN_TICKS;
    h.dac_lo_v = 0.0f;
    h.dac_hi_v = 3.3f;
    for (uint32_t i = 0; i < ENTRIES; i++) {
        t[i] = i * STEP_TICKS;
        codes[i] = (uint16_t)(i * 8u);
    }
    wdr_lut_encode(&h, t, codes, lut);
    wdr_lut_exposure ex = {.code_shift = FB_ADC_BITS - 6, .bins = WDR_LUT_EXPO_BINS};
    for (uint32_t b = 0; b < WDR_LUT_EXPO_BINS; b++)
        ex.ln_q8[b] = ln_q8;
    size_t end = wdr_lut_size(ENTRIES);
    wdr_lut_exposure_encode(&ex, lut + end);
    return end + WDR_LUT_EXPO_SIZE;
}

static int setup(void **state)
{
    (void)state;
    fb_init();
    th_boot(&fw);
    return 0;
}

/* Runs auto exposure on a table reading ln_q8 everywhere for up to `frames` frames; checks each
 * frame's integration against its gain; returns the last STATUS. */
static wdr_status_report run(int16_t ln_q8, int frames, double *worst)
{
    size_t len = crafted_lut(ln_q8);
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, lut, (uint32_t)len, 4096, NULL), WDR_ST_OK);
    wdr_status_report st = th_status(&fw);
    assert_int_equal(st.exposure_flags, 1); /* a table, fixed exposure: held by nothing */
    uint8_t on = 1;
    assert_int_equal(th_request(&fw, WDR_CMD_SET_EXPOSURE, &on, 1, NULL, 0), WDR_ST_OK);
    *worst = 0;
    for (int f = 0; f < frames; f++) {
        assert_int_equal(th_capture_frames(&fw, 1), WDR_ST_OK);
        st = th_status(&fw);
        double want_ns = (double)OWN_TICKS * OWN_PS * exp(-st.key_gain_q8 / 256.0) / 1000.0;
        double off = fabs(st.integration_ns / want_ns - 1);
        *worst = off > *worst ? off : *worst;
    }
    return st;
}

static void bright_scene_is_held_by_the_dac_rate(void **state)
{
    (void)state;
    double worst;
    wdr_status_report st = run(6 * 256, 40, &worst);
    print_message("bright: gain %+.3f ln, tick %u ps, integration %u ns, flags %u, worst integration off its gain "
                  "%.4f %%\n",
                  st.key_gain_q8 / 256.0, st.tick_ps, st.integration_ns, st.exposure_flags, 100 * worst);
    assert_true(worst < 5e-4);
    assert_int_equal(st.exposure_flags, 1u | WDR_EXPO_HELD_DAC_RATE);
    double tick_ps = OWN_PS * exp(-st.key_gain_q8 / 256.0);
    assert_true(tick_ps * STEP_TICKS >= WDR_FW_DAC_MIN_UPDATE_PS * 0.9995); /* at the limit, not past it */
    assert_true(tick_ps * STEP_TICKS < WDR_FW_DAC_MIN_UPDATE_PS * 1.01);   /* within 1 % of it */
}

static void dark_scene_is_held_by_the_longest_integration(void **state)
{
    (void)state;
    double worst;
    wdr_status_report st = run(-8 * 256, 60, &worst);
    print_message("dark: gain %+.3f ln, integration %u ns, flags %u, worst %.4f %%\n", st.key_gain_q8 / 256.0,
                  st.integration_ns, st.exposure_flags, 100 * worst);
    assert_true(worst < 5e-4);
    assert_int_equal(st.exposure_flags, 1u | WDR_EXPO_HELD_INTEGRATION);
    assert_true(st.integration_ns <= WDR_FW_MAX_INTEGRATION_NS);
    assert_true(st.integration_ns > WDR_FW_MAX_INTEGRATION_NS * 0.99);
    uint8_t off = 0; /* fixed exposure: the flag goes with it */
    assert_int_equal(th_request(&fw, WDR_CMD_SET_EXPOSURE, &off, 1, NULL, 0), WDR_ST_OK);
    assert_int_equal(th_status(&fw).exposure_flags, 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(bright_scene_is_held_by_the_dac_rate, setup),
        cmocka_unit_test_setup(dark_scene_is_held_by_the_longest_integration, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
