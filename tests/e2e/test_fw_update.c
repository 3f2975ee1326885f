/* The field update on the simulated board, over its socket (issue 18): wdr-simboard flashed
 * with a factory v1 (--firmware), v2 uploaded with the protocol client, a reboot into a test
 * boot, confirm, a reboot: still v2. An unconfirmed v2 is back to v1 after 3 reboots; a bad
 * image is refused with its reason and v1 keeps answering. Every reset goes through the
 * bootloader's logic compiled for the host (hal/sim/hal_sim_boot.c). Images are signed with
 * OpenSSL by the development key (tests/firmware/boot_test_util.c). Upload times are printed. */
#include "boot_test_util.h"
#include "e2e_board.h"
#include "crc32.h"
#include "transport.h"
#include "wdr_boot.h"
#include "wdr_bytes.h"
#include "wdr_err.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define BOARD "sim-qvga"
#define APP_BYTES (256u * 1024u)

static bt_key key;
static char dir[64], v1_path[128];
static uint8_t *v1, *v2;
static size_t v1_len, v2_len;

static uint8_t *sign(uint8_t major, uint32_t counter, const char *board, size_t *len)
{
    bt_image_spec s = bt_spec(major, counter, APP_BYTES);
    s.version.build = 42;
    s.board = board;
    s.flags |= WDR_IMAGE_F_DEV_KEY;
    uint8_t *img = malloc(APP_BYTES + 256);
    *len = bt_image_build(img, APP_BYTES + 256, &s, &key, NULL);
    return img;
}

/* BEGIN, 4 KiB chunks, COMMIT; the first status that is not OK. */
static int upload(e2e_board *rig, const uint8_t *img, size_t len)
{
    static uint8_t pl[WDR_PROTO_MAX_PAYLOAD];
    int64_t t0 = wdr_transport_now_ms();
    wdr_put_u32(pl, (uint32_t)len);
    wdr_put_u32(pl + 4, wdr_crc32(0, img, len));
    int rc = wdr_client_request(rig->c, WDR_CMD_FW_BEGIN, pl, WDR_BEGIN_SIZE);
    for (size_t off = 0; rc == WDR_OK && off < len; off += WDR_PROTO_CHUNK_DATA_MAX) {
        size_t n = len - off < WDR_PROTO_CHUNK_DATA_MAX ? len - off : WDR_PROTO_CHUNK_DATA_MAX;
        wdr_put_u32(pl, (uint32_t)off);
        memcpy(pl + 4, img + off, n);
        rc = wdr_client_request(rig->c, WDR_CMD_FW_CHUNK, pl, (uint32_t)(4 + n));
    }
    if (rc == WDR_OK)
        rc = wdr_client_request(rig->c, WDR_CMD_FW_COMMIT, NULL, 0);
    int64_t ms = wdr_transport_now_ms() - t0;
    printf("upload of %zu bytes over sim: %lld ms (%.2f MB/s), status %s\n", len, (long long)ms,
           ms > 0 ? len / 1e3 / (double)ms : 0.0, wdr_status_name(rc == WDR_OK ? 0 : rig->c->status));
    return rc == WDR_OK ? WDR_ST_OK : rc == WDR_E_STATUS ? rig->c->status : -1;
}

static wdr_fw_status_report fw_status(e2e_board *rig)
{
    wdr_fw_status_report r;
    memset(&r, 0, sizeof r);
    assert_int_equal(wdr_client_request(rig->c, WDR_CMD_FW_STATUS, NULL, 0), WDR_OK);
    assert_int_equal(wdr_fw_status_unpack(rig->c->reply, rig->c->reply_len, &r), WDR_OK);
    return r;
}

/* REBOOT, then a new session on the board that came back (the reset drops the link). */
static void reboot(e2e_board *rig)
{
    assert_int_equal(wdr_client_request(rig->c, WDR_CMD_REBOOT, NULL, 0), WDR_OK);
    for (int tries = 0; tries < 50; tries++) {
        if (e2e_reconnect(rig) == 0)
            return;
        usleep(20000);
    }
    fail_msg("the board did not come back after REBOOT");
}

