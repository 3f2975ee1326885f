/* wdrctl's firmware commands against a scripted board (protocol 1.4): fw upload stores an image
 * and reports bytes, time and UART time; each refusal (statuses 15-21, and TRUNCATED, BAD_CRC,
 * TOO_LARGE) prints its sentence, the status name and what still runs; a bad file or another
 * board's image is refused before any byte goes to the board; fw status prints both slots and
 * a fault's PC and CFSR; confirm and revert name BAD_STATE; reboot reconnects and prints the
 * new version; info prints the running image. Every child is bounded by a deadline. */
#include "fw_sign.h"
#include "scripted_board.h"
#include "wdrctl_child.h"
#include "crc32.h"
#include "wdr_err.h"
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
#include <sys/wait.h>
#include <sysexits.h>
#include <time.h>
#include <unistd.h>

#ifndef WDRCTL_PATH
#error "WDRCTL_PATH must name the wdrctl program"
#endif
#ifndef WDR_DEV_KEY_DIR
#error "WDR_DEV_KEY_DIR must name firmware/boot/keys"
#endif
#define DEV_KEY WDR_DEV_KEY_DIR "/dev-signing-key.NOT-FOR-PRODUCTION.pem"
#define CHILD_DEADLINE_S 30

static char dir[64], img_path[128], other_board_path[128], short_path[128];
static char err_text[8192], out_text[8192];
static int case_no;

/* ---- The child ------------------------------------------------------------------------------------ */


/* Run wdrctl with args (NULL-terminated); its stdout and stderr land in out_text, err_text. */
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

static void assert_has(const char *text, const char *part)
{
    if (!strstr(text, part))
        fail_msg("output lacks '%s':\n%s", part, text);
}

/* ---- The scripted board: protocol 1.4, v1.0.0+1 in slot A; refuses as a case says ------------ */

static int refuse_commit, refuse_begin, refuse_confirm, proto_minor = 4, rebooted;
static int stale_sessions, sessions_after_reboot; /* hosts the old boot still answers after REBOOT */

static int new_boot(void)
{
    return rebooted && sessions_after_reboot > stale_sessions;
}
static uint32_t got_len, got_crc;
static uint8_t got_img[8192];
static int hangup_on_commit, commit_took; /* the link dies on FW_COMMIT; whether the board took it */

static void reply_info(scripted_board *b, const wdr_packet *req)
{
    wdr_info info = {.proto_major = WDR_PROTO_VERSION_MAJOR,
                     .proto_minor = (uint16_t)proto_minor,
                     .fw_major = 1,
                     .fw_minor = 0,
                     .fw_patch = 0,
                     .fw_build = 1,
                     .fw_slot = 0,
                     .fw_flags = 0,
                     .sensor_id = 0x1234,
                     .width = 16,
                     .height = 8,
                     .adc_bits = 12,
                     .dac_bits = 12,
                     .max_payload = WDR_PROTO_MAX_PAYLOAD,
                     .lut_capacity = 1 << 20,
                     .cal_capacity = 1 << 22,
                     .row_time_ns = 1000};
    if (rebooted)
        sessions_after_reboot++; /* every host starts with INFO */
    if (new_boot())              /* the pending image now runs as a test boot */
        info = (wdr_info){.proto_major = 1,
                          .proto_minor = 4,
                          .fw_major = 2,
                          .fw_minor = 0,
                          .fw_patch = 0,
                          .fw_build = 2,
                          .fw_slot = 1,
                          .fw_flags = 1,
                          .sensor_id = 0x1234,
                          .width = 16,
                          .height = 8,
                          .adc_bits = 12,
                          .dac_bits = 12,
                          .max_payload = WDR_PROTO_MAX_PAYLOAD,
                          .row_time_ns = 1000};
    strcpy(info.name, "fake");
    uint8_t p[WDR_INFO_SIZE];
    wdr_info_pack(&info, p);
    fake_reply(b, req, WDR_ST_OK, p, proto_minor >= 4 ? WDR_INFO_SIZE : WDR_INFO_SIZE_1_3);
}

