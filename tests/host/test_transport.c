/* Transport and protocol client against a scripted fake board over a socketpair: timeouts,
 * retries, resynchronisation after garbage, disconnects mid-transfer, bad answers. */
#include "scripted_board.h"
#include "transport.h"
#include "transport_client.h"
#include "crc32.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

typedef struct rig {
    scripted_board board;
    wdr_transport *t;
    wdr_client *c;
} rig;

static rig *rig_start(fake_script script, int timeout_ms)
{
    int sv[2];
    assert_int_equal(socketpair(AF_UNIX, SOCK_STREAM, 0, sv), 0);
    rig *r = calloc(1, sizeof *r);
    r->c = calloc(1, sizeof *r->c);
    scripted_board_start_fd(&r->board, sv[1], script);
    assert_int_equal(wdr_transport_from_fd(sv[0], "test", &r->t), WDR_OK);
    r->c->timeout_ms = timeout_ms;
    r->c->retries = 2;
    return r;
}

static void rig_stop(rig *r)
{
    wdr_transport_close(r->t);
    scripted_board_stop(&r->board);
    free(r->c);
    free(r);
}

/* ---- Transport -------------------------------------------------------------------------------- */

static int script_silent(scripted_board *b, const wdr_packet *req, int n)
{
    (void)b, (void)req, (void)n;
    return 0;
}

static void recv_times_out(void **state)
{
    (void)state;
    rig *r = rig_start(script_silent, 100);
    uint8_t buf[16];
    int64_t t0 = wdr_transport_now_ms();
    assert_int_equal(wdr_transport_recv(r->t, buf, sizeof buf, 100), WDR_E_TIMEOUT);
    int64_t took = wdr_transport_now_ms() - t0;
    assert_true(took >= 90 && took < 2000);
    rig_stop(r);
}

static void peer_close_is_io_error(void **state)
{
    (void)state;
    int sv[2];
    assert_int_equal(socketpair(AF_UNIX, SOCK_STREAM, 0, sv), 0);
    wdr_transport *t;
    assert_int_equal(wdr_transport_from_fd(sv[0], "test", &t), WDR_OK);
    close(sv[1]);
    uint8_t buf[16] = {0};
    assert_int_equal(wdr_transport_recv(t, buf, sizeof buf, 1000), WDR_E_IO);
    assert_int_equal(wdr_transport_send(t, buf, sizeof buf, 1000), WDR_E_IO); /* and no SIGPIPE */
    wdr_transport_close(t);
}

static void send_to_stalled_peer_times_out(void **state)
{
    (void)state;
    int sv[2];
    assert_int_equal(socketpair(AF_UNIX, SOCK_STREAM, 0, sv), 0);
    wdr_transport *t;
    assert_int_equal(wdr_transport_from_fd(sv[0], "test", &t), WDR_OK);
    size_t big = 8 << 20; /* more than any socket buffer holds */
    uint8_t *buf = calloc(1, big);
    assert_int_equal(wdr_transport_send(t, buf, big, 100), WDR_E_TIMEOUT);
    free(buf);
    wdr_transport_close(t);
    close(sv[1]);
}

static void bad_addresses(void **state)
{
    (void)state;
    wdr_transport *t;
    char err[512], path[200];
    assert_int_equal(wdr_transport_open("tcp:1.2.3.4", &t, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "tcp:1.2.3.4"));
    assert_int_equal(wdr_transport_open(NULL, &t, err, sizeof err), WDR_E_INVAL);
    memset(path, 'x', sizeof path - 1);
    path[0] = '/';
    path[sizeof path - 1] = 0;
    char addr[256];
    snprintf(addr, sizeof addr, "sim:%s", path);
    assert_int_equal(wdr_transport_open(addr, &t, err, sizeof err), WDR_E_INVAL);
    assert_int_equal(wdr_transport_open("sim:/nonexistent/dir/board.sock", &t, err, sizeof err), WDR_E_ABSENT);
    assert_non_null(strstr(err, "/nonexistent/dir/board.sock"));
    assert_int_equal(wdr_transport_open("usb:zz", &t, err, sizeof err), WDR_E_INVAL);
    assert_null(t);
    /* No board on this machine's bus (or no USB at all in a container): absent, or libusb
     * could not start; either way a message, not a crash. */
    int rc = wdr_transport_open("usb:250-127", &t, err, sizeof err);
    assert_true(rc == WDR_E_ABSENT || rc == WDR_E_IO);
    assert_true(strlen(err) > 10);
    wdr_usb_board boards[4];
    int found = wdr_transport_list_usb(boards, 4, err, sizeof err);
    assert_true(found >= 0 || found == WDR_E_IO);
}