static void start_with_v1(e2e_board *rig)
{
    assert_int_equal(e2e_start_with_firmware(rig, BOARD, NULL, v1_path), 0);
    assert_int_equal(rig->c->info.fw_major, 1);
    assert_int_equal(rig->c->info.fw_slot, 0);
    assert_int_equal(rig->c->info.fw_build, 42);
}

static void update_test_boot_confirm(void **state)
{
    (void)state;
    e2e_board rig;
    start_with_v1(&rig);
    assert_int_equal(upload(&rig, v2, v2_len), WDR_ST_OK);
    assert_int_equal(fw_status(&rig).slot[1].state, WDR_SLOT_PENDING);
    reboot(&rig);
    assert_int_equal(rig.c->info.fw_major, 2);
    assert_int_equal(rig.c->info.fw_slot, 1);
    assert_int_equal(rig.c->info.fw_flags, 1); /* a test boot */
    wdr_fw_status_report r = fw_status(&rig);
    assert_int_equal(r.reset_cause, WDR_RESET_SOFTWARE);
    assert_int_equal(r.slot[1].state, WDR_SLOT_TESTING);
    assert_int_equal(wdr_client_request(rig.c, WDR_CMD_FW_CONFIRM, NULL, 0), WDR_OK);
    reboot(&rig);
    assert_int_equal(rig.c->info.fw_major, 2);
    assert_int_equal(rig.c->info.fw_flags, 0);
    assert_int_equal(fw_status(&rig).slot[1].state, WDR_SLOT_CONFIRMED);
    e2e_stop(&rig);
}

static void unconfirmed_reverts_after_three_reboots(void **state)
{
    (void)state;
    e2e_board rig;
    start_with_v1(&rig);
    assert_int_equal(upload(&rig, v2, v2_len), WDR_ST_OK);
    for (unsigned i = 0; i < WDR_BOOT_MAX_ATTEMPTS; i++) {
        reboot(&rig);
        assert_int_equal(rig.c->info.fw_major, 2);
        assert_int_equal(rig.c->info.fw_flags, 1);
    }
    reboot(&rig);
    assert_int_equal(rig.c->info.fw_major, 1);
    assert_int_equal(rig.c->info.fw_slot, 0);
    wdr_fw_status_report r = fw_status(&rig);
    assert_int_equal(r.slot[1].state, WDR_SLOT_REJECTED);
    assert_int_equal(r.slot[1].reject_reason, WDR_REJECT_UNCONFIRMED);
    e2e_stop(&rig);
}

static void bad_image_refused_v1_answers(void **state)
{
    (void)state;
    e2e_board rig;
    size_t n;
    uint8_t *other = sign(2, 1, "sim-vga", &n);
    start_with_v1(&rig);
    assert_int_equal(upload(&rig, other, n), WDR_ST_BAD_BOARD);
    assert_int_not_equal(fw_status(&rig).slot[1].state, WDR_SLOT_PENDING);
    reboot(&rig);
    assert_int_equal(rig.c->info.fw_major, 1);
    e2e_stop(&rig);
    free(other);
}

static void blank_board_runs_unversioned(void **state)
{
    (void)state;
    e2e_board rig;
    assert_int_equal(e2e_start(&rig, BOARD), 0);
    assert_int_equal(rig.c->info.fw_slot, WDR_SLOT_NONE);
    assert_true(fw_status(&rig).flags & WDR_FW_STATUS_F_NO_BOOT);
    e2e_stop(&rig);
}

static int setup(void **state)
{
    (void)state;
    bt_key_dev(&key);
    v1 = sign(1, 1, BOARD, &v1_len);
    v2 = sign(2, 2, BOARD, &v2_len);
    snprintf(dir, sizeof dir, "/tmp/wdr-fwup-XXXXXX");
    if (!mkdtemp(dir))
        return -1;
    snprintf(v1_path, sizeof v1_path, "%s/v1.img", dir);
    FILE *f = fopen(v1_path, "wb");
    if (!f || fwrite(v1, 1, v1_len, f) != v1_len || fclose(f))
        return -1;
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    unlink(v1_path);
    rmdir(dir);
    free(v1);
    free(v2);
    return 0;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(update_test_boot_confirm),
        cmocka_unit_test(unconfirmed_reverts_after_three_reboots),
        cmocka_unit_test(bad_image_refused_v1_answers),
        cmocka_unit_test(blank_board_runs_unversioned),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
