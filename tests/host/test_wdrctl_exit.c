/* The wdrctl program against scripted fake boards on a socket: each failure (board absent,
 * silent, unplugged mid-upload, refusing, speaking another version) gives its sysexits code
 * and a message naming what failed. Every child is bounded by a deadline. */
#include "scripted_board.h"
#include "wdrctl_child.h"
#include "wdr_lut.h"
#include <cJSON.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <sysexits.h>
#include <time.h>
#include <unistd.h>

#ifndef WDRCTL_PATH
#error "WDRCTL_PATH must name the wdrctl program"
#endif
#define CHILD_DEADLINE_S 20

static char dir[64];
static char err_text[4096], out_text[4096];
static int case_no;


/* Run wdrctl with args (NULL-terminated) and no WDR_DEVICE; returns its exit code; its stderr
 * lands in err_text, its stdout in out_text. */
static int run_wdrctl(const char *const *args)
{
    char err_path[128], out_path[128];
    snprintf(err_path, sizeof err_path, "%s/stderr.txt", dir);
    snprintf(out_path, sizeof out_path, "%s/stdout.txt", dir);
    double wall;
    int rc = wdr_child_run(WDRCTL_PATH, args, out_path, err_path, CHILD_DEADLINE_S, &wall);
    if (rc == WDR_CHILD_KILLED)
        fail_msg("wdrctl did not finish within %d s", CHILD_DEADLINE_S);
    assert_true(rc >= 0);
    wdr_child_slurp(err_path, err_text, sizeof err_text);
    wdr_child_slurp(out_path, out_text, sizeof out_text);
    return rc;
}

/* A fresh socket path and a fake board listening on it. */
static const char *start_board(scripted_board *b, fake_script script, char *addr, size_t cap)
{
    char path[128];
    snprintf(path, sizeof path, "%s/board%d.sock", dir, case_no++);
    memset(b, 0, sizeof *b);
    assert_int_equal(scripted_board_start_listen(b, path, script), 0);
    snprintf(addr, cap, "sim:%s", path);
    return addr;
}

static const char *write_file(const char *name, const void *bytes, size_t len)
{
    static char path[128];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fwrite(bytes, 1, len, f);
    fclose(f);
    return path;
}

static int script_silent(scripted_board *b, const wdr_packet *req, int n)
{
    (void)b, (void)req, (void)n;
    return 0;
}

static int script_hangup_mid_upload(scripted_board *b, const wdr_packet *req, int n)
{
    if (req->h.opcode == WDR_CMD_LUT_CHUNK && b->opcodes[WDR_CMD_LUT_CHUNK] == 2)
        return -1;
    return fake_script_good(b, req, n);
}

static int script_unplug_mid_frame(scripted_board *b, const wdr_packet *req, int n)
{
    if (req->h.opcode != WDR_CMD_CAPTURE)
        return fake_script_good(b, req, n);
    fake_reply(b, req, WDR_ST_OK, NULL, 0);
    return -1;
}

static int script_refuse(scripted_board *b, const wdr_packet *req, int n)
{
    int status = req->h.opcode == WDR_CMD_CAL_COMMIT ? WDR_ST_BAD_GEOMETRY
               : req->h.opcode == WDR_CMD_SIM_SET_ILLUMINANT ? WDR_ST_UNSUPPORTED
               : req->h.opcode == WDR_CMD_CAPTURE ? WDR_ST_NO_TABLE : -1;
    if (status < 0)
        return fake_script_good(b, req, n);
    fake_reply(b, req, status, NULL, 0);
    return 0;
}

static int script_other_version(scripted_board *b, const wdr_packet *req, int n)
{
    (void)n;
    fake_reply_info(b, req, WDR_PROTO_VERSION_MAJOR + 1);
    return 0;
}

/* ---- Cases ------------------------------------------------------------------------------------------ */