/* ---- Requests ------------------------------------------------------------------------------------ */

static void connect_and_status(void **state)
{
    (void)state;
    rig *r = rig_start(fake_script_good, 1000);
    assert_int_equal(wdr_client_connect(r->c, r->t), WDR_OK);
    assert_int_equal(r->c->info.width, 16);
    assert_string_equal(r->c->info.name, "fake");
    wdr_status_report s;
    assert_int_equal(wdr_client_status(r->c, &s), WDR_OK);
    assert_int_equal(s.integration_ns, 1000000);
    assert_int_equal(r->c->retries_used, 0);
    rig_stop(r);
}

/* Drops the first INFO: the client must ask again with the same sequence number. */
static uint16_t first_seq;
static int seq_changed; /* checked by the test thread: cmocka asserts only work there */
static int script_drop_first(scripted_board *b, const wdr_packet *req, int n)
{
    if (n == 0) {
        first_seq = req->h.seq;
        return 0;
    }
    seq_changed |= req->h.seq != first_seq;
    return fake_script_good(b, req, n);
}

static void retry_after_timeout(void **state)
{
    (void)state;
    rig *r = rig_start(script_drop_first, 150);
    assert_int_equal(wdr_client_connect(r->c, r->t), WDR_OK);
    assert_int_equal(r->c->retries_used, 1);
    assert_int_equal(r->board.opcodes[WDR_CMD_INFO], 2);
    assert_false(seq_changed);
    rig_stop(r);
}

static void gives_up_after_retries(void **state)
{
    (void)state;
    rig *r = rig_start(script_silent, 100);
    int64_t t0 = wdr_transport_now_ms();
    assert_int_equal(wdr_client_connect(r->c, r->t), WDR_E_TIMEOUT);
    assert_true(wdr_transport_now_ms() - t0 < 5000);
    assert_non_null(strstr(r->c->err, "no answer to INFO after 3 attempt"));
    usleep(50000);
    assert_int_equal(r->board.opcodes[WDR_CMD_INFO], 3);
    rig_stop(r);
}

static int script_garbage_first(scripted_board *b, const wdr_packet *req, int n)
{
    static const uint8_t junk[] = {0x57, 0x44, 0x00, 0x57, 0x13, 0x99, 'W', 'D', 'W', 1, 2, 3};
    fake_send_raw(b, junk, sizeof junk);
    return fake_script_good(b, req, n);
}

static void resyncs_after_garbage(void **state)
{
    (void)state;
    rig *r = rig_start(script_garbage_first, 1000);
    assert_int_equal(wdr_client_connect(r->c, r->t), WDR_OK);
    assert_int_equal(r->c->retries_used, 0);
    assert_true(r->c->dec.skipped >= 12);
    rig_stop(r);
}

static int script_bad_crc_first(scripted_board *b, const wdr_packet *req, int n)
{
    if (n == 0) {
        fake_reply_bad_crc(b, req);
        return 0;
    }
    return fake_script_good(b, req, n);
}

static void garbled_answer_is_asked_again(void **state)
{
    (void)state;
    rig *r = rig_start(script_bad_crc_first, 1000);
    assert_int_equal(wdr_client_connect(r->c, r->t), WDR_OK);
    assert_int_equal(r->c->retries_used, 1);
    rig_stop(r);
}

static int script_wrong_opcode(scripted_board *b, const wdr_packet *req, int n)
{
    (void)n;
    wdr_packet fake = *req;
    fake.h.opcode = WDR_CMD_STATUS;
    fake_reply(b, &fake, WDR_ST_OK, NULL, 0);
    return 0;
}

static void wrong_opcode_is_protocol_error(void **state)
{
    (void)state;
    rig *r = rig_start(script_wrong_opcode, 1000);
    assert_int_equal(wdr_client_connect(r->c, r->t), WDR_E_PROTOCOL);
    rig_stop(r);
}

static int script_old_board(scripted_board *b, const wdr_packet *req, int n)
{
    (void)n;
    fake_reply_info(b, req, WDR_PROTO_VERSION_MAJOR + 1);
    return 0;
}

static void version_mismatch(void **state)
{
    (void)state;
    rig *r = rig_start(script_old_board, 1000);
    assert_int_equal(wdr_client_connect(r->c, r->t), WDR_E_VERSION);
    assert_non_null(strstr(r->c->err, "protocol 2.0"));
    rig_stop(r);
}

