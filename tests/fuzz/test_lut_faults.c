/* Faults fuzzing found on the LUT path, reproduced: wdr_cal_lut_extend (calibrate --lut) on a
 * ramp that ends steeper than one code per tick gave equal time stamps (issue 14), and on a ramp
 * ending near 2^32 ticks its integration end wrapped below its own last entry (fuzz_lut,
 * corpus/lut/lut_extend_invalid.bin); both results failed wdr_lut_parse. (--dac-bits outside
 * 4..16 is the CLI test fuzz_lut_dac_bits.) */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "cal_engine.h"
#include "crc32.h"
#include "wdr_bytes.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <stdio.h>
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
    assert_int_equal(c, 27 + 12);           /* the whole 12 mV margin, at the ramp's own slope */
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
    assert_int_equal(
        wdr_cal_lut_extend(in, n + WDR_LUT_EXPO_SIZE, 0.012, 0.5, &out, &out_len, &added_s, &done_v, err, sizeof err),
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

/* fuzz_lut's finding, as the harness sees it (its CRCs written for its layout: 5 entries, the
 * last at 2,147,483,895 ticks on a ramp rising 2 codes over 2^31 ticks, t_integration 3,075,591,457,
 * and 8 KiB of trailing bytes): it parses, and its extension must parse too. The extension's
 * integration end was t_last + 2 ceil(step) + 1 = 4,294,967,792 ticks, wrapped in 32 bits to 496,
 * so the header kept the old end, below the new last entry. */
static void extension_near_2_32_ticks_parses(void **state)
{
    (void)state;
    FILE *f = fopen(LUT_FINDING, "rb");
    assert_non_null(f);
    static uint8_t in[16384];
    size_t n = fread(in, 1, sizeof in, f);
    fclose(f);
    assert_true(n > WDR_LUT_HEADER_SIZE && n < sizeof in);
    uint32_t entries = wdr_get_u32(in + 12);
    assert_true(wdr_lut_size(entries) <= n && wdr_lut_size(entries) + WDR_LUT_EXPO_SIZE != n); /* no exposure block */
    wdr_put_u32(in + 56, wdr_crc32(0, in + WDR_LUT_HEADER_SIZE, (size_t)entries * WDR_LUT_ENTRY_SIZE));
    wdr_put_u32(in + 60, wdr_crc32(0, in, WDR_LUT_HEADER_SIZE - 4));
    wdr_lut_view v, e;
    assert_int_equal(wdr_lut_parse(in, n, &v), WDR_OK);
    uint8_t *out = NULL;
    size_t out_len = 0;
    double added_s = 0, done_v = 0;
    char err[256] = "";
    int rc = wdr_cal_lut_extend(in, n, 0.01, 0.5, &out, &out_len, &added_s, &done_v, err, sizeof err);
    if (rc == WDR_OK) { /* an extension that fits in 32 bits, or a refusal that says why */
        assert_int_equal(wdr_lut_parse(out, out_len, &e), WDR_OK);
        uint32_t t_last;
        uint16_t c_last;
        wdr_lut_entry(&e, e.h.entry_count - 1, &t_last, &c_last);
        printf("  extended: %u entries, last at %u ticks, integration %u ticks, +%.3g mV\n", e.h.entry_count, t_last,
               e.h.t_integration_ticks, done_v * 1e3);
        assert_true(e.h.t_integration_ticks > t_last);
    } else {
        printf("  refused: %s\n", err);
        assert_int_equal(rc, WDR_E_INVAL);
        assert_non_null(strstr(err, "2^32 ticks"));
    }
    free(out);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(steep_ramp_extends_to_a_valid_lut),
                                       cmocka_unit_test(extension_keeps_the_exposure_block),
                                       cmocka_unit_test(extension_near_2_32_ticks_parses)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
