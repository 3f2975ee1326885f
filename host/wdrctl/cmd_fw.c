/* wdrctl fw upload, fw status, fw confirm, fw revert, reboot: firmware images on a board
 * (protocol 1.4; firmware/SPEC.md, "Image flash and boot"). The board keeps running while an
 * image goes into the slot it does not run; a refusal names its reason and changes nothing. */
#include "crc32.h"
#include "fw_sign.h"
#include "transport.h"
#include "transport_client.h"
#include "wdr_err.h"
#include "wdrctl.h"
#include "wdrctl_fw.h"
#include <cJSON.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define REBOOT_WAIT_MS 15000 /* a rebooting board answers again within this (unless --wait) */
#define DROP_WAIT_MS 1000    /* how long the old link may take to drop after REBOOT */

typedef struct fw_opts {
    const char *device;
    int timeout_ms, retries, wait_ms, no_verify, json;
} fw_opts;

#define O(f) offsetof(fw_opts, f)
static const cli_option upload_rows[] = {
    {"no-verify", 0, CLI_FLAG, O(no_verify), NULL, "send the file unchecked (to see the board's own refusals)"},
    {0}};
static const cli_option status_rows[] = {{"json", 0, CLI_FLAG, O(json), NULL, "print JSON"}, {0}};
static const cli_option no_rows[] = {{0}};
#undef O

#define FW_COMMAND(var, name, args, lo, hi, summary, details, rows, fn) \
    const cli_command var = {name, args, lo, hi, summary, details, rows, fn, CLI_CMD_BOARD}
FW_COMMAND(wdrctl_cmd_fw_upload, "fw upload", "APP.img", 1, 1, "send a signed image to the slot the board does not run",
           "The file is checked first (fw info's checks and the board's name); the board then verifies board, "
           "hash, key, signature and security counter and marks it pending, or refuses with a reason and marks "
           "nothing. Prints the bytes, the time, and what a UART at 115200 and 921600 baud would take.",
           upload_rows, cmd_fw_upload);
FW_COMMAND(wdrctl_cmd_fw_status, "fw status", NULL, 0, 0, "both image slots, the running one, the last reset's cause",
           NULL, status_rows, cmd_fw_status);
FW_COMMAND(wdrctl_cmd_fw_confirm, "fw confirm", NULL, 0, 0, "keep the running test image (it becomes confirmed)",
           NULL, no_rows, cmd_fw_confirm);
FW_COMMAND(wdrctl_cmd_fw_revert, "fw revert", NULL, 0, 0, "give up the running image: the next boot runs the other",
           NULL, no_rows, cmd_fw_revert);
FW_COMMAND(wdrctl_cmd_reboot, "reboot", NULL, 0, 0, "reset the board and wait until it answers again",
           "Sends REBOOT, then connects again until the board answers from a new boot (its FW_STATUS boot "
           "count changed; without one, after the old link dropped) within --wait MS (default 15000), and "
           "prints the image it runs now.",
           no_rows, cmd_reboot);

static int parse_fw(int argc, char **argv, const cli_command *cmd, fw_opts *o)
{
    int n_args = 0;
    *o = (fw_opts){.device = wdrctl_global.device, .timeout_ms = wdrctl_global.timeout_ms,
                   .retries = wdrctl_global.retries, .wait_ms = wdrctl_global.wait_ms};
    return wdrctl_parse(cmd, argc, argv, o, &n_args);
}

static int connect_fw(const fw_opts *o, wdrctl_conn *conn)
{
    return wdrctl_connect_wait(o->device, o->timeout_ms, o->retries, o->wait_ms, conn);
}

/* ---- Words ------------------------------------------------------------------------------------- */

/* FW_STATUS's codes (SPEC.md, "Firmware status"; wdr_boot.h's enums, which the host does not
 * include: it knows the board only through the protocol). */
enum { SLOT_EMPTY, SLOT_INCOMPLETE, SLOT_PENDING, SLOT_TESTING, SLOT_CONFIRMED, SLOT_REJECTED, SLOT_INVALID };
enum { REJECT_INVALID = 3, RESET_FAULT = 3 };

static const char *slot_letter(unsigned slot) { return slot == 0 ? "A" : slot == 1 ? "B" : "none"; }

/* "v1.2.3+4 in slot A (test boot)" from INFO 1.4, or the built-in version of a board not
 * started from a slot. */