static void reply_fw_status(scripted_board *b, const wdr_packet *req)
{
    wdr_fw_status_report r = {.running = 0,
                              .reset_cause = 3,
                              .flags = WDR_FW_STATUS_F_DEV_KEY,
                              .max_attempts = 3,
                              .fault_pc = 0x00001234u,
                              .fault_status = 0x00008200u,
                              .floor = 1,
                              .boots = new_boot() ? 6u : 5u,
                              .key_hash = {0x4d, 0x08, 0x20, 0xc8}};
    r.slot[0] = (wdr_fw_slot_report){
        .state = 4, .ver_major = 1, .ver_build = 1, .security_counter = 1, .image_size = 4096, .sha256 = {0xab, 0xcd}};
    r.slot[1] = (wdr_fw_slot_report){.state = 5,
                                     .reject_reason = 2,
                                     .ver_major = 2,
                                     .ver_build = 2,
                                     .security_counter = 2,
                                     .image_size = 8192,
                                     .sha256 = {0x12, 0x34}};
    if (commit_took && got_len >= 200) { /* what the lost commit left: slot B pending with our image */
        r.slot[1].state = 2;
        memcpy(r.slot[1].sha256, got_img + got_len - WDR_IMAGE_TRAILER_SIZE + 8, 32);
    }
    uint8_t p[WDR_FW_STATUS_SIZE];
    wdr_fw_status_pack(&r, p);
    fake_reply(b, req, WDR_ST_OK, p, sizeof p);
}

static void reply_commit(scripted_board *b, const wdr_packet *req)
{
    if (refuse_commit) {
        fake_reply(b, req, refuse_commit, NULL, 0);
        return;
    }
    uint8_t p[WDR_FW_COMMIT_REPLY_SIZE] = {1}; /* slot B */
    wdr_image_header h = {.image_size = 16, .version = {2, 0, 0, 2}, .security_counter = 2};
    strcpy(h.board, "fake");
    wdr_image_header_pack(&h, p + 4);
    fake_reply(b, req, WDR_ST_OK, p, sizeof p);
}

static int script_fw(scripted_board *b, const wdr_packet *req, int n)
{
    (void)n;
    switch (req->h.opcode) {
    case WDR_CMD_INFO: reply_info(b, req); break;
    case WDR_CMD_FW_BEGIN:
        got_len = got_crc = 0;
        fake_reply(b, req, refuse_begin, NULL, 0);
        break;
    case WDR_CMD_FW_CHUNK:
        if (got_len + req->h.length - 4 <= sizeof got_img)
            memcpy(got_img + got_len, req->payload + 4, req->h.length - 4);
        got_crc = wdr_crc32(got_crc, req->payload + 4, req->h.length - 4);
        got_len += req->h.length - 4;
        fake_reply(b, req, WDR_ST_OK, NULL, 0);
        break;
    case WDR_CMD_FW_COMMIT:
        if (hangup_on_commit)
            return -1; /* commit_took says whether the board got that far */
        reply_commit(b, req);
        break;
    case WDR_CMD_FW_STATUS: reply_fw_status(b, req); break;
    case WDR_CMD_FW_CONFIRM:
    case WDR_CMD_FW_REVERT: fake_reply(b, req, refuse_confirm, NULL, 0); break;
    case WDR_CMD_REBOOT:
        fake_reply(b, req, WDR_ST_OK, NULL, 0);
        rebooted = 1;
        return -1; /* the reset drops the link */
    default: fake_reply(b, req, WDR_ST_OK, NULL, 0); break;
    }
    return 0;
}

static const char *start_board(scripted_board *b, char *addr, size_t cap, int sessions)
{
    char path[128];
    snprintf(path, sizeof path, "%s/board%d.sock", dir, case_no++);
    memset(b, 0, sizeof *b);
    b->sessions = sessions;
    refuse_commit = refuse_begin = refuse_confirm = rebooted = stale_sessions = sessions_after_reboot = 0;
    hangup_on_commit = commit_took = 0;
    proto_minor = 4;
    assert_int_equal(scripted_board_start_listen(b, path, script_fw), 0);
    snprintf(addr, cap, "sim:%s", path);
    return addr;
}

/* ---- Files ----------------------------------------------------------------------------------------- */

static void write_bytes(const char *path, const uint8_t *p, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(p, 1, n, f), n);
    fclose(f);
}