static void usage_errors(void **state)
{
    (void)state;
    assert_int_equal(run_wdrctl((const char *[]){"info", NULL}), EX_USAGE);
    assert_non_null(strstr(err_text, "WDR_DEVICE"));
    assert_int_equal(run_wdrctl((const char *[]){"info", "--device", "tcp:x", NULL}), EX_USAGE);
    assert_int_equal(run_wdrctl((const char *[]){"capture", "--device", "sim:/x", NULL}), EX_USAGE);
    assert_non_null(strstr(err_text, "-o FILE"));
    assert_int_equal(run_wdrctl((const char *[]){"capture", "-n", "0", "-o", "x.png", NULL}), EX_USAGE);
    assert_int_equal(run_wdrctl((const char *[]){"info", "--bits", "8", NULL}), EX_USAGE);
}

static void board_absent(void **state)
{
    (void)state;
    char addr[160];
    snprintf(addr, sizeof addr, "sim:%s/nobody.sock", dir);
    assert_int_equal(run_wdrctl((const char *[]){"info", "--device", addr, NULL}), EX_UNAVAILABLE);
    assert_non_null(strstr(err_text, "nobody.sock"));
}

static void board_silent(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160];
    start_board(&b, script_silent, addr, sizeof addr);
    assert_int_equal(run_wdrctl((const char *[]){"status", "--device", addr, "--timeout", "100", "--retries", "1", NULL}),
                     EX_TEMPFAIL);
    assert_non_null(strstr(err_text, "no answer to INFO after 2 attempt"));
    scripted_board_stop(&b);
}

static void unplugged_mid_upload(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160];
    static uint8_t table[5 * 4096];
    const char *file = write_file("big.bin", table, sizeof table);
    start_board(&b, script_hangup_mid_upload, addr, sizeof addr);
    assert_int_equal(run_wdrctl((const char *[]){"lut", "upload", file, "--no-verify", "--device", addr, NULL}), EX_IOERR);
    assert_non_null(strstr(err_text, "disconnected"));
    scripted_board_stop(&b);
}

static void unplugged_mid_capture(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160], out[128];
    snprintf(out, sizeof out, "%s/lost.png", dir);
    start_board(&b, script_unplug_mid_frame, addr, sizeof addr);
    assert_int_equal(run_wdrctl((const char *[]){"capture", "-n", "3", "-o", out, "--device", addr, NULL}), EX_IOERR);
    assert_non_null(strstr(err_text, "disconnected"));
    scripted_board_stop(&b);
}

static void refused_upload(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160];
    const char *file = write_file("cal.bin", "0123456789", 10);
    start_board(&b, script_refuse, addr, sizeof addr);
    assert_int_equal(run_wdrctl((const char *[]){"cal", "upload", file, "--no-verify", "--device", addr, NULL}),
                     EX_DATAERR);
    assert_non_null(strstr(err_text, "bad geometry"));
    scripted_board_stop(&b);
}

static void bad_table_files(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160];
    const char *junk = write_file("junk.lut", "not a lut at all, just some text", 33);
    start_board(&b, fake_script_good, addr, sizeof addr);
    assert_int_equal(run_wdrctl((const char *[]){"lut", "upload", junk, "--device", addr, NULL}), EX_DATAERR);
    assert_non_null(strstr(err_text, "junk.lut"));
    assert_int_equal(b.opcodes[WDR_CMD_LUT_BEGIN], 0); /* refused before anything was sent */
    scripted_board_stop(&b);
    char missing[128];
    snprintf(missing, sizeof missing, "%s/missing.bin", dir);
    assert_int_equal(run_wdrctl((const char *[]){"lut", "upload", missing, "--device", addr, NULL}), EX_NOINPUT);
}

static void refused_requests(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160], out[128];
    snprintf(out, sizeof out, "%s/none.png", dir);
    start_board(&b, script_refuse, addr, sizeof addr);
    assert_int_equal(run_wdrctl((const char *[]){"sim", "illuminant", "1e-11", "--device", addr, NULL}), EX_UNAVAILABLE);
    scripted_board_stop(&b);
    start_board(&b, script_refuse, addr, sizeof addr);
    assert_int_equal(run_wdrctl((const char *[]){"capture", "-o", out, "--device", addr, NULL}), EX_CONFIG);
    assert_non_null(strstr(err_text, "no table"));
    scripted_board_stop(&b);
}

