/* Auto exposure on the board, end to end: wdr-simboard (the firmware on the simulated HAL), a
 * Reinhard LUT with its exposure table (LUT 1.1), SET_EXPOSURE auto, and a scene whose brightness
 * steps by 100x twice (a decade below the ramp's key, a decade above, a decade below again). Frame
 * by frame, STATUS reports the key the firmware is exposing for; it must settle on the scene's
 * within 5 % in 8 frames after each step, the DAC tick must follow, and the mean code of the frame
 * must come back to the key's code. Then the limits: a scene far beyond the longest integration
 * stops the tick at it; a damaged block is refused and the LUT in use stays; a LUT without the
 * table refuses auto. */
#include "e2e_board.h"
#include "ramp.h"
#include "wdr_err.h"
#include "wdr_fw_config.h"
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static e2e_board rig;
static uint8_t *lut;
static size_t lut_len;
static uint16_t *frame;
static double key_amp;

static int setup(void **state)
{
    (void)state;
    char err[256];
    if (e2e_start(&rig, "sim-qvga") != 0)
        return -1;
    if (wdr_ramp_board_lut(&rig.board, "reinhard", &lut, &lut_len, NULL, err, sizeof err) != WDR_OK)
        return -1;
    key_amp = 0.18 * rig.board.i_center_a; /* the log-average current the default ramp is built for */
    if (wdr_ramp_lut_append_exposure(&lut, &lut_len, &rig.board, key_amp) != WDR_OK)
        return -1;
    frame = calloc((size_t)rig.board.width * rig.board.height, sizeof *frame);
    return frame ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    e2e_stop(&rig);
    free(lut);
    free(frame);
    return 0;
}

static double mean_code(void)
{
    double s = 0;
    size_t n = (size_t)rig.board.width * rig.board.height;
    for (size_t i = 0; i < n; i++)
        s += frame[i];
    return s / (double)n;
}

typedef struct seen {
    double key_scale, tick_ps, error_ln, integration_ms, code;
} seen;

static seen one_frame(void)
{
    wdr_status_report st;
    seen r;
    assert_int_equal(wdr_client_capture(rig.c, 1, frame, NULL, NULL), WDR_OK);
    assert_int_equal(wdr_client_status(rig.c, &st), WDR_OK);
    assert_int_equal(st.exposure_auto, 1);
    r.key_scale = exp(st.key_gain_q8 / 256.0);
    r.tick_ps = st.tick_ps;
    r.error_ln = st.last_error_q8 / 256.0;
    r.integration_ms = st.integration_ns * 1e-6;
    r.code = mean_code();
    return r;
}

static void converges_on_100x_steps(void **state)
{
    (void)state;
    wdr_commit_reply reply;
    assert_int_equal(wdr_client_upload(rig.c, WDR_KIND_LUT, lut, lut_len, NULL, NULL, &reply), WDR_OK);
    uint8_t fixed = 0, on = 1;
    assert_int_equal(wdr_client_request(rig.c, WDR_CMD_SET_EXPOSURE, &fixed, 1), WDR_OK);
    assert_int_equal(wdr_client_set_illuminant(rig.c, key_amp), WDR_OK);
    assert_int_equal(wdr_client_capture(rig.c, 1, frame, NULL, NULL), WDR_OK);
    double key_code = mean_code(); /* what the scene's log-average should read at the right exposure */
    assert_int_equal(wdr_client_request(rig.c, WDR_CMD_SET_EXPOSURE, &on, 1), WDR_OK);
    const double scenes[3] = {0.1, 10.0, 0.1}; /* times the key: steps of 100x */
    printf("key code %.1f (the scene's log-average at the ramp's key, %.3g A)\n", key_code, key_amp);
    printf("frame | scene/key | measured ln err | key in force | tick ps | integration ms | mean code\n");
    int f = 0;
    for (int step = 0; step < 3; step++) {
        assert_int_equal(wdr_client_set_illuminant(rig.c, key_amp * scenes[step]), WDR_OK);
        seen s = {0};
        for (int k = 0; k < 10; k++, f++) {
            s = one_frame();
            printf("%5d | %9.3g | %+15.3f | x%11.4g | %7.0f | %14.4g | %9.1f\n", f, scenes[step], s.error_ln,
                   s.key_scale, s.tick_ps, s.integration_ms, s.code);
            if (k == 7) /* settled within 8 frames of the step */
                assert_true(fabs(log(s.key_scale / scenes[step])) < 0.05);
        }
        assert_true(fabs(s.error_ln) < 0.03);
        assert_true(fabs(s.tick_ps * scenes[step] / 1000.0 - 1) < 0.05); /* the LUT's own tick is 1000 ps */
        assert_true(fabs(s.code - key_code) < 20);
    }
}