static void running_text(const wdr_info *i, char *out, size_t cap)
{
    wdr_image_version v = {(uint8_t)i->fw_major, (uint8_t)i->fw_minor, i->fw_patch, i->fw_build};
    char ver[48];
    wdr_fw_version_format(&v, ver, sizeof ver);
    if (i->fw_slot > 1)
        snprintf(out, cap, "firmware %u.%u (not booted from a slot)", i->fw_major, i->fw_minor);
    else
        snprintf(out, cap, "v%s in slot %s%s", ver, slot_letter(i->fw_slot), i->fw_flags & 1 ? " (test boot)" : "");
}

/* Why the board refused opcode with status, as a sentence. */
static const char *refusal_text(int status, uint8_t opcode)
{
    switch (status) {
    case WDR_ST_BAD_SIGNATURE: return "its signature does not verify with the key the board trusts";
    case WDR_ST_BAD_KEY: return "signed by a key the board does not trust";
    case WDR_ST_DOWNGRADE: return "its security counter is below the board's floor: a downgrade";
    case WDR_ST_BAD_HASH: return "its SHA-256 differs from its trailer's: the image is damaged";
    case WDR_ST_BAD_BOARD: return "the image is for another board";
    case WDR_ST_BAD_IMAGE: return "its header or trailer is out of range";
    case WDR_ST_TRUNCATED: return "fewer bytes arrived than the image declares";
    case WDR_ST_BAD_CRC: return "the bytes the board stored differ from the bytes sent";
    case WDR_ST_TOO_LARGE: return "the image is larger than the board's image slot";
    case WDR_ST_UNSUPPORTED: return "this board has no image flash";
    case WDR_ST_FLASH: return "the image flash refused an operation";
    case WDR_ST_BUSY: return "a capture or stream is running";
    case WDR_ST_BAD_STATE:
        if (opcode == WDR_CMD_FW_CONFIRM)
            return "the running image is neither pending nor testing: nothing to confirm";
        if (opcode == WDR_CMD_FW_REVERT)
            return "the other slot holds no valid confirmed image: nothing to revert to";
        return "the running image is a test boot: confirm it (wdrctl fw confirm) or revert it (wdrctl fw revert) first";
    default: return NULL;
    }
}

/* Print the board's refusal of opcode and return its exit code; what: the file or the command. */
static int refused(wdrctl_conn *conn, int rc, uint8_t opcode, const char *what, const char *after)
{
    const char *why = rc == WDR_E_STATUS ? refusal_text(conn->c->status, opcode) : NULL;
    if (!why)
        return wdrctl_conn_fail(conn, rc);
    return wdrctl_fail(wdrctl_exit_code(rc, conn->c->status), "%s: refused by the board: %s (%s)%s", what, why,
                       wdr_client_status_ident(conn->c->status), after);
}

/* ---- fw upload ------------------------------------------------------------------------------------ */

/* The file's own checks, before the board is touched; hdr gets its header. */
static int check_image_file(const char *path, const uint8_t *img, size_t len, wdr_image_header *hdr)
{
    wdr_fw_image_report r;
    char err[512];
    int rc = wdr_fw_image_check(path, img, len, NULL, &r, err, sizeof err);
    *hdr = r.hdr;
    return rc == WDR_OK ? EX_OK : wdrctl_fail(wdrctl_fw_check_exit(rc), "%s", err);
}

static int check_board_name(const char *path, const wdr_image_header *h, const wdr_info *i)
{
    if (!strcmp(h->board, i->name))
        return EX_OK;
    return wdrctl_fail(EX_DATAERR, "%s: header field board: '%s', but the board is '%s' (nothing sent)", path,
                       h->board, i->name);
}

static void upload_progress(void *ctx, size_t done, size_t total)
{
    fprintf(stderr, "\r%s: %3d%% (%zu/%zu bytes)%s", (const char *)ctx, (int)(100.0 * (double)done / (double)total),
            done, total, done == total ? "\n" : "");
}

/* Bytes and time, and what a UART would take for the same bytes both ways (10 bits a byte:
 * start, 8 data, stop; the host waits for each chunk's answer, so both directions count). */
