/* Faults issue 14's fuzzing found in the calibration path, each reproduced: a table whose
 * shared_points * n_coeffs wraps in u32 (parser, upload to the board, boot from a stored copy)
 * and a view whose n_coeffs its form does not allow (the correction kernel). Under ASan the
 * unfixed code reads far outside its buffers; without it, the wrong status shows it. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "correct.h"
#include "crc32.h"
#include "harness.h"
#include "wdr_err.h"
#include <string.h>

static wdr_fw fw;
static _Alignas(4) uint8_t good[64 + 48 * (64 * 12 + 64)];
static _Alignas(4) uint8_t wrapped[64 + 16 + 48 * (64 * 16 + 64)];
static size_t good_len, wrapped_len;

static int setup(void **state)
{
    (void)state;
    fb_init();
    th_boot(&fw);
    good_len = th_make_cal(good, 0.5f, 0.0f, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT);
    wrapped_len = th_make_cal_wrapped(wrapped, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT);
    return 0;
}

static void wrapped_table_refused_by_parser(void **state)
{
    (void)state;
    assert_int_equal(wrapped_len, sizeof wrapped); /* the encoder made the 16-byte shared block */
    wdr_cal_view v;
    assert_int_equal(wdr_cal_parse(wrapped, wrapped_len, &v), WDR_E_INVAL);
}

static void wrapped_table_refused_by_board(void **state)
{
    (void)state;
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, good, (uint32_t)good_len, 4096, NULL), WDR_ST_OK);
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, wrapped, (uint32_t)wrapped_len, 4096, NULL), WDR_ST_BAD_TABLE);
    wdr_status_report s = th_status(&fw);
    assert_int_equal(s.cal_crc, wdr_crc32(0, good, good_len)); /* the old table stays active */
    fb_power_cycle();
    th_boot(&fw);
    assert_int_equal(th_status(&fw).cal_crc, wdr_crc32(0, good, good_len));
}

static void kernel_refuses_coefficient_counts_its_form_forbids(void **state)
{
    (void)state;
    wdr_cal_view v;
    assert_int_equal(wdr_cal_parse(good, good_len, &v), WDR_OK);
    uint16_t raw[FB_WIDTH] = {0}, out[FB_WIDTH];
    float rawf[FB_WIDTH] = {0}, outf[FB_WIDTH];
    v.h.form = WDR_FORM_POLY;
    v.h.n_coeffs = 0; /* c[n - 1] = c[-1] */
    assert_int_equal(wdr_correct_row(&v, 0, raw, out), WDR_E_INVAL);
    assert_int_equal(wdr_correct_row_f32(&v, 0, rawf, outf), WDR_E_INVAL);
    v.h.n_coeffs = WDR_CAL_MAX_COEFFS + 1; /* writes past c[WDR_CAL_MAX_COEFFS - 1] */
    assert_int_equal(wdr_correct_row(&v, 0, raw, out), WDR_E_INVAL);
    assert_int_equal(wdr_correct_row_f32(&v, 0, rawf, outf), WDR_E_INVAL);
    v.h.n_coeffs = 3; /* the counts the format allows still run */
    assert_int_equal(wdr_correct_row_f32(&v, 0, rawf, outf), WDR_OK);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(wrapped_table_refused_by_parser),
        cmocka_unit_test(wrapped_table_refused_by_board),
        cmocka_unit_test(kernel_refuses_coefficient_counts_its_form_forbids),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
