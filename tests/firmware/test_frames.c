/* The frame state machine and the protocol around it, on the fake board: identity and
 * calibrated rows, frame timing from LUT and board, busy, retries, version check, the
 * simulation-only illuminant. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "crc32.h"
#include "harness.h"
#include <math.h>
#include <string.h>

static wdr_fw fw;
static uint8_t lut[WDR_FW_LUT_MAX_BYTES], cal[64 + 48 * (64 * 12 + 64)];
static size_t lut_len, cal_len;

static int setup(void **state)
{
    (void)state;
    fb_init();
    th_boot(&fw);
    lut_len = th_make_lut(lut, 500, 0, FB_DAC_BITS);
    cal_len = th_make_cal(cal, 0.5f, 10.0f, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT);
    return 0;
}

static void info_checks_version(void **state)
{
    (void)state;
    uint8_t ver[4], out[WDR_INFO_SIZE];
    wdr_info in;
    wdr_put_u16(ver, WDR_PROTO_VERSION_MAJOR);
    wdr_put_u16(ver + 2, 7);
    assert_int_equal(th_request(&fw, WDR_CMD_INFO, ver, 4, out, sizeof out), WDR_ST_OK);
    assert_int_equal(wdr_info_unpack(out, sizeof out, &in), WDR_OK);
    assert_int_equal(in.sensor_id, FB_SENSOR_ID);
    assert_int_equal(in.width, FB_WIDTH);
    assert_int_equal(in.height, FB_HEIGHT);
    assert_int_equal(in.caps, WDR_INFO_CAP_ILLUMINANT);
    assert_string_equal(in.name, "fake-board");
    assert_true(in.lut_capacity >= WDR_FW_LUT_MAX_BYTES && in.cal_capacity >= cal_len);
    wdr_put_u16(ver, WDR_PROTO_VERSION_MAJOR + 1);
    assert_int_equal(th_request(&fw, WDR_CMD_INFO, ver, 4, out, sizeof out), WDR_ST_BAD_VERSION);
    assert_int_equal(th_request(&fw, WDR_CMD_INFO, ver, 2, NULL, 0), WDR_ST_BAD_LENGTH);
    assert_int_equal(th_request(&fw, 0x5e, NULL, 0, NULL, 0), WDR_ST_UNSUPPORTED);
}

static void capture_without_calibration_is_identity(void **state)
{
    (void)state;
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, lut, (uint32_t)lut_len, 4096, NULL), WDR_ST_OK);
    assert_int_equal(th_capture_frames(&fw, 1), WDR_ST_OK);
    assert_int_equal(th_cap.rows, FB_HEIGHT);
    assert_int_equal(th_cap.frame_ends, 1);
    assert_int_equal(th_cap.last_end.rows, FB_HEIGHT);
    assert_int_equal(th_cap.last_end.flags, 0);
    for (int r = 0; r < FB_HEIGHT; r++)
        for (int c = 0; c < FB_WIDTH; c++)
            assert_int_equal(th_cap.px[r][c], fb_pattern(r, c));
}

/* Reset pulse + the LUT's integration + one row time per row, in virtual time. */
static void frame_timing_follows_lut_and_board(void **state)
{
    (void)state;
    uint32_t integration = (uint32_t)(500u * 100u + 50u); /* ticks of 1 ns */
    assert_int_equal(th_cap.last_end.integration_ns, integration); /* FRAME_END of the last test */
    wdr_status_report s = th_status(&fw);
    assert_int_equal(s.integration_ns, integration);
    assert_int_equal(s.frame_time_ns, WDR_FW_RESET_NS + integration + (FB_HEIGHT - 1) * FB_ROW_TIME_NS);
    uint8_t ns[4];
    wdr_put_u32(ns, 1000000);
    assert_int_equal(th_request(&fw, WDR_CMD_SET_INTEGRATION, ns, 4, NULL, 0), WDR_ST_OK);
    assert_int_equal(th_capture_frames(&fw, 2), WDR_ST_OK);
    assert_int_equal(th_cap.frame_ends, 2);
    assert_int_equal(fb_ramp_ticks(), 1000000);
    assert_int_equal(th_status(&fw).frame_time_ns, WDR_FW_RESET_NS + 1000000 + (FB_HEIGHT - 1) * FB_ROW_TIME_NS);
    wdr_put_u32(ns, 49900); /* shorter than the ramp itself */
    assert_int_equal(th_request(&fw, WDR_CMD_SET_INTEGRATION, ns, 4, NULL, 0), WDR_ST_BAD_ARG);
    wdr_put_u32(ns, 0);
    assert_int_equal(th_request(&fw, WDR_CMD_SET_INTEGRATION, ns, 4, NULL, 0), WDR_ST_OK);
    assert_int_equal(th_capture_frames(&fw, 1), WDR_ST_OK);
    assert_int_equal(fb_ramp_ticks(), integration);
}

