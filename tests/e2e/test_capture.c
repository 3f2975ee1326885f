/* End to end: wdr-simboard (firmware on the simulated HAL) on a socket, a Reinhard LUT uploaded
 * through the protocol client, the default scene captured with fixed-pattern and noise effects
 * off, and the frame compared with the same scene tone-mapped in software (ideal pixel under the
 * quantised LUT, nominal source follower, board ADC). The same again through the wdrctl program. */
#include "e2e_board.h"
#include "crc32.h"
#include "image_io.h"
#include "wdr_err.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sysexits.h>
#include <unistd.h>

#ifndef WDRCTL_PATH
#error "WDRCTL_PATH must name the wdrctl program"
#endif

static e2e_board rig;
static uint8_t *lut;
static size_t lut_len;
static uint16_t *board_frame;

static int setup(void **state)
{
    (void)state;
    if (e2e_start(&rig, "sim-vga") != 0 || e2e_reinhard_lut(&rig.board, &lut, &lut_len) != WDR_OK)
        return -1;
    board_frame = calloc((size_t)rig.board.width * rig.board.height, sizeof *board_frame);
    return board_frame ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    e2e_stop(&rig);
    free(lut);
    free(board_frame);
    return 0;
}

static void upload_reinhard(void **state)
{
    (void)state;
    wdr_commit_reply reply;
    assert_int_equal(wdr_client_upload(rig.c, WDR_KIND_LUT, lut, lut_len, NULL, NULL, &reply), WDR_OK);
    assert_int_equal(reply.crc, wdr_crc32(0, lut, lut_len));
    wdr_status_report st;
    assert_int_equal(wdr_client_status(rig.c, &st), WDR_OK);
    assert_int_equal(st.lut_slot, reply.slot);
    assert_int_equal(st.lut_crc, reply.crc);
}

static void capture_matches_software(void **state)
{
    (void)state;
    size_t n = (size_t)rig.board.width * rig.board.height;
    uint16_t *soft = malloc(n * sizeof *soft);
    assert_int_equal(wdr_client_capture(rig.c, 1, board_frame, NULL, NULL), WDR_OK);
    assert_int_equal(e2e_software_frame(&rig.board, rig.scene_path, lut, lut_len, soft), WDR_OK);
    int worst = 0, lo = 65535, hi = 0;
    size_t differ = 0;
    for (size_t i = 0; i < n; i++) {
        int d = abs((int)board_frame[i] - (int)soft[i]);
        worst = d > worst ? d : worst;
        differ += d != 0;
        lo = soft[i] < lo ? soft[i] : lo;
        hi = soft[i] > hi ? soft[i] : hi;
    }
    printf("e2e: %zu pixels, %zu differ from the software model, worst %d ADC LSB; scene spans codes %d..%d\n", n,
           differ, worst, lo, hi);
    /* Both sides quantise the same DAC steps and ADC codes; what is left is float rounding at
     * an ADC code boundary: one LSB, on few pixels. */
    assert_true(worst <= 1);
    assert_true(differ <= n / 100);
    assert_true(hi - lo > 1000); /* six decades mapped onto most of the ADC range, not a flat frame */
    free(soft);
}

static void frames_are_repeatable(void **state)
{
    (void)state;
    size_t n = (size_t)rig.board.width * rig.board.height;
    uint16_t *again = malloc(n * sizeof *again);
    assert_int_equal(wdr_client_capture(rig.c, 2, again, NULL, NULL), WDR_OK);
    assert_memory_equal(again, board_frame, n * sizeof *again); /* no noise: every frame the same */
    free(again);
}

/* The same board through the command-line program: upload the LUT file, capture a PFM. */
static void wdrctl_program_end_to_end(void **state)
{
    (void)state;
    char lut_path[128], pfm_path[128], err[256];
    snprintf(lut_path, sizeof lut_path, "%s/reinhard.lut", rig.dir);
    snprintf(pfm_path, sizeof pfm_path, "%s/frame.pfm", rig.dir);
    FILE *f = fopen(lut_path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(lut, 1, lut_len, f), lut_len);
    fclose(f);
    wdr_transport_close(rig.t); /* one host at a time, as on a USB port */
    rig.t = NULL;
    char *upload[] = {WDRCTL_PATH, "lut", "upload", lut_path, "--device", rig.address, NULL};
    char *capture[] = {WDRCTL_PATH, "capture", "-o", pfm_path, "--device", rig.address, NULL};
    assert_int_equal(e2e_run(upload, 30), EX_OK);
    assert_int_equal(e2e_run(capture, 30), EX_OK);
    float *px;
    int w, h;
    assert_int_equal(wdr_pfm_read(pfm_path, &px, &w, &h, err, sizeof err), WDR_OK);
    assert_int_equal(w, rig.board.width);
    assert_int_equal(h, rig.board.height);
    for (long i = 0; i < (long)w * h; i++)
        assert_int_equal((int)px[i], board_frame[i]);
    free(px);
}

/* The simulation-only command: a uniform illuminant, as automated calibration uses it. */
static void illuminant_lights_every_pixel(void **state)
{
    (void)state;
    size_t n = (size_t)rig.board.width * rig.board.height;
    uint16_t *frame = malloc(n * sizeof *frame);
    assert_int_equal(e2e_reconnect(&rig), 0);
    for (double amps = 1e-13; amps < 2e-8; amps *= 100) {
        assert_int_equal(wdr_client_set_illuminant(rig.c, amps), WDR_OK);
        assert_int_equal(wdr_client_capture(rig.c, 1, frame, NULL, NULL), WDR_OK);
        int want = e2e_software_code(&rig.board, lut, lut_len, amps);
        for (size_t i = 0; i < n; i++)
            assert_true(abs((int)frame[i] - want) <= 1);
    }
    assert_int_equal(wdr_client_set_illuminant(rig.c, -1.0), WDR_E_STATUS);
    free(frame);
}

static void wdrctl_stream_runs(void **state)
{
    (void)state;
    wdr_transport_close(rig.t);
    rig.t = NULL;
    char *stream[] = {WDRCTL_PATH, "stream", "-n", "3", "--device", rig.address, NULL};
    assert_int_equal(e2e_run(stream, 30), EX_OK);
    char *illum[] = {WDRCTL_PATH, "sim", "illuminant", "1e-11", "--device", rig.address, NULL};
    assert_int_equal(e2e_run(illum, 30), EX_OK);
    char *devices[] = {WDRCTL_PATH, "devices", "--device", rig.address, NULL};
    assert_int_equal(e2e_run(devices, 30), EX_OK);
}

/* The board ends by itself, cleanly (status 0: no sanitizer report either), when the pipe on
 * its stdin closes: a parent that dies takes its board along. */
static void board_exits_on_parent_eof(void **state)
{
    (void)state;
    close(rig.stdin_fd);
    rig.stdin_fd = -1;
    assert_int_equal(e2e_wait_exit(&rig, 10000), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(upload_reinhard),
        cmocka_unit_test(capture_matches_software),
        cmocka_unit_test(frames_are_repeatable),
        cmocka_unit_test(wdrctl_program_end_to_end),
        cmocka_unit_test(illuminant_lights_every_pixel),
        cmocka_unit_test(wdrctl_stream_runs),
        cmocka_unit_test(board_exits_on_parent_eof),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
