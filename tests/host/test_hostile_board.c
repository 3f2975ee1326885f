/* wdrctl against a hostile board (issue 23): one that floods or drips events of another request,
 * lies about its timing, never accepts the connection, garbles or oversizes its answers, or
 * sends a frame whose rows are repeated, missing or out of range. Each misbehaviour is served
 * over a unix socket (sim:) and, where the link matters, over a pty (serial:); each case asserts
 * the exit code and a message naming what was seen, and prints the wall time. The only bound on
 * time is the hang guard (CHILD_DEADLINE_S, and the test's CTest TIMEOUT): a command that never
 * ends fails, one that is slow on a loaded machine does not. */
#include "scripted_board.h"
#include "wdrctl_child.h"
#include "crc32.h"
#include "wdr_bytes.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <sysexits.h>
#include <time.h>
#include <unistd.h>

#ifndef WDRCTL_PATH
#error "WDRCTL_PATH must name the wdrctl program"
#endif
#define CHILD_DEADLINE_S 60 /* hang guard only: every case ends within about 2 s when it works */
#define TIMEOUT_ARG "300"   /* --timeout ms of every case */

static char dir[64];
static char err_text[4096];
static int case_no;

/* Run wdrctl with args (NULL-terminated); its exit code, stderr in err_text; prints what, the
 * code, the wall time and the message (the figures of the closing note). */
static int run_wdrctl(const char *what, const char *const *args)
{
    char err_path[128];
    snprintf(err_path, sizeof err_path, "%s/stderr.txt", dir);
    const char *guard_env = getenv("WDR_HANG_GUARD_S"); /* shorter, to see a planted hang fail quickly */
    double guard = guard_env ? atof(guard_env) : CHILD_DEADLINE_S, wall;
    int rc = wdr_child_run(WDRCTL_PATH, args, NULL, err_path, guard, &wall);
    if (rc == WDR_CHILD_KILLED)
        fail_msg("%s: wdrctl still running after %.0f s (hang guard)", what, guard);
    assert_true(rc >= 0);
    wdr_child_slurp(err_path, err_text, sizeof err_text);
    char *nl = strchr(err_text, '\n');
    printf("%-34s exit %d  %6.0f ms  %.*s\n", what, rc, wall * 1000, nl ? (int)(nl - err_text) : (int)strlen(err_text),
           err_text);
    return rc;
}

/* ---- Links: the same script behind a unix socket or a pty ------------------------------------- */

enum link { LINK_UNIX, LINK_PTY };

static const char *start(scripted_board *b, enum link link, fake_script script, char *addr, size_t cap)
{
    memset(b, 0, sizeof *b);
    if (link == LINK_UNIX) {
        char path[128];
        snprintf(path, sizeof path, "%s/board%d.sock", dir, case_no++);
        assert_int_equal(scripted_board_start_listen(b, path, script), 0);
        snprintf(addr, cap, "sim:%s", path);
    } else {
        char slave[64];
        assert_int_equal(scripted_board_start_pty(b, slave, sizeof slave, script), 0);
        snprintf(addr, cap, "serial:%s", slave);
    }
    return addr;
}

static const char *link_name(enum link link) { return link == LINK_UNIX ? "unix" : "pty"; }

/* Run a command line against a fresh board on each link; check exit code and message. */
static void on_both_links(const char *what, fake_script script, const char *cmd, int want_rc, const char *want_msg)
{
    for (int l = LINK_UNIX; l <= LINK_PTY; l++) {
        scripted_board b;
        char addr[160], out[160], label[96];
        snprintf(out, sizeof out, "%s/out%d.pfm", dir, case_no);
        start(&b, (enum link)l, script, addr, sizeof addr);
        snprintf(label, sizeof label, "%s (%s)", what, link_name((enum link)l));
        const char *args[16];
        int n = 0;
        if (!strcmp(cmd, "capture")) {
            args[n++] = "capture", args[n++] = "-o", args[n++] = out;
        } else if (!strcmp(cmd, "stream")) {
            args[n++] = "stream", args[n++] = "-n", args[n++] = "3";
        } else {
            args[n++] = cmd;
        }
        const char *tail[] = {"--device", addr, "--timeout", TIMEOUT_ARG, "--retries", "1", NULL};
        memcpy(args + n, tail, sizeof tail);
        int rc = run_wdrctl(label, args);
        scripted_board_stop(&b);
        assert_int_equal(rc, want_rc);
        if (!strstr(err_text, want_msg))
            fail_msg("%s: message lacks '%s': %s", label, want_msg, err_text);
    }
}

