/* The protocol client fed by a hostile board: every request is answered with seeded random
 * bytes, random-length frames that carry the right sequence number, and random ROW and
 * FRAME_END events. Whatever arrives, each call returns OK or an error code, never reads or
 * writes out of bounds (run under ASan+UBSan in CI), and never waits past its timeouts. */
#include "scripted_board.h"
#include "transport.h"
#include "transport_client.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

#define ROUNDS 150

static uint64_t rng_state;
static int connected, captured; /* how far the sessions got, for the report */

static uint32_t rnd(void)
{
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return (uint32_t)(rng_state >> 33);
}

static void send_junk(scripted_board *b)
{
    uint8_t junk[300];
    uint32_t n = rnd() % sizeof junk;
    for (uint32_t i = 0; i < n; i++)
        junk[i] = (uint8_t)(rnd() % 4 == 0 ? 'W' : rnd() % 4 == 0 ? 'D' : rnd());
    fake_send_raw(b, junk, n);
}

static void send_random_frame(scripted_board *b, const wdr_packet *req)
{
    uint8_t payload[600];
    uint32_t len = rnd() % sizeof payload;
    for (uint32_t i = 0; i < len; i++)
        payload[i] = (uint8_t)rnd();
    if (len >= 8 && rnd() % 2) { /* a ROW that looks plausible: small row and width */
        wdr_put_u16(payload + 4, (uint16_t)(rnd() % 12));
        wdr_put_u16(payload + 6, (uint16_t)(rnd() % 2 ? 16 : rnd() % 40));
    }
    uint32_t kind = rnd() % 4;
    if (kind == 0) {
        fake_reply(b, req, (int)(rnd() % 16), payload, len);
    } else if (kind == 1) {
        fake_event(b, WDR_CMD_ROW, req->h.seq, payload, len);
    } else if (kind == 2) {
        fake_event(b, WDR_CMD_FRAME_END, req->h.seq, payload, len < WDR_FRAME_END_SIZE ? len : WDR_FRAME_END_SIZE);
    } else {
        wdr_packet other = *req;
        other.h.opcode = (uint8_t)rnd();
        fake_reply(b, &other, WDR_ST_OK, payload, len);
    }
}

static int script_hostile(scripted_board *b, const wdr_packet *req, int n)
{
    (void)n;
    if (req->h.opcode == WDR_CMD_INFO && rnd() % 2) {
        fake_reply_info(b, req, WDR_PROTO_VERSION_MAJOR); /* sometimes let the client in */
        return 0;
    }
    for (uint32_t k = rnd() % 4; k > 0; k--) {
        if (rnd() % 2)
            send_junk(b);
        else
            send_random_frame(b, req);
    }
    return rnd() % 50 == 0 ? -1 : 0; /* now and then, unplug */
}

static void one_round(uint64_t seed)
{
    int sv[2];
    scripted_board b = {.width = 16, .height = 8};
    wdr_transport *t;
    wdr_client *c = calloc(1, sizeof *c);
    rng_state = seed;
    assert_int_equal(socketpair(AF_UNIX, SOCK_STREAM, 0, sv), 0);
    scripted_board_start_fd(&b, sv[1], script_hostile);
    assert_int_equal(wdr_transport_from_fd(sv[0], "fuzz", &t), WDR_OK);
    c->timeout_ms = 5;
    c->retries = 1;
    int rc = wdr_client_connect(c, t);
    assert_true(rc <= 0);
    if (rc == WDR_OK) {
        connected++;
        wdr_status_report st;
        uint8_t table[5000] = {0};
        uint16_t codes[16 * 8];
        assert_true(wdr_client_status(c, &st) <= 0);
        assert_true(wdr_client_upload(c, WDR_KIND_LUT, table, sizeof table, NULL, NULL, NULL) <= 0);
        if (c->info.width == 16 && c->info.height == 8) {
            captured++;
            assert_true(wdr_client_capture(c, 2, codes, NULL, NULL) <= 0);
        }
    }
    assert_true(strlen(c->err) < sizeof c->err);
    wdr_transport_close(t);
    scripted_board_stop(&b);
    free(c);
}

static void hostile_board(void **state)
{
    (void)state;
    int64_t t0 = wdr_transport_now_ms();
    for (uint64_t seed = 1; seed <= ROUNDS; seed++)
        one_round(seed * 0x9e3779b97f4a7c15ull);
    print_message("%d hostile sessions in %lld ms: %d connected, %d reached a capture\n", ROUNDS,
                  (long long)(wdr_transport_now_ms() - t0), connected, captured);
    assert_true(connected > ROUNDS / 4 && captured > 0); /* the fuzz got past the front door */
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(hostile_board)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
