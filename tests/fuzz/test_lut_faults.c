/* Faults issue 14's fuzzing found on the LUT path, reproduced: wdr_cal_lut_extend (calibrate
 * --lut) on a ramp that ends steeper than one code per tick gave equal time stamps, and the
 * result failed wdr_lut_parse. (--dac-bits outside 4..16 is the CLI test fuzz_lut_dac_bits.) */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "cal_engine.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <stdlib.h>
#include <string.h>

/* 3 codes per tick: t = 0..9, codes 0, 3, .., 27, a 12-bit DAC over 0..4.095 V (1 mV a code). */
static size_t steep_lut(uint8_t *out)
{
    uint32_t t[10];
    uint16_t c[10];
    for (int i = 0; i < 10; i++)
        t[i] = (uint32_t)i, c[i] = (uint16_t)(3 * i);
    wdr_lut_header h;
    memset(&h, 0, sizeof h);
    h.dac_bits = 12;
    h.entry_count = 10;
    h.tick_ps = 1000;
    h.t_integration_ticks = 100;
    h.dac_hi_v = 4.095f;
    wdr_lut_encode(&h, t, c, out);
    return wdr_lut_size(10);
}

static void steep_ramp_extends_to_a_valid_lut(void **state)
{
    (void)state;
    static uint8_t in[1024];
    size_t n = steep_lut(in);
    uint8_t *out = NULL;
    size_t out_len = 0;
    double added_s = 0, done_v = 0;
    char err[256] = "";
    int rc = wdr_cal_lut_extend(in, n, 0.012, 0.5, &out, &out_len, &added_s, &done_v, err, sizeof err);
    assert_int_equal(rc, WDR_OK);
    wdr_lut_view v;
    assert_int_equal(wdr_lut_parse(out, out_len, &v), WDR_OK); /* failed: equal time stamps */
    uint32_t t, t_prev = 0;
    uint16_t c = 0;
    for (uint32_t i = 0; i < v.h.entry_count; i++) {
        wdr_lut_entry(&v, i, &t, &c);
        assert_true(i == 0 || t > t_prev);
        t_prev = t;
    }
    assert_int_equal(c, 27 + 12); /* the whole 12 mV margin, at the ramp's own slope */
    assert_true(v.h.entry_count < 10 + 12); /* several codes per tick: fewer entries than codes */
    free(out);
}

/* The same steep ramp with a LUT 1.1 exposure block: the extension keeps the block, right after
 * the entries it actually wrote (a merge once put it after n + extra entries while the steep end
 * kept fewer, so the block was cut off and the board's auto exposure answered UNSUPPORTED). */
static void extension_keeps_the_exposure_block(void **state)
{
    (void)state;
    static uint8_t in[1024];
    size_t n = steep_lut(in);
    wdr_lut_exposure ex = {.code_shift = 6, .bins = WDR_LUT_EXPO_BINS};
    for (unsigned b = 0; b < WDR_LUT_EXPO_BINS; b++)
        ex.ln_q8[b] = (int16_t)(1000 - 30 * (int)b);
    wdr_lut_exposure_encode(&ex, in + n);
    uint8_t *out = NULL;
    size_t out_len = 0;
    double added_s = 0, done_v = 0;
    char err[256] = "";
    assert_int_equal(wdr_cal_lut_extend(in, n + WDR_LUT_EXPO_SIZE, 0.012, 0.5, &out, &out_len, &added_s, &done_v, err,
                                        sizeof err),
                     WDR_OK);
    wdr_lut_view v;
    assert_int_equal(wdr_lut_parse(out, out_len, &v), WDR_OK);
    assert_int_equal(out_len, wdr_lut_size(v.h.entry_count) + WDR_LUT_EXPO_SIZE);
    wdr_lut_exposure back;
    assert_int_equal(wdr_lut_exposure_parse(out + wdr_lut_size(v.h.entry_count), WDR_LUT_EXPO_SIZE, &back), WDR_OK);
    assert_int_equal(back.code_shift, ex.code_shift);
    assert_int_equal(back.bins, ex.bins);
    assert_memory_equal(back.ln_q8, ex.ln_q8, WDR_LUT_EXPO_BINS * sizeof ex.ln_q8[0]);
    free(out);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(steep_ramp_extends_to_a_valid_lut),
                                       cmocka_unit_test(extension_keeps_the_exposure_block)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