/* ---- Scripts --------------------------------------------------------------------------------- */

static void send_row(scripted_board *b, uint16_t seq, uint32_t frame, uint16_t row)
{
    uint8_t p[WDR_PROTO_ROW_HEADER + 2 * 64] = {0};
    wdr_put_u32(p, frame);
    wdr_put_u16(p + 4, row);
    wdr_put_u16(p + 6, b->width);
    fake_event(b, WDR_CMD_ROW, seq, p, WDR_PROTO_ROW_HEADER + 2u * b->width);
}

static void send_frame_end(scripted_board *b, uint16_t seq, uint32_t frame)
{
    wdr_frame_end fe = {.frame = frame, .rows = b->height};
    uint8_t p[WDR_FRAME_END_SIZE];
    wdr_frame_end_pack(&fe, p);
    fake_event(b, WDR_CMD_FRAME_END, seq, p, sizeof p);
}

static int is_frame_request(const wdr_packet *req)
{
    return req->h.opcode == WDR_CMD_CAPTURE || (req->h.opcode == WDR_CMD_STREAM && req->payload[0] == 1);
}

/* Rows of another request's number, as fast as the host takes them, until it leaves. */
static int script_flood_foreign_rows(scripted_board *b, const wdr_packet *req, int n)
{
    if (!is_frame_request(req))
        return fake_script_good(b, req, n);
    fake_reply(b, req, WDR_ST_OK, NULL, 0);
    for (uint16_t r = 0; fake_alive(b); r++)
        send_row(b, (uint16_t)(req->h.seq + 1000), 0, r % b->height);
    return -1;
}

/* The same, one every 100 ms: each packet well inside --timeout, no frame ever complete. */
static int script_drip_foreign_rows(scripted_board *b, const wdr_packet *req, int n)
{
    if (!is_frame_request(req))
        return fake_script_good(b, req, n);
    fake_reply(b, req, WDR_ST_OK, NULL, 0);
    for (uint16_t r = 0; fake_alive(b); r++) {
        send_row(b, (uint16_t)(req->h.seq + 1000), 0, r % b->height);
        usleep(100000);
    }
    return -1;
}

/* Row 0 sent H times, then FRAME_END: H packets, one row. */
static int script_row_zero_repeated(scripted_board *b, const wdr_packet *req, int n)
{
    if (req->h.opcode != WDR_CMD_CAPTURE)
        return fake_script_good(b, req, n);
    fake_reply(b, req, WDR_ST_OK, NULL, 0);
    for (uint16_t r = 0; r < b->height; r++)
        send_row(b, req->h.seq, 0, 0);
    send_frame_end(b, req->h.seq, 0);
    return 0;
}

static int script_rows_missing(scripted_board *b, const wdr_packet *req, int n)
{
    if (req->h.opcode != WDR_CMD_CAPTURE)
        return fake_script_good(b, req, n);
    fake_reply(b, req, WDR_ST_OK, NULL, 0);
    for (uint16_t r = 0; r < b->height; r++)
        if (r < 1 || r > 3)
            send_row(b, req->h.seq, 0, r);
    send_frame_end(b, req->h.seq, 0);
    return 0;
}

static int script_row_out_of_range(scripted_board *b, const wdr_packet *req, int n)
{
    if (req->h.opcode != WDR_CMD_CAPTURE)
        return fake_script_good(b, req, n);
    fake_reply(b, req, WDR_ST_OK, NULL, 0);
    for (uint16_t r = 0; r < b->height; r++)
        send_row(b, req->h.seq, 0, r == 5 ? (uint16_t)(b->height + 1) : r);
    send_frame_end(b, req->h.seq, 0);
    return 0;
}

/* INFO claims 4 s a row: the 78-hour wait of the issue. */
static int script_lie_row_time(scripted_board *b, const wdr_packet *req, int n)
{
    b->row_time_ns = 4000000000u;
    return script_flood_foreign_rows(b, req, n);
}