static void print_upload_time(const wdrctl_conn *conn, size_t len, uint64_t tx, uint64_t rx, int64_t ms)
{
    double bits = 10.0 * (double)(tx + rx), kb_s = ms > 0 ? (double)len / (double)ms : 0.0; /* bytes/ms */
    printf("%zu image bytes in %.3f s over %s (%.*f %s); on the link %llu bytes out, %llu back\n", len,
           (double)ms / 1000.0, wdr_transport_name(conn->t), kb_s < 1000 ? 1 : 2, kb_s < 1000 ? kb_s : kb_s / 1000,
           kb_s < 1000 ? "kB/s" : "MB/s", (unsigned long long)tx, (unsigned long long)rx);
    printf("the same bytes on a UART (wire time alone): %.1f s at 115200 baud, %.2f s at 921600 baud\n",
           bits / 115200.0, bits / 921600.0);
}

/* The link failed on FW_COMMIT: ask again whether the image is pending. */
static int fw_commit_outcome(wdrctl_conn *conn, const fw_opts *o, const char *path, const uint8_t *img, size_t len)
{
    const uint8_t *sha = len >= WDR_IMAGE_HEADER_SIZE + WDR_IMAGE_TRAILER_SIZE ? img + len - WDR_IMAGE_TRAILER_SIZE + 8
                                                                              : NULL; /* a --no-verify scrap */
    fprintf(stderr, "wdrctl: %s; %s was sent in full, asking the board whether it took it\n", conn->c->err, path);
    wdrctl_disconnect(conn);
    wdrctl_conn again;
    wdr_fw_status_report st;
    if (wdrctl_connect_wait(o->device, o->timeout_ms, o->retries, 3000, &again) != EX_OK)
        return wdrctl_fail(EX_TEMPFAIL, "outcome unknown: the board did not answer again; run 'wdrctl fw status'");
    int rc = wdr_client_fw_status(again.c, &st), code = EX_IOERR;
    for (int s = 0; rc == WDR_OK && s < 2; s++)
        if (sha && st.slot[s].state == SLOT_PENDING && !memcmp(st.slot[s].sha256, sha, WDR_SHA256_SIZE)) {
            printf("%s: pending in slot %s (the board reports it after the link failed)\n", path, slot_letter(s));
            code = EX_OK;
        }
    if (code != EX_OK)
        code = wdrctl_fail(rc == WDR_OK ? EX_IOERR : EX_TEMPFAIL, "%s: not pending on the board%s", path,
                           rc == WDR_OK ? "" : " (FW_STATUS failed; run 'wdrctl fw status')");
    wdrctl_disconnect(&again);
    return code;
}

static int send_image(wdrctl_conn *conn, const fw_opts *o, const char *path, const uint8_t *img, size_t len)
{
    wdr_client *c = conn->c;
    char runs[96], after[160];
    uint64_t tx0 = c->tx_bytes, rx0 = c->rx_bytes;
    int64_t t0 = wdr_transport_now_ms();
    wdr_fw_commit reply;
    int r = wdr_client_fw_upload(c, img, len, wdrctl_show_progress() ? upload_progress : NULL, (void *)path, &reply);
    int64_t ms = wdr_transport_now_ms() - t0;
    if (r != WDR_OK && c->commit_unknown)
        return fw_commit_outcome(conn, o, path, img, len);
    running_text(&c->info, runs, sizeof runs);
    snprintf(after, sizeof after, "; nothing is pending, %s still runs", runs);
    if (r != WDR_OK)
        return refused(conn, r, WDR_CMD_FW_COMMIT, path, after);
    char ver[48];
    wdr_fw_version_format(&reply.hdr.version, ver, sizeof ver);
    printf("%s: v%s stored in slot %s, pending: 'wdrctl reboot' runs it as a test boot, 'wdrctl fw confirm' then "
           "keeps it\n", path, ver, slot_letter(reply.slot));
    print_upload_time(conn, len, c->tx_bytes - tx0, c->rx_bytes - rx0, ms);
    return EX_OK;
}