static void sign_to(const char *path, const char *board, size_t cut)
{
    wdr_fw_key k;
    char err[512];
    uint8_t app[5000], *img = NULL;
    size_t len = 0;
    for (size_t i = 0; i < sizeof app; i++)
        app[i] = (uint8_t)(i * 7u);
    assert_int_equal(wdr_fw_key_load(DEV_KEY, 1, &k, err, sizeof err), WDR_OK);
    wdr_fw_sign_params p = {.version = {2, 0, 0, 2}, .security_counter = 2, .board = board, .ram_load = 1};
    assert_int_equal(wdr_fw_sign("app.bin", app, sizeof app, &p, &k, &img, &len, err, sizeof err), WDR_OK);
    write_bytes(path, img, len - cut);
    free(img);
    wdr_fw_key_free(&k);
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/wdr_fw_client_XXXXXX");
    assert_non_null(mkdtemp(dir));
    snprintf(img_path, sizeof img_path, "%s/v2.img", dir);
    snprintf(other_board_path, sizeof other_board_path, "%s/other.img", dir);
    snprintf(short_path, sizeof short_path, "%s/short.img", dir);
    sign_to(img_path, "fake", 0);
    sign_to(other_board_path, "mps2-an500", 0);
    sign_to(short_path, "fake", 100);
    signal(SIGPIPE, SIG_IGN);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[160];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

/* ---- Cases --------------------------------------------------------------------------------------------- */

static void upload_stores_and_reports_time(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160];
    const char *args[] = {"--device", start_board(&b, addr, sizeof addr, 1), "fw", "upload", img_path, NULL};
    int rc = run_wdrctl(args);
    scripted_board_stop(&b);
    assert_int_equal(rc, EX_OK);
    assert_has(out_text, "v2.0.0+2 stored in slot B, pending");
    assert_has(out_text, "5208 image bytes in");
    assert_has(out_text, "at 115200 baud");
    assert_has(out_text, "at 921600 baud");
    assert_int_equal(got_len, 5208);
    uint8_t *img;
    size_t len;
    FILE *f = fopen(img_path, "rb");
    img = malloc(8192);
    len = fread(img, 1, 8192, f);
    fclose(f);
    assert_int_equal(got_crc, wdr_crc32(0, img, len));
    free(img);
    assert_int_equal(b.opcodes[WDR_CMD_FW_CHUNK], 2);
}

/* The link dies on FW_COMMIT: wdrctl asks again and says whether the image is pending. */
static void lost_commit_answer_is_asked_again(void **state)
{
    (void)state;
    for (int took = 1; took >= 0; took--) {
        scripted_board b;
        char addr[160];
        const char *args[] = {"--device", start_board(&b, addr, sizeof addr, 2), "fw", "upload", img_path, NULL};
        hangup_on_commit = 1;
        commit_took = took;
        int rc = run_wdrctl(args);
        scripted_board_stop(&b);
        assert_int_equal(b.opcodes[WDR_CMD_FW_STATUS], 1);
        if (took) {
            assert_int_equal(rc, EX_OK);
            assert_has(out_text, "v2.img: pending in slot B (the board reports it after the link failed)");
        } else {
            assert_int_equal(rc, EX_IOERR);
            assert_has(err_text, "v2.img: not pending on the board");
        }
    }
}

typedef struct refusal {
    int status;
    int at_begin;
    const char *sentence;
} refusal;