/* STATUS claims an integration of 4.29 s, above the protocol's 4 s. */
static int script_lie_integration(scripted_board *b, const wdr_packet *req, int n)
{
    if (req->h.opcode != WDR_CMD_STATUS)
        return script_flood_foreign_rows(b, req, n);
    wdr_status_report s = {.cal_slot = WDR_SLOT_NONE, .integration_ns = 4294967295u};
    uint8_t st[WDR_STATUS_SIZE];
    wdr_status_pack(&s, st);
    fake_reply(b, req, WDR_ST_OK, st, sizeof st);
    return 0;
}

/* INFO claims fast rows; CAPTURE is answered, then nothing but silence. */
static int script_slow_despite_timing(scripted_board *b, const wdr_packet *req, int n)
{
    if (req->h.opcode != WDR_CMD_CAPTURE)
        return fake_script_good(b, req, n);
    fake_reply(b, req, WDR_ST_OK, NULL, 0);
    return 0;
}

static int script_garbled(scripted_board *b, const wdr_packet *req, int n)
{
    (void)n;
    fake_reply_bad_crc(b, req);
    return 0;
}

/* An answer whose header (CRC good) declares 5000 bytes of payload. */
static int script_oversize(scripted_board *b, const wdr_packet *req, int n)
{
    (void)n;
    uint8_t frame[WDR_PROTO_HEADER_SIZE + 64] = {0};
    wdr_proto_header h = {.opcode = req->h.opcode, .flags = WDR_FLAG_RESPONSE, .seq = req->h.seq};
    wdr_proto_encode(frame, sizeof frame, &h, NULL, 0);
    wdr_put_u32(frame + 8, 5000);
    wdr_put_u32(frame + 16, wdr_crc32(0, frame, 16));
    fake_send_raw(b, frame, sizeof frame);
    return 0;
}

static int script_silent(scripted_board *b, const wdr_packet *req, int n)
{
    (void)b, (void)req, (void)n;
    return 0;
}

/* ---- Cases ------------------------------------------------------------------------------------ */

static void flood_of_foreign_rows(void **state)
{
    (void)state;
    on_both_links("capture, flood of foreign rows", script_flood_foreign_rows, "capture", EX_TEMPFAIL,
                  "event(s) of another request");
    on_both_links("stream, flood of foreign rows", script_flood_foreign_rows, "stream", EX_TEMPFAIL,
                  "no complete frame within");
}

static void drip_of_foreign_rows(void **state)
{
    (void)state;
    on_both_links("capture, drip of foreign rows", script_drip_foreign_rows, "capture", EX_TEMPFAIL,
                  "no complete frame within");
}

static void duplicate_rows(void **state)
{
    (void)state;
    on_both_links("capture, row 0 sent 8 times", script_row_zero_repeated, "capture", EX_IOERR,
                  "row 0 arrived twice");
}

static void missing_rows(void **state)
{
    (void)state;
    on_both_links("capture, rows 1-3 missing", script_rows_missing, "capture", EX_IOERR, "rows 1-3 missing");
}

static void out_of_range_row(void **state)
{
    (void)state;
    on_both_links("capture, row 9 of 8", script_row_out_of_range, "capture", EX_IOERR,
                  "row 9 is outside the sensor's rows 0-7");
}

static void lies_about_timing(void **state)
{
    (void)state;
    on_both_links("capture, INFO row time 4 s", script_lie_row_time, "capture", EX_PROTOCOL, "'row_time_ns' is 4000000000");
    on_both_links("capture, STATUS integration 4.3 s", script_lie_integration, "capture", EX_PROTOCOL,
                  "'integration_ns' is 4294967295");
    on_both_links("capture, fast timing, no rows", script_slow_despite_timing, "capture", EX_TEMPFAIL,
                  "no complete frame within");
}

static void garbled_and_oversize_answers(void **state)
{
    (void)state;
    on_both_links("info, garbled answers", script_garbled, "info", EX_PROTOCOL, "2 garbled (payload CRC wrong)");
    on_both_links("info, oversize answers", script_oversize, "info", EX_PROTOCOL, "2 oversize");
}