static void calibration_corrects_every_pixel(void **state)
{
    (void)state;
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, cal, (uint32_t)cal_len, 4096, NULL), WDR_ST_OK);
    assert_int_equal(th_capture_frames(&fw, 1), WDR_ST_OK);
    assert_int_equal(th_cap.rows, FB_HEIGHT);
    assert_int_equal(th_cap.last_end.flags & 1, 1);
    for (int r = 0; r < FB_HEIGHT; r++)
        for (int c = 0; c < FB_WIDTH; c++) {
            float want = 0.5f * fb_pattern(r, c) + 10.0f;
            assert_int_equal(th_cap.px[r][c], (uint16_t)(want + 0.5f));
        }
}

/* Every pixel of a captured frame is th_basis_expect of its raw code (within the rounding). */
static void assert_basis_frame(void)
{
    assert_int_equal(th_capture_frames(&fw, 1), WDR_ST_OK);
    assert_int_equal(th_cap.rows, FB_HEIGHT);
    assert_int_equal(th_cap.last_end.flags & 1, 1);
    for (int r = 0; r < FB_HEIGHT; r++)
        for (int c = 0; c < FB_WIDTH; c++) {
            float want = th_basis_expect(r, c, (float)fb_pattern(r, c));
            assert_true(fabsf((float)th_cap.px[r][c] - want) <= 0.51f);
        }
}

/* A BASIS table (minor version 1): uploads, corrects every pixel through its shared block (held
 * in RAM, rows streamed from flash after it), survives a reboot; a basis table with a NaN in its
 * shared block is refused and leaves the active one, shared block included, in use. */
static void basis_calibration_uploads_survives_reboot_and_corrects(void **state)
{
    (void)state;
    static uint8_t basis[64 + 2 * 1025 * 4 + FB_HEIGHT * (FB_WIDTH * 8 + FB_WIDTH)];
    size_t len = th_make_cal_basis(basis, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT, 0);
    assert_true(len <= sizeof basis);
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, basis, (uint32_t)len, 4096, NULL), WDR_ST_OK);
    assert_int_equal(th_status(&fw).cal_crc, wdr_crc32(0, basis, len));
    assert_basis_frame();
    fb_power_cycle();
    th_boot(&fw);
    assert_int_equal(th_status(&fw).cal_crc, wdr_crc32(0, basis, len));
    assert_basis_frame();
    static uint8_t poisoned[sizeof basis];
    size_t plen = th_make_cal_basis(poisoned, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT, 1);
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, poisoned, (uint32_t)plen, 4096, NULL), WDR_ST_BAD_TABLE);
    assert_int_equal(th_status(&fw).cal_crc, wdr_crc32(0, basis, len));
    assert_basis_frame();
    /* back to a Moebius table: the other forms are unaffected by a basis table before them */
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, cal, (uint32_t)cal_len, 4096, NULL), WDR_ST_OK);
    assert_int_equal(th_capture_frames(&fw, 1), WDR_ST_OK);
    assert_int_equal(th_cap.px[3][5], (uint16_t)(0.5f * fb_pattern(3, 5) + 10.0f + 0.5f));
}