/* ---- Uploads -------------------------------------------------------------------------------------- */

static uint8_t *table_of(size_t len)
{
    uint8_t *t = malloc(len);
    for (size_t i = 0; i < len; i++)
        t[i] = (uint8_t)(i * 7 + 3);
    return t;
}

static void upload_checks_crc(void **state)
{
    (void)state;
    rig *r = rig_start(fake_script_good, 1000);
    size_t len = 3 * WDR_PROTO_CHUNK_DATA_MAX + 123;
    uint8_t *table = table_of(len);
    wdr_commit_reply reply;
    assert_int_equal(wdr_client_connect(r->c, r->t), WDR_OK);
    assert_int_equal(wdr_client_upload(r->c, WDR_KIND_LUT, table, len, NULL, NULL, &reply), WDR_OK);
    assert_int_equal(reply.crc, wdr_crc32(0, table, len));
    assert_int_equal(r->board.opcodes[WDR_CMD_LUT_CHUNK], 4);
    free(table);
    rig_stop(r);
}

static int script_hangup_mid_upload(scripted_board *b, const wdr_packet *req, int n)
{
    if (req->h.opcode == WDR_CMD_LUT_CHUNK && b->opcodes[WDR_CMD_LUT_CHUNK] == 2)
        return -1; /* unplugged during the second chunk */
    return fake_script_good(b, req, n);
}

static void disconnect_mid_upload(void **state)
{
    (void)state;
    rig *r = rig_start(script_hangup_mid_upload, 1000);
    size_t len = 5 * WDR_PROTO_CHUNK_DATA_MAX;
    uint8_t *table = table_of(len);
    assert_int_equal(wdr_client_connect(r->c, r->t), WDR_OK);
    assert_int_equal(wdr_client_upload(r->c, WDR_KIND_LUT, table, len, NULL, NULL, NULL), WDR_E_IO);
    assert_non_null(strstr(r->c->err, "disconnected during LUT_CHUNK"));
    free(table);
    rig_stop(r);
}

static int script_refuse_commit(scripted_board *b, const wdr_packet *req, int n)
{
    if (req->h.opcode == WDR_CMD_CAL_COMMIT) {
        fake_reply(b, req, WDR_ST_BAD_GEOMETRY, NULL, 0);
        return 0;
    }
    return fake_script_good(b, req, n);
}

static void refused_commit_reports_status_and_aborts(void **state)
{
    (void)state;
    rig *r = rig_start(script_refuse_commit, 1000);
    uint8_t *table = table_of(100);
    assert_int_equal(wdr_client_connect(r->c, r->t), WDR_OK);
    assert_int_equal(wdr_client_upload(r->c, WDR_KIND_CAL, table, 100, NULL, NULL, NULL), WDR_E_STATUS);
    assert_int_equal(r->c->status, WDR_ST_BAD_GEOMETRY);
    assert_non_null(strstr(r->c->err, "bad geometry"));
    usleep(50000);
    assert_int_equal(r->board.opcodes[WDR_CMD_ABORT], 1);
    free(table);
    rig_stop(r);
}

static int script_wrong_readback(scripted_board *b, const wdr_packet *req, int n)
{
    if (req->h.opcode == WDR_CMD_LUT_COMMIT) {
        wdr_commit_reply c = {.crc = 0xdeadbeef};
        uint8_t p[WDR_COMMIT_REPLY_SIZE];
        wdr_commit_pack(&c, p);
        fake_reply(b, req, WDR_ST_OK, p, sizeof p);
        return 0;
    }
    return fake_script_good(b, req, n);
}

static void readback_mismatch_is_corrupt(void **state)
{
    (void)state;
    rig *r = rig_start(script_wrong_readback, 1000);
    uint8_t *table = table_of(100);
    assert_int_equal(wdr_client_connect(r->c, r->t), WDR_OK);
    assert_int_equal(wdr_client_upload(r->c, WDR_KIND_LUT, table, 100, NULL, NULL, NULL), WDR_E_CORRUPT);
    assert_non_null(strstr(r->c->err, "deadbeef"));
    free(table);
    rig_stop(r);
}

/* ---- Capture --------------------------------------------------------------------------------------- */

static int frames_seen;
static int count_frame(void *ctx, const wdr_frame *f)
{
    (void)ctx;
    for (int i = 0; i < f->width * f->height; i++)
        assert_int_equal(f->codes[i], (i + (int)f->end.frame) & 0xfff);
    frames_seen++;
    return WDR_OK;
}