static void other_protocol_version(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160];
    start_board(&b, script_other_version, addr, sizeof addr);
    assert_int_equal(run_wdrctl((const char *[]){"info", "--device", addr, NULL}), EX_PROTOCOL);
    assert_non_null(strstr(err_text, "protocol 2.0"));
    scripted_board_stop(&b);
}

static void json_reports(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160];
    start_board(&b, fake_script_good, addr, sizeof addr);
    assert_int_equal(run_wdrctl((const char *[]){"info", "--json", "--device", addr, NULL}), EX_OK);
    cJSON *info = cJSON_Parse(out_text);
    assert_non_null(info);
    assert_int_equal(cJSON_GetObjectItem(info, "width")->valuedouble, 16);
    assert_string_equal(cJSON_GetObjectItem(info, "board")->valuestring, "fake");
    cJSON_Delete(info);
    scripted_board_stop(&b);
    start_board(&b, fake_script_good, addr, sizeof addr);
    assert_int_equal(run_wdrctl((const char *[]){"status", "--json", "--device", addr, NULL}), EX_OK);
    cJSON *st = cJSON_Parse(out_text);
    assert_non_null(st);
    assert_string_equal(cJSON_GetObjectItem(cJSON_GetObjectItem(st, "lut"), "slot")->valuestring, "A");
    assert_int_equal(cJSON_GetObjectItem(st, "integration_ns")->valuedouble, 1000000);
    cJSON_Delete(st);
    scripted_board_stop(&b);
    assert_int_equal(run_wdrctl((const char *[]){"capture", "--json", "-o", "x.png", NULL}), EX_USAGE);
}

static void good_board_round_trip(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160], png[128], pfm[128];
    struct stat st;
    static uint8_t table[9000];
    const char *file = write_file("table.bin", table, sizeof table);
    snprintf(png, sizeof png, "%s/frame.png", dir);
    snprintf(pfm, sizeof pfm, "%s/frame.pfm", dir);
    start_board(&b, fake_script_good, addr, sizeof addr);
    assert_int_equal(run_wdrctl((const char *[]){"lut", "upload", file, "--no-verify", "--device", addr, NULL}), EX_OK);
    scripted_board_stop(&b);
    start_board(&b, fake_script_good, addr, sizeof addr);
    assert_int_equal(run_wdrctl((const char *[]){"capture", "-n", "2", "-o", png, "--bits", "8", "--device", addr, NULL}),
                     EX_OK);
    snprintf(png, sizeof png, "%s/frame-0001.png", dir);
    assert_int_equal(stat(png, &st), 0);
    scripted_board_stop(&b);
    start_board(&b, fake_script_good, addr, sizeof addr);
    assert_int_equal(run_wdrctl((const char *[]){"capture", "-o", pfm, "--device", addr, NULL}), EX_OK);
    assert_int_equal(stat(pfm, &st), 0);
    assert_true(st.st_size > 16 * 8 * 4);
    scripted_board_stop(&b);
}

int main(void)
{
    snprintf(dir, sizeof dir, "/tmp/wdr-host-XXXXXX");
    if (!mkdtemp(dir))
        return 1;
    signal(SIGPIPE, SIG_IGN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(usage_errors),        cmocka_unit_test(board_absent),
        cmocka_unit_test(board_silent),        cmocka_unit_test(unplugged_mid_upload),
        cmocka_unit_test(unplugged_mid_capture),
        cmocka_unit_test(refused_upload),      cmocka_unit_test(bad_table_files),
        cmocka_unit_test(refused_requests),    cmocka_unit_test(other_protocol_version),
        cmocka_unit_test(json_reports),
        cmocka_unit_test(good_board_round_trip),
    };
    int rc = cmocka_run_group_tests(tests, NULL, NULL);
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", dir);
    return rc;
}