/* 1000x below the key would need 1.46 s of integration: the tick stops at the board's longest. */
static void stops_at_the_longest_integration(void **state)
{
    (void)state;
    assert_int_equal(wdr_client_set_illuminant(rig.c, key_amp * 1e-3), WDR_OK);
    seen s = {0};
    for (int k = 0; k < 12; k++)
        s = one_frame();
    printf("scene 1/1000 of the key: key in force x%.4g, integration %.4g ms, measured error %+.3f ln\n", s.key_scale,
           s.integration_ms, s.error_ln);
    assert_true(s.integration_ms <= WDR_FW_MAX_INTEGRATION_NS * 1e-6);
    assert_true(s.integration_ms > 0.95 * WDR_FW_MAX_INTEGRATION_NS * 1e-6);
    assert_true(s.error_ln < -1); /* it still sees the scene as too dark: it says so */
}

/* A damaged exposure block is refused like any table fault, and the LUT in use stays. */
static void bad_blocks_refused(void **state)
{
    (void)state;
    wdr_status_report before, after;
    assert_int_equal(wdr_client_status(rig.c, &before), WDR_OK);
    uint8_t *bad = malloc(lut_len + 10);
    assert_non_null(bad);
    memcpy(bad, lut, lut_len);
    bad[lut_len - 20] ^= 0x40; /* inside ln_q8: the block's CRC no longer matches */
    int rc = wdr_client_upload(rig.c, WDR_KIND_LUT, bad, lut_len, NULL, NULL, NULL);
    printf("exposure block with a flipped bit: %s\n", wdr_status_name(rig.c->status));
    assert_int_equal(rc, WDR_E_STATUS);
    assert_int_equal(rig.c->status, WDR_ST_BAD_CRC);
    memcpy(bad, lut, lut_len);
    memset(bad + lut_len, 0, 10); /* ten bytes more than a block: not a 1.1 table */
    rc = wdr_client_upload(rig.c, WDR_KIND_LUT, bad, lut_len + 10, NULL, NULL, NULL);
    printf("exposure block and 10 bytes more: %s\n", wdr_status_name(rig.c->status));
    assert_int_equal(rc, WDR_E_STATUS);
    assert_int_equal(rig.c->status, WDR_ST_BAD_TABLE);
    assert_int_equal(wdr_client_status(rig.c, &after), WDR_OK);
    assert_int_equal(after.lut_crc, before.lut_crc);
    assert_int_equal(after.lut_slot, before.lut_slot);
    assert_int_equal(after.exposure_auto, 1);
    free(bad);
}

static void refused_without_table(void **state)
{
    (void)state;
    char err[256];
    uint8_t *plain;
    size_t len;
    wdr_commit_reply reply;
    assert_int_equal(wdr_ramp_board_lut(&rig.board, "reinhard", &plain, &len, NULL, err, sizeof err), WDR_OK);
    assert_int_equal(wdr_client_upload(rig.c, WDR_KIND_LUT, plain, len, NULL, NULL, &reply), WDR_OK);
    uint8_t on = 1;
    int rc = wdr_client_request(rig.c, WDR_CMD_SET_EXPOSURE, &on, 1);
    printf("auto exposure with a LUT without exposure table: %s\n", wdr_status_name(rig.c->status));
    assert_int_equal(rc, WDR_E_STATUS);
    assert_int_equal(rig.c->status, WDR_ST_UNSUPPORTED);
    wdr_status_report st;
    assert_int_equal(wdr_client_status(rig.c, &st), WDR_OK);
    assert_int_equal(st.exposure_auto, 0);
    assert_int_equal(st.exposure_flags & 1, 0);
    free(plain);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(converges_on_100x_steps),
        cmocka_unit_test(stops_at_the_longest_integration),
        cmocka_unit_test(bad_blocks_refused),
        cmocka_unit_test(refused_without_table),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