static void retries_zero_is_one_attempt(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160];
    start(&b, LINK_UNIX, script_silent, addr, sizeof addr);
    int rc = run_wdrctl("info, silent, --retries 0",
                        (const char *[]){"info", "--device", addr, "--timeout", TIMEOUT_ARG, "--retries", "0", NULL});
    usleep(100000);
    int infos = b.opcodes[WDR_CMD_INFO];
    scripted_board_stop(&b);
    assert_int_equal(rc, EX_TEMPFAIL);
    assert_non_null(strstr(err_text, "after 1 attempt(s)"));
    assert_int_equal(infos, 1);
}

/* A listener whose queue is full: the connection is never accepted. */
static int full_unix_listener(const char *path, int *filler)
{
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    snprintf(sa.sun_path, sizeof sa.sun_path, "%s", path);
    int fd = socket(AF_UNIX, SOCK_STREAM, 0);
    assert_true(fd >= 0 && bind(fd, (struct sockaddr *)&sa, sizeof sa) == 0 && listen(fd, 0) == 0);
    *filler = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK, 0);
    assert_int_equal(connect(*filler, (struct sockaddr *)&sa, sizeof sa), 0); /* takes the one place */
    return fd;
}

static int full_tcp_listener(int *port, int fillers[2])
{
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK)};
    socklen_t len = sizeof sa;
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    assert_true(fd >= 0 && bind(fd, (struct sockaddr *)&sa, sizeof sa) == 0 && listen(fd, 0) == 0);
    getsockname(fd, (struct sockaddr *)&sa, &len);
    *port = ntohs(sa.sin_port);
    for (int i = 0; i < 2; i++) {
        fillers[i] = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK, 0);
        (void)connect(fillers[i], (struct sockaddr *)&sa, sizeof sa); /* the second stays in SYN-SENT */
    }
    usleep(50000);
    return fd;
}

static void never_accepts(void **state)
{
    (void)state;
    char path[100], addr[160];
    int filler, fillers[2], port;
    snprintf(path, sizeof path, "%s/full.sock", dir);
    int fd = full_unix_listener(path, &filler);
    snprintf(addr, sizeof addr, "sim:%s", path);
    int rc_sim = run_wdrctl("info, sim: listener never accepts",
                            (const char *[]){"info", "--device", addr, "--timeout", TIMEOUT_ARG, NULL});
    assert_int_equal(rc_sim, EX_TEMPFAIL);
    assert_non_null(strstr(err_text, "accepted no connection within 300 ms"));
    snprintf(addr, sizeof addr, "unix:%s", path);
    int rc_unix = run_wdrctl("info, unix: listener never accepts",
                             (const char *[]){"info", "--device", addr, "--timeout", TIMEOUT_ARG, NULL});
    assert_int_equal(rc_unix, EX_TEMPFAIL);
    assert_non_null(strstr(err_text, "accepted no connection within 300 ms"));
    close(filler);
    close(fd);
    int tfd = full_tcp_listener(&port, fillers);
    snprintf(addr, sizeof addr, "tcp:127.0.0.1:%d", port);
    int rc_tcp = run_wdrctl("info, tcp: listener never accepts",
                            (const char *[]){"info", "--device", addr, "--timeout", TIMEOUT_ARG, NULL});
    close(fillers[0]);
    close(fillers[1]);
    close(tfd);
    assert_int_equal(rc_tcp, EX_TEMPFAIL);
}

int main(void)
{
    snprintf(dir, sizeof dir, "/tmp/wdr-hostile-XXXXXX");
    if (!mkdtemp(dir))
        return 1;
    signal(SIGPIPE, SIG_IGN);
    setvbuf(stdout, NULL, _IOLBF, 0);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(flood_of_foreign_rows),   cmocka_unit_test(drip_of_foreign_rows),
        cmocka_unit_test(duplicate_rows),          cmocka_unit_test(missing_rows),
        cmocka_unit_test(out_of_range_row),        cmocka_unit_test(lies_about_timing),
        cmocka_unit_test(garbled_and_oversize_answers), cmocka_unit_test(retries_zero_is_one_attempt),
        cmocka_unit_test(never_accepts),
    };
    int rc = cmocka_run_group_tests(tests, NULL, NULL);
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", dir);
    return rc;
}
