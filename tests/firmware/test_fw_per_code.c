/* The firmware activates a BASIS table at one point per raw code (wdr_correct_per_code), so
 * READOUT does one dot product per pixel: after an upload, after a reboot, after a refused
 * upload and after another form came and went, the active view has a point for every code of
 * the board's ADC and every captured pixel is the table's value. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "crc32.h"
#include "harness.h"
#include <math.h>
#include <string.h>

static wdr_fw fw;
static uint8_t lut[WDR_FW_LUT_MAX_BYTES], moebius[64 + 48 * (64 * 12 + 64)];
static uint8_t basis[64 + 2 * 1025 * 4 + FB_HEIGHT * (FB_WIDTH * 8 + FB_WIDTH)];
static size_t lut_len, moebius_len, basis_len;

static int setup(void **state)
{
    (void)state;
    fb_init();
    th_boot(&fw);
    lut_len = th_make_lut(lut, 500, 0, FB_DAC_BITS);
    moebius_len = th_make_cal(moebius, 0.5f, 10.0f, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT);
    basis_len = th_make_cal_basis(basis, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT, 0);
    assert_true(basis_len <= sizeof basis);
    return th_upload(&fw, WDR_KIND_LUT, lut, (uint32_t)lut_len, 4096, NULL) != WDR_ST_OK;
}

/* The active table is the stored BASIS table, held as one point per code of the ADC (not the
 * stored block in fw.cal_shared), and a captured frame is its map within the output rounding. */
static void assert_per_code_basis_active(void)
{
    assert_int_equal(th_status(&fw).cal_crc, wdr_crc32(0, basis, basis_len));
    assert_int_equal(fw.cal.h.form, WDR_FORM_BASIS);
    assert_int_equal(fw.cal.h.shared_points, 1u << FB_ADC_BITS);
    assert_true(fw.cal.h.in_scale == 1.0f && fw.cal.h.in_offset == 0.0f);
    assert_true(fw.cal.shared != fw.cal_shared[0] && fw.cal.shared != fw.cal_shared[1]);
    assert_int_equal(th_capture_frames(&fw, 1), WDR_ST_OK);
    assert_int_equal(th_cap.rows, FB_HEIGHT);
    for (int r = 0; r < FB_HEIGHT; r++)
        for (int c = 0; c < FB_WIDTH; c++) {
            float want = th_basis_expect(r, c, (float)fb_pattern(r, c));
            assert_true(fabsf((float)th_cap.px[r][c] - want) <= 0.51f);
        }
}

static void basis_runs_per_code_after_upload_reboot_and_refusal(void **state)
{
    (void)state;
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, basis, (uint32_t)basis_len, 4096, NULL), WDR_ST_OK);
    assert_per_code_basis_active();
    fb_power_cycle();
    th_boot(&fw); /* the points live in RAM only: boot builds them again */
    assert_per_code_basis_active();
    static uint8_t poisoned[sizeof basis];
    size_t plen = th_make_cal_basis(poisoned, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT, 1);
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, poisoned, (uint32_t)plen, 4096, NULL), WDR_ST_BAD_TABLE);
    assert_per_code_basis_active();
}

/* A Moebius table replaces the per-code view (no shared block), and BASIS again rebuilds it;
 * rows are read from the right place of each stored table in turn. */
static void other_forms_in_between(void **state)
{
    (void)state;
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, moebius, (uint32_t)moebius_len, 4096, NULL), WDR_ST_OK);
    assert_null(fw.cal.shared);
    assert_int_equal(th_capture_frames(&fw, 1), WDR_ST_OK);
    assert_int_equal(th_cap.px[FB_HEIGHT - 1][5], (uint16_t)(0.5f * fb_pattern(FB_HEIGHT - 1, 5) + 10.0f + 0.5f));
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, basis, (uint32_t)basis_len, 4096, NULL), WDR_ST_OK);
    assert_per_code_basis_active();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(basis_runs_per_code_after_upload_reboot_and_refusal),
        cmocka_unit_test(other_forms_in_between),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
