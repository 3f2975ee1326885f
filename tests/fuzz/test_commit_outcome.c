/* `wdrctl cal upload` when the link fails during CAL_COMMIT (issue 14): the board may have made
 * the table active all the same, so wdrctl must ask it (STATUS on a new connection) and say
 * what it found, instead of reporting a failure (exit 74) for a table that is in fact active.
 * A scripted board answers the upload and hangs up on the COMMIT; a second one, listening on
 * the same socket before the first hangs up, answers STATUS with the new table active, the old
 * one active, or (third case) nobody listens: the outcome is unknown (exit 75). */
#include "crc32.h"
#include "scripted_board.h"
#include "wdr_proto.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <sysexits.h>
#include <unistd.h>

static char dir[64], sock[128], addr[160], table_path[160];
static uint8_t table[5000];
static scripted_board first, second;
static int second_crc_is_new, second_listens;

static int script_status(scripted_board *b, const wdr_packet *req, int n)
{
    (void)n;
    if (req->h.opcode != WDR_CMD_STATUS)
        return fake_script_good(b, req, n);
    wdr_status_report s = {.lut_slot = WDR_SLOT_NONE, .cal_slot = 1,
                           .cal_crc = second_crc_is_new ? wdr_crc32(0, table, sizeof table) : 0x12345678u};
    uint8_t p[WDR_STATUS_SIZE];
    wdr_status_pack(&s, p);
    fake_reply(b, req, WDR_ST_OK, p, sizeof p);
    return 0;
}

/* Good answers until the COMMIT arrives; then (the table taken or not, nobody knows) hand the
 * socket to the second board and hang up without an answer. */
static int script_cut_at_commit(scripted_board *b, const wdr_packet *req, int n)
{
    if (req->h.opcode != WDR_CMD_CAL_COMMIT)
        return fake_script_good(b, req, n);
    close(b->listen_fd);
    b->listen_fd = -1;
    unlink(sock);
    if (second_listens)
        assert_int_equal(scripted_board_start_listen(&second, sock, script_status), 0);
    return -1;
}

static int run(char *out, size_t cap)
{
    char cmd[1024];
    snprintf(cmd, sizeof cmd, "%s cal upload %s --no-verify --device %s --timeout 300 --retries 1 >%s/out.txt 2>&1",
             WDRCTL_PATH, table_path, addr, dir);
    int status = system(cmd);
    char path[128];
    snprintf(path, sizeof path, "%s/out.txt", dir);
    FILE *f = fopen(path, "r");
    size_t got = f ? fread(out, 1, cap - 1, f) : 0;
    out[got] = 0;
    if (f)
        fclose(f);
    printf("%s", out);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

static void one_case(int listens, int crc_is_new, int want_exit, const char *want_text)
{
    char out[4096];
    second_listens = listens;
    second_crc_is_new = crc_is_new;
    memset(&first, 0, sizeof first);
    memset(&second, 0, sizeof second);
    unlink(sock);
    assert_int_equal(scripted_board_start_listen(&first, sock, script_cut_at_commit), 0);
    int rc = run(out, sizeof out);
    scripted_board_stop(&first);
    if (listens)
        scripted_board_stop(&second);
    assert_int_equal(rc, want_exit);
    assert_non_null(strstr(out, want_text));
}

static void table_taken(void **s)
{
    (void)s;
    one_case(1, 1, EX_OK, "reports it active after the link failed");
}

static void table_not_taken(void **s)
{
    (void)s;
    one_case(1, 0, EX_IOERR, "still runs the previous calibration table");
}

static void nobody_answers(void **s)
{
    (void)s;
    one_case(0, 0, EX_TEMPFAIL, "outcome unknown");
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/wdr_commit_XXXXXX");
    if (!mkdtemp(dir))
        return -1;
    snprintf(sock, sizeof sock, "%s/board.sock", dir);
    snprintf(addr, sizeof addr, "sim:%s", sock);
    snprintf(table_path, sizeof table_path, "%s/table.bin", dir);
    for (size_t i = 0; i < sizeof table; i++)
        table[i] = (uint8_t)(i * 7);
    FILE *f = fopen(table_path, "wb");
    if (!f || fwrite(table, 1, sizeof table, f) != sizeof table)
        return -1;
    return fclose(f);
}

static int teardown(void **state)
{
    (void)state;
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    return system(cmd);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(table_taken),
        cmocka_unit_test(table_not_taken),
        cmocka_unit_test(nobody_answers),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