int cmd_fw_upload(int argc, char **argv)
{
    fw_opts o;
    wdrctl_conn conn;
    uint8_t *img = NULL;
    size_t len = 0;
    wdr_image_header hdr;
    int rc = parse_fw(argc, argv, &wdrctl_cmd_fw_upload, &o);
    if (rc != EX_OK || (rc = wdrctl_fw_read_image(argv[1], &img, &len)) != EX_OK)
        return rc;
    if (!o.no_verify && (rc = check_image_file(argv[1], img, len, &hdr)) != EX_OK) {
        free(img);
        return rc;
    }
    if ((rc = connect_fw(&o, &conn)) == EX_OK) {
        if (o.no_verify || (rc = check_board_name(argv[1], &hdr, &conn.c->info)) == EX_OK)
            rc = send_image(&conn, &o, argv[1], img, len);
        wdrctl_disconnect(&conn);
    }
    free(img);
    return rc;
}

/* ---- fw status -------------------------------------------------------------------------------------- */

static const char *const slot_states[] = {"empty",     "incomplete", "pending", "testing",
                                          "confirmed", "rejected",   "invalid"};
static const char *const reset_causes[] = {"power-on", "software", "watchdog", "fault", "unknown"};
static const char *const reject_reasons[] = {"", "unconfirmed after its test boots", "reverted", "failed verification"};

static const char *state_word(unsigned s) { return s < 7 ? slot_states[s] : "?"; }
static const char *cause_word(unsigned c) { return c < 5 ? reset_causes[c] : "?"; }

static void slot_version(const wdr_fw_slot_report *s, char *out, size_t cap)
{
    wdr_image_version v = {s->ver_major, s->ver_minor, s->ver_patch, s->ver_build};
    out[0] = 'v';
    wdr_fw_version_format(&v, out + 1, cap - 1);
}

/* What follows the state: why it was rejected, fails, or never ran. */
static void slot_note(const wdr_fw_slot_report *s, char *out, size_t cap)
{
    out[0] = 0;
    if (s->state == SLOT_INCOMPLETE)
        snprintf(out, cap, " (an upload that never verified: never booted)");
    else if (s->state == SLOT_REJECTED && s->reject_reason == REJECT_INVALID && s->verify_err)
        snprintf(out, cap, " (%s: %s)", reject_reasons[REJECT_INVALID], wdr_strerror(s->verify_err));
    else if (s->state == SLOT_REJECTED && s->reject_reason > 0 && s->reject_reason <= REJECT_INVALID)
        snprintf(out, cap, " (%s)", reject_reasons[s->reject_reason]);
    else if (s->state == SLOT_INVALID && s->verify_err)
        snprintf(out, cap, " (%s)", wdr_strerror(s->verify_err));
}

static void print_slot(int n, const wdr_fw_slot_report *s, int running)
{
    char ver[48], sha[17], note[96];
    slot_note(s, note, sizeof note);
    if (s->state == SLOT_EMPTY) {
        printf("slot %s:           empty\n", slot_letter(n));
        return;
    }
    slot_version(s, ver, sizeof ver);
    wdr_fw_hex(s->sha256, 8, sha);
    printf("slot %s:           %-10s %-14s counter %u, %u bytes, sha256 %s..., attempts %u%s%s\n", slot_letter(n),
           state_word(s->state), ver, s->security_counter, s->image_size, sha, s->attempts, note,
           running ? "  <- running" : "");
}

static void print_fw_status_text(const wdr_fw_status_report *st, const wdr_info *i)
{
    char runs[96], key[9];
    running_text(i, runs, sizeof runs);
    if (st->flags & WDR_FW_STATUS_F_NO_BOOT)
        printf("running:          %s; not started by the bootloader (no image flash, or a debug load)\n", runs);
    else
        printf("running:          %s%s\n", runs,
               st->flags & WDR_FW_STATUS_F_TESTING ? ": confirm it (wdrctl fw confirm) or it reverts" : "");
    for (int s = 0; s < 2; s++)
        print_slot(s, &st->slot[s], st->running == s);
    if (st->reset_cause == RESET_FAULT)
        printf("last reset:       fault at PC 0x%08x, CFSR 0x%08x\n", st->fault_pc, st->fault_status);
    else
        printf("last reset:       %s\n", cause_word(st->reset_cause));
    wdr_fw_hex(st->key_hash, 4, key);
    printf("security floor:   %u\nboots:            %u since power-on\ntest boots:       %u before a revert\n"
           "trusted key:      sha256 %s...\n", st->floor, st->boots, st->max_attempts, key);
    if (st->flags & WDR_FW_STATUS_F_DEV_KEY)
        printf("development key: not for production\n");
}

