/* The real firmware on the simulated board (served from a thread of this test), with faults
 * injected on its USB link at the HAL boundary: a lost request, a damaged answer, a damaged
 * row, a pulled cable. The host recovers where the protocol says it can (a retry with the same
 * sequence number gets the cached answer, and nothing runs twice) and reports the rest. */
#include "e2e_board.h"
#include "hal.h"
#include "hal_sim_emul.h"
#include "simboard_loop.h"
#include "wdr_err.h"
#include "wdr_sim.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static wdr_board board;
static pthread_t server;
static char dir[64], address[160];
static wdr_transport *t;
static wdr_client *c;
static uint8_t *lut;
static size_t lut_len;

static void *serve(void *arg)
{
    (void)arg;
    simboard_serve();
    return NULL;
}

static int setup(void **state)
{
    (void)state;
    char path[512], err[512], sock[128];
    wdr_board_defaults(&board);
    wdr_board_path("sim-qvga", path, sizeof path);
    snprintf(dir, sizeof dir, "/tmp/wdr-faults-XXXXXX");
    if (wdr_board_load(path, &board, err, sizeof err) != WDR_OK || !mkdtemp(dir))
        return -1;
    snprintf(sock, sizeof sock, "%s/board.sock", dir);
    snprintf(address, sizeof address, "sim:%s", sock);
    hal_sim_config cfg = {.board = &board, .seed = 1, .frame_seed = 1, .socket_path = sock};
    if (hal_sim_setup(&cfg, err, sizeof err) != WDR_OK || hal_init() != WDR_OK)
        return -1;
    hal_sim_set_illuminant(1e-11);
    for (int fx = 0; fx < WDR_FX_COUNT; fx++)
        wdr_sim_set_effect(hal_sim_sensor(), fx, fx == WDR_FX_DAC_QUANT || fx == WDR_FX_ADC_QUANT ? WDR_FX_ON : WDR_FX_OFF);
    if (pthread_create(&server, NULL, serve, NULL) != 0 || e2e_reinhard_lut(&board, &lut, &lut_len) != WDR_OK)
        return -1;
    c = calloc(1, sizeof *c);
    c->timeout_ms = 300;
    c->retries = 2;
    return wdr_transport_open(address, &t, err, sizeof err) == WDR_OK && wdr_client_connect(c, t) == WDR_OK ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    wdr_transport_close(t);
    hal_sim_request_stop();
    pthread_join(server, NULL);
    hal_sim_teardown();
    free(c);
    free(lut);
    rmdir(dir);
    return 0;
}

static void lost_request_is_retried(void **state)
{
    (void)state;
    wdr_status_report st;
    uint32_t before = c->retries_used;
    hal_sim_usb_drop_rx(WDR_PROTO_HEADER_SIZE); /* the STATUS request vanishes */
    assert_int_equal(wdr_client_status(c, &st), WDR_OK);
    assert_int_equal(c->retries_used, before + 1);
    assert_int_equal(st.rx_skipped, 0); /* the board lost a whole frame; it never saw a piece */
}

/* A damaged answer to an upload's first CHUNK: the retry must get the board's cached answer; a
 * second run of the chunk would find its offset already taken (BAD_SEQUENCE) and fail the upload. */
static void damaged_answer_is_resent_not_rerun(void **state)
{
    (void)state;
    wdr_commit_reply reply;
    uint32_t before = c->retries_used;
    /* BEGIN's answer (a bare header) passes; the CHUNK answer's header CRC is hit. */
    hal_sim_usb_corrupt_tx(WDR_PROTO_HEADER_SIZE + WDR_PROTO_HEADER_SIZE - 2);
    assert_int_equal(wdr_client_upload(c, WDR_KIND_LUT, lut, lut_len, NULL, NULL, &reply), WDR_OK);
    assert_true(c->retries_used >= before + 1);
    wdr_status_report st;
    assert_int_equal(wdr_client_status(c, &st), WDR_OK);
    assert_int_equal(st.lut_crc, reply.crc);
}

/* A damaged row cannot be asked for again: the frame is reported incomplete, and the next
 * capture is whole. */
static void damaged_row_is_reported(void **state)
{
    (void)state;
    uint16_t *codes = malloc((size_t)board.width * board.height * sizeof *codes);
    /* Some way into the frame's rows: whether it hits a sync byte, a header or a payload, that
     * row is lost (each QVGA row frame is 348 bytes, the answers before them under 100). */
    hal_sim_usb_corrupt_tx(5000);
    int rc = wdr_client_capture(c, 1, codes, NULL, NULL);
    assert_int_equal(rc, WDR_E_FRAME);
    assert_non_null(strstr(c->err, "missing"));
    assert_int_equal(wdr_client_capture(c, 1, codes, NULL, NULL), WDR_OK);
    free(codes);
}

static void pulled_cable_mid_capture(void **state)
{
    (void)state;
    uint16_t *codes = malloc((size_t)board.width * board.height * sizeof *codes);
    hal_sim_usb_unplug();
    int rc = wdr_client_capture(c, 50, codes, NULL, NULL);
    assert_int_equal(rc, WDR_E_IO);
    assert_non_null(strstr(c->err, "disconnected"));
    free(codes);
    /* Plugged in again: a new connection works. */
    char err[320];
    wdr_transport_close(t);
    assert_int_equal(wdr_transport_open(address, &t, err, sizeof err), WDR_OK);
    assert_int_equal(wdr_client_connect(c, t), WDR_OK);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(lost_request_is_retried),
        cmocka_unit_test(damaged_answer_is_resent_not_rerun),
        cmocka_unit_test(damaged_row_is_reported),
        cmocka_unit_test(pulled_cable_mid_capture),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