static void each_refusal_names_its_reason(void **state)
{
    (void)state;
    const refusal cases[] = {
        {WDR_ST_BAD_SIGNATURE, 0, "its signature does not verify with the key the board trusts (BAD_SIGNATURE)"},
        {WDR_ST_BAD_KEY, 0, "signed by a key the board does not trust (BAD_KEY)"},
        {WDR_ST_DOWNGRADE, 0, "its security counter is below the board's floor: a downgrade (DOWNGRADE)"},
        {WDR_ST_BAD_HASH, 0, "its SHA-256 differs from its trailer's: the image is damaged (BAD_HASH)"},
        {WDR_ST_BAD_BOARD, 0, "the image is for another board (BAD_BOARD)"},
        {WDR_ST_BAD_STATE, 1, "the running image is a test boot: confirm it (wdrctl fw confirm) or revert it"},
        {WDR_ST_BAD_IMAGE, 0, "its header or trailer is out of range (BAD_IMAGE)"},
        {WDR_ST_TRUNCATED, 0, "fewer bytes arrived than the image declares (TRUNCATED)"},
        {WDR_ST_BAD_CRC, 0, "the bytes the board stored differ from the bytes sent (BAD_CRC)"},
        {WDR_ST_TOO_LARGE, 1, "the image is larger than the board's image slot (TOO_LARGE)"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        scripted_board b;
        char addr[160];
        const char *args[] = {"--device", start_board(&b, addr, sizeof addr, 1), "fw", "upload", img_path, NULL};
        if (cases[i].at_begin)
            refuse_begin = cases[i].status;
        else
            refuse_commit = cases[i].status;
        int rc = run_wdrctl(args);
        scripted_board_stop(&b);
        assert_int_equal(rc, EX_DATAERR);
        assert_has(err_text, ": refused by the board: ");
        assert_has(err_text, cases[i].sentence);
        assert_has(err_text, "; nothing is pending, v1.0.0+1 in slot A still runs");
        assert_int_equal(b.opcodes[WDR_CMD_ABORT], 1); /* the board is told to drop the upload */
    }
}

static void bad_files_never_reach_the_board(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160];
    const char *args[] = {"--device", start_board(&b, addr, sizeof addr, 1), "fw", "upload", short_path, NULL};
    int rc = run_wdrctl(args);
    scripted_board_stop(&b);
    assert_int_equal(rc, EX_DATAERR);
    assert_has(err_text, "short.img: 5108 bytes, but header field image_size says 5208");
    assert_int_equal(b.requests, 0); /* not even connected */

    const char *other[] = {"--device", start_board(&b, addr, sizeof addr, 1), "fw", "upload", other_board_path, NULL};
    rc = run_wdrctl(other);
    scripted_board_stop(&b);
    assert_int_equal(rc, EX_DATAERR);
    assert_has(err_text, "other.img: header field board: 'mps2-an500', but the board is 'fake' (nothing sent)");
    assert_int_equal(b.opcodes[WDR_CMD_FW_BEGIN], 0);

    /* --no-verify sends it all the same: what the board's own refusals are tested with */
    const char *unchecked[] = {
        "--device", start_board(&b, addr, sizeof addr, 1), "fw", "upload", "--no-verify", short_path, NULL};
    refuse_commit = WDR_ST_TRUNCATED;
    rc = run_wdrctl(unchecked);
    scripted_board_stop(&b);
    assert_int_equal(rc, EX_DATAERR);
    assert_int_equal(b.opcodes[WDR_CMD_FW_BEGIN], 1);
}

static void old_board_is_told_to_flash_by_debugger(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160];
    const char *args[] = {"--device", start_board(&b, addr, sizeof addr, 1), "fw", "upload", img_path, NULL};
    proto_minor = 3;
    int rc = run_wdrctl(args);
    scripted_board_stop(&b);
    assert_int_equal(rc, EX_UNAVAILABLE);
    assert_has(err_text, "board speaks protocol 1.3: firmware update needs 1.4");
    assert_int_equal(b.opcodes[WDR_CMD_FW_BEGIN], 0);
}

static void status_shows_slots_and_the_fault(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160];
    const char *args[] = {"--device", start_board(&b, addr, sizeof addr, 1), "fw", "status", NULL};
    int rc = run_wdrctl(args);
    scripted_board_stop(&b);
    assert_int_equal(rc, EX_OK);
    assert_has(out_text, "running:          v1.0.0+1 in slot A");
    assert_has(out_text, "slot A:           confirmed  v1.0.0+1       counter 1, 4096 bytes, sha256 abcd");
    assert_has(out_text, "slot B:           rejected   v2.0.0+2       counter 2, 8192 bytes");
    assert_has(out_text, "(reverted)");
    assert_has(out_text, "last reset:       fault at PC 0x00001234, CFSR 0x00008200");
    assert_has(out_text, "security floor:   1");
    assert_has(out_text, "development key: not for production");

    const char *json[] = {"--device", start_board(&b, addr, sizeof addr, 1), "fw", "status", "--json", NULL};
    rc = run_wdrctl(json);
    scripted_board_stop(&b);
    assert_int_equal(rc, EX_OK);
    cJSON *o = cJSON_Parse(out_text);
    assert_non_null(o);
    assert_string_equal(cJSON_GetObjectItem(o, "reset_cause")->valuestring, "fault");
    assert_string_equal(cJSON_GetObjectItem(o, "fault_pc")->valuestring, "0x00001234");
    assert_true(cJSON_IsTrue(cJSON_GetObjectItem(o, "dev_key")));
    cJSON *slots = cJSON_GetObjectItem(o, "slots");
    assert_int_equal(cJSON_GetArraySize(slots), 2);
    assert_string_equal(cJSON_GetObjectItem(cJSON_GetArrayItem(slots, 1), "state")->valuestring, "rejected");
    assert_string_equal(cJSON_GetObjectItem(cJSON_GetArrayItem(slots, 1), "version")->valuestring, "2.0.0+2");
    cJSON_Delete(o);
}