static void add_hex(cJSON *o, const char *name, uint32_t v)
{
    char hex[16];
    snprintf(hex, sizeof hex, "0x%08x", v);
    cJSON_AddStringToObject(o, name, hex);
}

static cJSON *slot_json(int n, const wdr_fw_slot_report *s)
{
    char ver[48], sha[65];
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "slot", slot_letter(n));
    cJSON_AddStringToObject(o, "state", state_word(s->state));
    slot_version(s, ver, sizeof ver);
    cJSON_AddStringToObject(o, "version", ver + 1);
    cJSON_AddNumberToObject(o, "security_counter", s->security_counter);
    cJSON_AddNumberToObject(o, "image_size", s->image_size);
    wdr_fw_hex(s->sha256, WDR_SHA256_SIZE, sha);
    cJSON_AddStringToObject(o, "sha256", sha);
    cJSON_AddNumberToObject(o, "attempts", s->attempts);
    cJSON_AddNumberToObject(o, "reject_reason", s->reject_reason);
    cJSON_AddStringToObject(o, "verify_error", s->verify_err ? wdr_strerror(s->verify_err) : "");
    return o;
}

static void print_fw_status_json(const wdr_fw_status_report *st)
{
    char key[9];
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "running", slot_letter(st->running));
    cJSON_AddBoolToObject(o, "testing", (st->flags & WDR_FW_STATUS_F_TESTING) != 0);
    cJSON_AddBoolToObject(o, "bootloader", !(st->flags & WDR_FW_STATUS_F_NO_BOOT));
    cJSON_AddBoolToObject(o, "dev_key", (st->flags & WDR_FW_STATUS_F_DEV_KEY) != 0);
    cJSON_AddStringToObject(o, "reset_cause", cause_word(st->reset_cause));
    add_hex(o, "fault_pc", st->fault_pc);
    add_hex(o, "fault_status", st->fault_status);
    cJSON_AddNumberToObject(o, "floor", st->floor);
    cJSON_AddNumberToObject(o, "boots", st->boots);
    cJSON_AddNumberToObject(o, "max_attempts", st->max_attempts);
    wdr_fw_hex(st->key_hash, 4, key);
    cJSON_AddStringToObject(o, "key_hash_prefix", key);
    cJSON *slots = cJSON_AddArrayToObject(o, "slots");
    for (int s = 0; s < 2; s++)
        cJSON_AddItemToArray(slots, slot_json(s, &st->slot[s]));
    char *text = cJSON_Print(o);
    printf("%s\n", text ? text : "{}");
    free(text);
    cJSON_Delete(o);
}

int cmd_fw_status(int argc, char **argv)
{
    fw_opts o;
    wdrctl_conn conn;
    wdr_fw_status_report st;
    int rc = parse_fw(argc, argv, &wdrctl_cmd_fw_status, &o);
    if (rc != EX_OK || (rc = connect_fw(&o, &conn)) != EX_OK)
        return rc;
    int r = wdr_client_fw_status(conn.c, &st);
    if (r == WDR_OK && o.json)
        print_fw_status_json(&st);
    else if (r == WDR_OK)
        print_fw_status_text(&st, &conn.c->info);
    rc = r == WDR_OK ? EX_OK : refused(&conn, r, WDR_CMD_FW_STATUS, "fw status", "");
    wdrctl_disconnect(&conn);
    return rc;
}

/* ---- fw confirm, fw revert ---------------------------------------------------------------------------- */

static int fw_simple(int argc, char **argv, const cli_command *cmd, uint8_t opcode, const char *done)
{
    fw_opts o;
    wdrctl_conn conn;
    char runs[96];
    int rc = parse_fw(argc, argv, cmd, &o);
    if (rc != EX_OK || (rc = connect_fw(&o, &conn)) != EX_OK)
        return rc;
    int r = wdr_client_fw_request(conn.c, opcode);
    running_text(&conn.c->info, runs, sizeof runs);
    if (r == WDR_OK)
        printf("%s: %s\n", runs, done);
    rc = r == WDR_OK ? EX_OK : refused(&conn, r, opcode, cmd->name, "");
    wdrctl_disconnect(&conn);
    return rc;
}

int cmd_fw_confirm(int argc, char **argv)
{
    return fw_simple(argc, argv, &wdrctl_cmd_fw_confirm, WDR_CMD_FW_CONFIRM, "confirmed, it stays");
}