/* Protocol 1.2: a host that opens a session with the new-session flag stops the stream and the
 * upload an earlier host left behind; a 1.0 INFO (no flags) leaves them running. */
static void new_session_stops_what_the_last_host_left(void **state)
{
    (void)state;
    uint8_t on = 1, begin[8], ver[WDR_INFO_REQUEST_SIZE], out[WDR_INFO_SIZE];
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, lut, (uint32_t)lut_len, 4096, NULL), WDR_ST_OK);
    assert_int_equal(th_request(&fw, WDR_CMD_STREAM, &on, 1, NULL, 0), WDR_ST_OK);
    wdr_put_u16(ver, WDR_PROTO_VERSION_MAJOR);
    wdr_put_u16(ver + 2, WDR_PROTO_VERSION_MINOR);
    wdr_put_u32(ver + 4, 0);
    assert_int_equal(th_request(&fw, WDR_CMD_INFO, ver, 4, out, sizeof out), WDR_ST_OK);
    assert_int_equal(th_request(&fw, WDR_CMD_INFO, ver, sizeof ver, out, sizeof out), WDR_ST_OK);
    assert_int_not_equal(th_status(&fw).state, WDR_FW_IDLE);
    wdr_put_u32(ver + 4, WDR_INFO_FLAG_NEW_SESSION);
    assert_int_equal(th_request(&fw, WDR_CMD_INFO, ver, sizeof ver, out, sizeof out), WDR_ST_OK);
    assert_int_equal(th_status(&fw).state, WDR_FW_IDLE);
    wdr_put_u32(begin, (uint32_t)lut_len);
    wdr_put_u32(begin + 4, wdr_crc32(0, lut, lut_len));
    assert_int_equal(th_request(&fw, WDR_CMD_LUT_BEGIN, begin, sizeof begin, NULL, 0), WDR_ST_OK);
    assert_int_not_equal(th_status(&fw).upload_kind, 0);
    assert_int_equal(th_request(&fw, WDR_CMD_INFO, ver, sizeof ver, out, sizeof out), WDR_ST_OK);
    assert_int_equal(th_status(&fw).upload_kind, 0);
    assert_int_equal(th_capture_frames(&fw, 1), WDR_ST_OK); /* not BUSY */
    assert_int_equal(th_cap.frame_ends, 1);
}

static void busy_while_streaming(void **state)
{
    (void)state;
    uint8_t on = 1, off = 0, pl[8];
    wdr_put_u32(pl, 1);
    wdr_put_u32(pl + 4, 0);
    assert_int_equal(th_request(&fw, WDR_CMD_STREAM, &on, 1, NULL, 0), WDR_ST_OK);
    assert_int_equal(th_request(&fw, WDR_CMD_CAPTURE, pl, 4, NULL, 0), WDR_ST_BUSY);
    assert_int_equal(th_request(&fw, WDR_CMD_SET_INTEGRATION, pl + 4, 4, NULL, 0), WDR_ST_BUSY);
    assert_int_equal(th_request(&fw, WDR_CMD_LUT_BEGIN, pl, 8, NULL, 0), WDR_ST_BUSY);
    assert_int_equal(th_request(&fw, WDR_CMD_STREAM, &on, 1, NULL, 0), WDR_ST_BUSY);
    wdr_status_report s = th_status(&fw);
    assert_int_not_equal(s.state, WDR_FW_IDLE);
    uint32_t frames_before = s.frames;
    assert_int_equal(th_request(&fw, WDR_CMD_STREAM, &off, 1, NULL, 0), WDR_ST_OK);
    s = th_status(&fw);
    assert_int_equal(s.state, WDR_FW_IDLE);
    assert_true(s.frames >= frames_before);
    assert_int_equal(th_capture_frames(&fw, 1), WDR_ST_OK);
    assert_int_equal(th_cap.frame_ends, 1);
}