static void capture_assembles_frames(void **state)
{
    (void)state;
    rig *r = rig_start(fake_script_good, 1000);
    uint16_t codes[16 * 8];
    frames_seen = 0;
    assert_int_equal(wdr_client_connect(r->c, r->t), WDR_OK);
    assert_int_equal(wdr_client_capture(r->c, 3, codes, count_frame, NULL), WDR_OK);
    assert_int_equal(frames_seen, 3);
    rig_stop(r);
}

static int script_lose_a_row(scripted_board *b, const wdr_packet *req, int n)
{
    if (req->h.opcode != WDR_CMD_CAPTURE)
        return fake_script_good(b, req, n);
    fake_reply(b, req, WDR_ST_OK, NULL, 0);
    wdr_frame_end fe = {.frame = 0, .rows = b->height};
    uint8_t p[WDR_FRAME_END_SIZE];
    wdr_frame_end_pack(&fe, p);
    fake_event(b, WDR_CMD_FRAME_END, req->h.seq, p, sizeof p); /* no rows at all */
    return 0;
}

static void missing_rows_refuse_the_frame(void **state)
{
    (void)state;
    rig *r = rig_start(script_lose_a_row, 1000);
    uint16_t codes[16 * 8];
    assert_int_equal(wdr_client_connect(r->c, r->t), WDR_OK);
    assert_int_equal(wdr_client_capture(r->c, 1, codes, NULL, NULL), WDR_E_FRAME);
    assert_non_null(strstr(r->c->err, "rows 0-7 missing (0 of 8 rows"));
    rig_stop(r);
}

static int script_capture_then_silence(scripted_board *b, const wdr_packet *req, int n)
{
    if (req->h.opcode != WDR_CMD_CAPTURE)
        return fake_script_good(b, req, n);
    fake_reply(b, req, WDR_ST_OK, NULL, 0); /* ...and never a row */
    return 0;
}

static void capture_stall_times_out(void **state)
{
    (void)state;
    rig *r = rig_start(script_capture_then_silence, 100);
    uint16_t codes[16 * 8];
    assert_int_equal(wdr_client_connect(r->c, r->t), WDR_OK);
    int64_t t0 = wdr_transport_now_ms();
    assert_int_equal(wdr_client_capture(r->c, 1, codes, NULL, NULL), WDR_E_TIMEOUT);
    assert_true(wdr_transport_now_ms() - t0 < 10000);
    assert_non_null(strstr(r->c->err, "no complete frame within"));
    rig_stop(r);
}

static int script_unplug_mid_frame(scripted_board *b, const wdr_packet *req, int n)
{
    if (req->h.opcode != WDR_CMD_CAPTURE)
        return fake_script_good(b, req, n);
    fake_reply(b, req, WDR_ST_OK, NULL, 0);
    uint8_t row[WDR_PROTO_ROW_HEADER + 2 * 16] = {0};
    wdr_put_u16(row + 6, b->width);
    fake_event(b, WDR_CMD_ROW, req->h.seq, row, sizeof row);
    return -1; /* one row, then the cable */
}

static void disconnect_mid_capture(void **state)
{
    (void)state;
    rig *r = rig_start(script_unplug_mid_frame, 1000);
    uint16_t codes[16 * 8];
    assert_int_equal(wdr_client_connect(r->c, r->t), WDR_OK);
    assert_int_equal(wdr_client_capture(r->c, 1, codes, NULL, NULL), WDR_E_IO);
    assert_non_null(strstr(r->c->err, "disconnected during CAPTURE"));
    rig_stop(r);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(recv_times_out),
        cmocka_unit_test(peer_close_is_io_error),
        cmocka_unit_test(send_to_stalled_peer_times_out),
        cmocka_unit_test(bad_addresses),
        cmocka_unit_test(connect_and_status),
        cmocka_unit_test(retry_after_timeout),
        cmocka_unit_test(gives_up_after_retries),
        cmocka_unit_test(resyncs_after_garbage),
        cmocka_unit_test(garbled_answer_is_asked_again),
        cmocka_unit_test(wrong_opcode_is_protocol_error),
        cmocka_unit_test(version_mismatch),
        cmocka_unit_test(upload_checks_crc),
        cmocka_unit_test(disconnect_mid_upload),
        cmocka_unit_test(refused_commit_reports_status_and_aborts),
        cmocka_unit_test(readback_mismatch_is_corrupt),
        cmocka_unit_test(capture_assembles_frames),
        cmocka_unit_test(missing_rows_refuse_the_frame),
        cmocka_unit_test(capture_stall_times_out),
        cmocka_unit_test(disconnect_mid_capture),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