int cmd_fw_revert(int argc, char **argv)
{
    return fw_simple(argc, argv, &wdrctl_cmd_fw_revert, WDR_CMD_FW_REVERT,
                     "given up: the next boot runs the other slot ('wdrctl reboot')");
}

/* ---- reboot ------------------------------------------------------------------------------------------- */

/* The board's boot count, to tell the new boot from the old one; 0 when it has none. */
static uint32_t boots_of(wdr_client *c)
{
    wdr_fw_status_report st;
    if (wdr_client_fw_status(c, &st) != WDR_OK || (st.flags & WDR_FW_STATUS_F_NO_BOOT))
        return 0;
    return st.boots;
}

/* After REBOOT: the old link drops (a socket) or goes quiet (a UART); wait for either. */
static void wait_link_drop(wdrctl_conn *conn)
{
    uint8_t junk[256];
    int64_t deadline = wdr_transport_now_ms() + DROP_WAIT_MS;
    for (int64_t left = DROP_WAIT_MS; left > 0; left = deadline - wdr_transport_now_ms())
        if (wdr_transport_recv(conn->t, junk, sizeof junk, (int)left) < 0)
            return;
}

/* Connect again and again, quietly, until the board answers INFO (with another boot count
 * than old_boots, when that is known) or the deadline passes. */
static int reconnect_quietly(const fw_opts *o, int64_t deadline, uint32_t old_boots, wdrctl_conn *conn, char *err,
                             size_t cap)
{
    memset(conn, 0, sizeof *conn);
    conn->c = calloc(1, sizeof *conn->c);
    if (!conn->c)
        return WDR_E_NOMEM;
    int rc = WDR_E_TIMEOUT;
    snprintf(err, cap, "no answer");
    while (wdr_transport_now_ms() < deadline) {
        rc = wdr_transport_open(o->device, &conn->t, err, (int)cap);
        if (rc == WDR_OK) {
            conn->c->timeout_ms = o->timeout_ms;
            conn->c->retries = 0;
            rc = wdr_client_connect(conn->c, conn->t);
            if (rc == WDR_OK && (!old_boots || boots_of(conn->c) != old_boots))
                return WDR_OK;
            if (rc == WDR_OK) {
                rc = WDR_E_TIMEOUT;
                snprintf(err, cap, "it still answers from the boot before the REBOOT");
            } else
                snprintf(err, cap, "%s", conn->c->err);
            wdr_transport_close(conn->t);
            conn->t = NULL;
        }
        usleep(50000);
    }
    free(conn->c);
    conn->c = NULL;
    return rc;
}

int cmd_reboot(int argc, char **argv)
{
    fw_opts o;
    wdrctl_conn conn;
    char before[96], after[96], err[320];
    int rc = parse_fw(argc, argv, &wdrctl_cmd_reboot, &o);
    if (rc != EX_OK || (rc = connect_fw(&o, &conn)) != EX_OK)
        return rc;
    running_text(&conn.c->info, before, sizeof before);
    uint32_t old_boots = conn.c->info.proto_minor >= 4 ? boots_of(conn.c) : 0;
    int r = wdr_client_fw_request(conn.c, WDR_CMD_REBOOT);
    if (r != WDR_OK) {
        rc = refused(&conn, r, WDR_CMD_REBOOT, "reboot", "");
        wdrctl_disconnect(&conn);
        return rc;
    }
    int64_t t0 = wdr_transport_now_ms();
    if (!old_boots)
        wait_link_drop(&conn); /* no boot count to tell the boots apart: let the old one go */
    wdrctl_disconnect(&conn);
    int wait = o.wait_ms > 0 ? o.wait_ms : REBOOT_WAIT_MS;
    r = reconnect_quietly(&o, t0 + wait, old_boots, &conn, err, sizeof err);
    if (r != WDR_OK)
        return wdrctl_fail(wdrctl_exit_code(r == WDR_E_ABSENT ? WDR_E_TIMEOUT : r, 0),
                           "reboot: the board did not answer again within %d ms (%s); it ran %s", wait, err, before);
    running_text(&conn.c->info, after, sizeof after);
    printf("rebooted in %.2f s: was %s, now %s\n", (double)(wdr_transport_now_ms() - t0) / 1000.0, before, after);
    wdrctl_disconnect(&conn);
    return EX_OK;
}