/* A retried request (same seq) gets the same answer and is not executed twice. */
static void retry_is_answered_not_repeated(void **state)
{
    (void)state;
    uint8_t pl[4];
    wdr_put_u32(pl, 2);
    assert_int_equal(th_request_seq(&fw, 7777, WDR_CMD_CAPTURE, pl, 4, NULL, 0), WDR_ST_OK);
    assert_int_equal(th_cap.frame_ends, 2);
    assert_int_equal(th_request_seq(&fw, 7777, WDR_CMD_CAPTURE, pl, 4, NULL, 0), WDR_ST_OK);
    assert_int_equal(th_cap.frame_ends, 0);
    assert_int_equal(th_request_seq(&fw, 7778, WDR_CMD_CAPTURE, pl, 4, NULL, 0), WDR_ST_OK);
    assert_int_equal(th_cap.frame_ends, 2);
    assert_int_equal(th_capture_frames(&fw, 0), WDR_ST_BAD_ARG);
}

static void illuminant_reaches_the_hal(void **state)
{
    (void)state;
    uint8_t pl[8];
    float f = 1e-11f;
    double d = 2.5e-9;
    memcpy(pl, &f, 4);
    assert_int_equal(th_request(&fw, WDR_CMD_SIM_SET_ILLUMINANT, pl, 4, NULL, 0), WDR_ST_OK);
    assert_true(fb_illuminant() == (double)1e-11f);
    memcpy(pl, &d, 8);
    assert_int_equal(th_request(&fw, WDR_CMD_SIM_SET_ILLUMINANT, pl, 8, NULL, 0), WDR_ST_OK);
    assert_true(fb_illuminant() == 2.5e-9);
    d = -1e-12;
    memcpy(pl, &d, 8);
    assert_int_equal(th_request(&fw, WDR_CMD_SIM_SET_ILLUMINANT, pl, 8, NULL, 0), WDR_ST_BAD_ARG);
    wdr_put_u32(pl, 0x7fc00000u); /* NaN */
    assert_int_equal(th_request(&fw, WDR_CMD_SIM_SET_ILLUMINANT, pl, 4, NULL, 0), WDR_ST_BAD_ARG);
    assert_int_equal(th_request(&fw, WDR_CMD_SIM_SET_ILLUMINANT, pl, 3, NULL, 0), WDR_ST_BAD_LENGTH);
    assert_true(fb_illuminant() == 2.5e-9);
    /* 1.4: no payload puts the scene back (the fake board's is 0 A) */
    assert_int_equal(th_request(&fw, WDR_CMD_SIM_SET_ILLUMINANT, NULL, 0, NULL, 0), WDR_ST_OK);
    assert_true(fb_illuminant() == 0.0);
}

/* A sensor that fails mid-frame ends the frame early, flagged, and stops the capture. */
static void sensor_failure_ends_capture(void **state)
{
    (void)state;
    fb_fail_adc_row(17);
    assert_int_equal(th_capture_frames(&fw, 3), WDR_ST_OK);
    fb_fail_adc_row(-1);
    assert_int_equal(th_cap.rows, 17);
    assert_int_equal(th_cap.frame_ends, 1);
    assert_int_equal(th_cap.last_end.rows, 17);
    assert_int_equal(th_cap.last_end.flags & 2, 2);
    assert_int_equal(th_status(&fw).state, WDR_FW_IDLE);
    assert_int_equal(th_capture_frames(&fw, 1), WDR_ST_OK);
    assert_int_equal(th_cap.rows, FB_HEIGHT);
    assert_int_equal(th_cap.last_end.flags & 2, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(info_checks_version),
        cmocka_unit_test(capture_without_calibration_is_identity),
        cmocka_unit_test(frame_timing_follows_lut_and_board),
        cmocka_unit_test(calibration_corrects_every_pixel),
        cmocka_unit_test(basis_calibration_uploads_survives_reboot_and_corrects),
        cmocka_unit_test(busy_while_streaming),
        cmocka_unit_test(new_session_stops_what_the_last_host_left),
        cmocka_unit_test(retry_is_answered_not_repeated),
        cmocka_unit_test(illuminant_reaches_the_hal),
        cmocka_unit_test(sensor_failure_ends_capture),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
