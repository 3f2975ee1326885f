/* Faults issue 14's fuzzing found in the host's protocol client, each reproduced against a
 * scripted board: INFO answers with adc_bits 40 or 0, or a 0x0 sensor, were taken as they came
 * (an undefined shift, a 0x0 image written with exit 0); a board that hangs up during a stream
 * left the client's event callback pointing into the stream function's returned frame; and a
 * board that never answers (another host holds it) gave no word of why. */
#include "scripted_board.h"
#include "transport.h"
#include "transport_client.h"
#include "wdr_err.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

static wdr_info bad_info;

static int script_info(scripted_board *b, const wdr_packet *req, int n)
{
    (void)n;
    uint8_t p[WDR_INFO_SIZE];
    wdr_info_pack(&bad_info, p);
    fake_reply(b, req, WDR_ST_OK, p, sizeof p);
    return 0;
}

/* Connect c over a socketpair to a scripted board; the caller stops b and closes *t. */
static void connect_to(scripted_board *b, fake_script script, wdr_client *c, wdr_transport **t, int *rc)
{
    int sv[2];
    assert_int_equal(socketpair(AF_UNIX, SOCK_STREAM, 0, sv), 0);
    scripted_board_start_fd(b, sv[1], script);
    assert_int_equal(wdr_transport_from_fd(sv[0], "scripted", t), WDR_OK);
    c->timeout_ms = 100;
    c->retries = 0;
    *rc = wdr_client_connect(c, *t);
}

static void expect_info_refused(const char *field, uint16_t w, uint16_t h, uint8_t adc, uint8_t dac)
{
    bad_info = (wdr_info){.proto_major = WDR_PROTO_VERSION_MAJOR, .fw_major = 1, .width = w, .height = h,
                          .adc_bits = adc, .dac_bits = dac, .max_payload = WDR_PROTO_MAX_PAYLOAD};
    scripted_board b = {.width = w, .height = h};
    wdr_client *c = calloc(1, sizeof *c);
    wdr_transport *t;
    int rc;
    connect_to(&b, script_info, c, &t, &rc);
    printf("%ux%u adc %u dac %u -> %d: %s\n", w, h, adc, dac, rc, c->err);
    assert_int_equal(rc, WDR_E_PROTOCOL);
    assert_non_null(strstr(c->err, field));
    wdr_transport_close(t);
    scripted_board_stop(&b);
    free(c);
}

static void info_fields_validated(void **state)
{
    (void)state;
    expect_info_refused("'adc_bits' is 40", 16, 8, 40, 12);
    expect_info_refused("'adc_bits' is 0", 16, 8, 0, 12);
    expect_info_refused("'dac_bits' is 17", 16, 8, 12, 17);
    expect_info_refused("'width' is 0", 0, 0, 12, 12);
    expect_info_refused("'height' is 0", 16, 0, 12, 12);
}

/* Good answers, until the stream starts: then hang up. */
static int script_hangs_up_in_stream(scripted_board *b, const wdr_packet *req, int n)
{
    if (req->h.opcode == WDR_CMD_STREAM)
        return -1;
    return fake_script_good(b, req, n);
}

static void stream_cut_leaves_no_dangling_callback(void **state)
{
    (void)state;
    scripted_board b = {.width = 16, .height = 8};
    wdr_client *c = calloc(1, sizeof *c);
    wdr_transport *t;
    int rc;
    connect_to(&b, script_hangs_up_in_stream, c, &t, &rc);
    assert_int_equal(rc, WDR_OK);
    uint16_t codes[16 * 8];
    volatile int stop = 0;
    assert_int_equal(wdr_client_stream(c, codes, NULL, NULL, &stop), WDR_E_IO);
    assert_null(c->on_event); /* it pointed at the stream's own stack frame */
    wdr_transport_close(t);
    scripted_board_stop(&b);
    free(c);
}

static int script_silent(scripted_board *b, const wdr_packet *req, int n)
{
    (void)b, (void)req, (void)n;
    return 0;
}

static void silent_board_named_as_possibly_held(void **state)
{
    (void)state;
    scripted_board b = {.width = 16, .height = 8};
    wdr_client *c = calloc(1, sizeof *c);
    wdr_transport *t;
    int rc;
    connect_to(&b, script_silent, c, &t, &rc);
    printf("-> %d: %s\n", rc, c->err);
    assert_int_equal(rc, WDR_E_TIMEOUT);
    assert_non_null(strstr(c->err, "another host"));
    wdr_transport_close(t);
    scripted_board_stop(&b);
    free(c);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(info_fields_validated),
        cmocka_unit_test(stream_cut_leaves_no_dangling_callback),
        cmocka_unit_test(silent_board_named_as_possibly_held),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