static void confirm_and_revert_name_bad_state(void **state)
{
    (void)state;
    const char *cmds[] = {"confirm", "revert"};
    const char *says[] = {"fw confirm: refused by the board: the running image is neither pending nor testing: "
                          "nothing to confirm (BAD_STATE)",
                          "fw revert: refused by the board: the other slot holds no valid confirmed image: nothing to "
                          "revert to (BAD_STATE)"};
    for (int i = 0; i < 2; i++) {
        scripted_board b;
        char addr[160];
        const char *args[] = {"--device", start_board(&b, addr, sizeof addr, 1), "fw", cmds[i], NULL};
        refuse_confirm = WDR_ST_BAD_STATE;
        int rc = run_wdrctl(args);
        scripted_board_stop(&b);
        assert_int_equal(rc, EX_DATAERR);
        assert_has(err_text, says[i]);
        const char *ok[] = {"--device", start_board(&b, addr, sizeof addr, 1), "fw", cmds[i], NULL};
        rc = run_wdrctl(ok);
        scripted_board_stop(&b);
        assert_int_equal(rc, EX_OK);
        assert_has(out_text, i ? "given up" : "confirmed, it stays");
    }
}

static void reboot_reconnects_and_prints_the_new_image(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160];
    const char *args[] = {"--device", start_board(&b, addr, sizeof addr, 2), "reboot", NULL};
    int rc = run_wdrctl(args);
    scripted_board_stop(&b);
    assert_int_equal(rc, EX_OK);
    assert_int_equal(b.opcodes[WDR_CMD_REBOOT], 1);
    assert_int_equal(b.opcodes[WDR_CMD_INFO], 2);
    assert_has(out_text, "was v1.0.0+1 in slot A, now v2.0.0+2 in slot B (test boot)");

    /* the old boot answers the first host after REBOOT: its boot count gives it away */
    const char *stale[] = {"--device", start_board(&b, addr, sizeof addr, 3), "reboot", NULL};
    stale_sessions = 1;
    rc = run_wdrctl(stale);
    scripted_board_stop(&b);
    assert_int_equal(rc, EX_OK);
    assert_int_equal(b.opcodes[WDR_CMD_INFO], 3);
    assert_has(out_text, "now v2.0.0+2 in slot B (test boot)");

    /* a board that never comes back: the wait ends with the reason and what ran */
    const char *gone[] = {
        "--device", start_board(&b, addr, sizeof addr, 1), "--wait", "300", "--timeout", "300", "reboot", NULL};
    rc = run_wdrctl(gone);
    scripted_board_stop(&b);
    assert_int_equal(rc, EX_TEMPFAIL);
    assert_has(err_text, "reboot: the board did not answer again within 300 ms");
}

static void info_prints_the_running_image(void **state)
{
    (void)state;
    scripted_board b;
    char addr[160];
    const char *args[] = {"--device", start_board(&b, addr, sizeof addr, 1), "info", NULL};
    int rc = run_wdrctl(args);
    scripted_board_stop(&b);
    assert_int_equal(rc, EX_OK);
    assert_has(out_text, "firmware:      1.0.0+1, slot A\n");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(upload_stores_and_reports_time),
        cmocka_unit_test(each_refusal_names_its_reason),
        cmocka_unit_test(lost_commit_answer_is_asked_again),
        cmocka_unit_test(bad_files_never_reach_the_board),
        cmocka_unit_test(old_board_is_told_to_flash_by_debugger),
        cmocka_unit_test(status_shows_slots_and_the_fault),
        cmocka_unit_test(confirm_and_revert_name_bad_state),
        cmocka_unit_test(reboot_reconnects_and_prints_the_new_image),
        cmocka_unit_test(info_prints_the_running_image),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
