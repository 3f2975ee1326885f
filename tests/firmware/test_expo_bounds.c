/* Auto exposure's arithmetic is defined for every table a board accepts (issue 23): an exposure
 * block whose ln_q8 lies outside +-WDR_LUT_EXPO_MAX_LN_Q8 is refused at COMMIT (BAD_TABLE), and
 * the largest it accepts, on a ramp whose tick may shrink 2^31 times, drives the gain past
 * 8,600/256 ln, where tick_for_gain's shift used to reach 64 (undefined: UBSan stops the asan
 * build there). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "harness.h"
#include "crc32.h"
#include "wdr_bytes.h"
#include "wdr_lut.h"
#include <string.h>

static wdr_fw fw;
static uint8_t lut[WDR_LUT_HEADER_SIZE + 16 * WDR_LUT_ENTRY_SIZE + WDR_LUT_EXPO_SIZE];

/* 16 entries 1000 ticks apart at a 2^31 ps tick (a 34 s ramp at its own tick: auto exposure
 * shortens it), then an exposure block whose every bin reads ln_q8. Returns the length. */
static size_t crafted_lut(int16_t ln_q8)
{
    uint32_t t[16];
    uint16_t codes[16];
    wdr_lut_header h;
    memset(&h, 0, sizeof h);
    h.operator_id = WDR_OP_REINHARD;
    h.dac_bits = FB_DAC_BITS;
    h.timing = WDR_TIMING_STAMPED;
    h.entry_count = 16;
    h.tick_ps = 1u << 31;
    h.t_integration_ticks = 16 * 1000u + 500u;
    h.dac_lo_v = 0.0f;
    h.dac_hi_v = 3.3f;
    for (uint32_t i = 0; i < 16; i++) {
        t[i] = i * 1000u;
        codes[i] = (uint16_t)(i * 8u);
    }
    wdr_lut_encode(&h, t, codes, lut);
    wdr_lut_exposure ex = {.code_shift = FB_ADC_BITS - 6, .bins = WDR_LUT_EXPO_BINS};
    for (uint32_t b = 0; b < WDR_LUT_EXPO_BINS; b++)
        ex.ln_q8[b] = ln_q8;
    size_t end = wdr_lut_size(16);
    wdr_lut_exposure_encode(&ex, lut + end); /* its CRC right: only the range check can refuse it */
    return end + WDR_LUT_EXPO_SIZE;
}

static int setup(void **state)
{
    (void)state;
    fb_init();
    th_boot(&fw);
    return 0;
}

static void ln_out_of_range_is_refused(void **state)
{
    (void)state;
    size_t len = crafted_lut(32767);
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, lut, (uint32_t)len, 4096, NULL), WDR_ST_BAD_TABLE);
    len = crafted_lut(-WDR_LUT_EXPO_MAX_LN_Q8 - 1);
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, lut, (uint32_t)len, 4096, NULL), WDR_ST_BAD_TABLE);
}

static void largest_gain_steps_stay_defined(void **state)
{
    (void)state;
    size_t len = crafted_lut(WDR_LUT_EXPO_MAX_LN_Q8);
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, lut, (uint32_t)len, 4096, NULL), WDR_ST_OK);
    uint8_t on = 1;
    assert_int_equal(th_request(&fw, WDR_CMD_SET_EXPOSURE, &on, 1, NULL, 0), WDR_ST_OK);
    int32_t top = 0;
    for (int f = 0; f < 6; f++) {
        assert_int_equal(th_capture_frames(&fw, 1), WDR_ST_OK);
        wdr_status_report st = th_status(&fw);
        assert_true(st.tick_ps >= 1); /* the tick stops at a limit, never 0 */
        top = st.key_gain_q8 > top ? st.key_gain_q8 : top;
    }
    print_message("gain reached %d/256 ln, tick %u ps\n", top, th_status(&fw).tick_ps);
    assert_true(top > 4096); /* past one step: the loop tried gains where the old shift overflowed */
}

/* The dark-current field (flags bit 1): read back as written, with or without the droop array and
 * the linear-dark bit;
 * a reserved half not 0, a value past +-WDR_LUT_EXPO_MAX_LN_Q8 or an unknown flag bit refused. */
static void dark_field_round_trips_and_is_checked(void **state)
{
    (void)state;
    static uint8_t block[WDR_LUT_EXPO_BLOCK_SIZE_FOR(WDR_LUT_EXPO_BINS, WDR_LUT_EXPO_FLAGS)];
    static wdr_lut_exposure ex, back;
    for (unsigned flags = WDR_LUT_EXPO_DARK; flags <= WDR_LUT_EXPO_FLAGS; flags++) {
        if (!(flags & WDR_LUT_EXPO_DARK))
            continue;
        memset(&ex, 0, sizeof ex);
        ex.bins = WDR_LUT_EXPO_BINS, ex.code_shift = 6, ex.flags = (uint8_t)flags, ex.dark_ln_q8 = -2237;
        for (uint32_t b = 0; b < WDR_LUT_EXPO_BINS; b++)
            ex.ln_q8[b] = (int16_t)(1000 - 30 * (int)b), ex.droop_q8[b] = (int16_t)(flags & 1u ? 127 - (int)b : 0);
        size_t len = WDR_LUT_EXPO_BLOCK_SIZE_FOR(ex.bins, flags);
        wdr_lut_exposure_encode(&ex, block);
        assert_int_equal(wdr_lut_exposure_parse(block, len, &back), WDR_OK);
        assert_int_equal(back.flags, flags);
        assert_int_equal(back.dark_ln_q8, -2237);
        assert_memory_equal(back.droop_q8, ex.droop_q8, sizeof ex.droop_q8[0] * WDR_LUT_EXPO_BINS);
        assert_int_equal(wdr_lut_exposure_parse(block, len - 4, &back), WDR_E_INVAL); /* the field cut off */
        uint8_t *dark = block + len - 8;
        wdr_put_u16(dark + 2, 1); /* reserved */
        wdr_put_u32(block + len - 4, wdr_crc32(0, block, len - 4));
        assert_int_equal(wdr_lut_exposure_parse(block, len, &back), WDR_E_INVAL);
        wdr_put_u16(dark + 2, 0);
        wdr_put_u16(dark, (uint16_t)(int16_t)(-WDR_LUT_EXPO_MAX_LN_Q8 - 1));
        wdr_put_u32(block + len - 4, wdr_crc32(0, block, len - 4));
        assert_int_equal(wdr_lut_exposure_parse(block, len, &back), WDR_E_INVAL);
    }
    ex.flags = 8u;                       /* no such bit */
    wdr_lut_exposure_encode(&ex, block); /* the encoder drops it: write it by hand */
    block[7] = 8u;
    wdr_put_u32(block + WDR_LUT_EXPO_BLOCK_SIZE_FOR(ex.bins, 0) - 4,
                wdr_crc32(0, block, WDR_LUT_EXPO_BLOCK_SIZE_FOR(ex.bins, 0) - 4));
    assert_int_equal(wdr_lut_exposure_parse(block, WDR_LUT_EXPO_BLOCK_SIZE_FOR(ex.bins, 0), &back), WDR_E_INVAL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(ln_out_of_range_is_refused, setup),
        cmocka_unit_test_setup(largest_gain_steps_stay_defined, setup),
        cmocka_unit_test(dark_field_round_trips_and_is_checked),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
