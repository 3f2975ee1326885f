/* The firmware's update commands (protocol 1.4, fw_update.c) on the fake board: uploads into the
 * slot not running, every refusal with its status and nothing marked pending, the firmware
 * status, confirm, revert and reboot. The bootloader's part of each reset is fb_boot: the boot
 * library's decision over the fake image flash, as the real bootloader runs it. Images are
 * signed with OpenSSL (boot_test_util.c) by the development key and by a key made on the fly. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "boot_test_util.h"
#include "crc32.h"
#include "harness.h"
#include "wdr_boot.h"
#include "wdr_bytes.h"
#include <stdlib.h>
#include <string.h>

static wdr_fw fw;
static bt_key dev_key, other_key;

#define APP_BYTES 10000u /* three image blocks: erases between chunks are exercised */

typedef struct image {
    uint8_t *p;
    size_t n;
} image;

/* ---- Images ------------------------------------------------------------------------------------ */

static image sign_as(uint8_t major, uint8_t minor, uint32_t counter, const char *board, const bt_key *key)
{
    bt_image_spec s = bt_spec(major, counter, APP_BYTES);
    s.version = (wdr_image_version){major, minor, 0, 7};
    s.board = board;
    s.flags |= key == &dev_key ? WDR_IMAGE_F_DEV_KEY : 0;
    image im = {malloc(APP_BYTES + 256), 0};
    im.n = bt_image_build(im.p, APP_BYTES + 256, &s, key, NULL);
    return im;
}

static image sign_v(uint8_t major, uint32_t counter) { return sign_as(major, 0, counter, FB_BOARD_NAME, &dev_key); }

/* ---- The board's life ---------------------------------------------------------------------------- */

static wdr_boot_layout layout(void)
{
    const hal_flash_geometry g = {FB_IMG_BLOCK_SIZE, FB_IMG_BLOCK_COUNT, FB_IMG_PROG_SIZE};
    wdr_boot_layout l;
    assert_int_equal(wdr_boot_layout_init(&l, &g), WDR_OK);
    return l;
}

/* A blank board flashed with a factory image in slot A (no state records). */
static void flash_factory(const image *im)
{
    fb_init();
    memcpy(fb_image_flash() + layout().slot_addr[0], im->p, im->n);
}

/* A reset: the bootloader decides, then the firmware starts on what it was told. */
static int reset_board(uint8_t cause)
{
    fb_power_cycle();
    int slot = fb_boot(cause);
    th_boot(&fw);
    return slot;
}

static int upload(const image *im, uint32_t chunk, uint8_t *reply)
{
    uint8_t pl[WDR_PROTO_MAX_PAYLOAD];
    wdr_put_u32(pl, (uint32_t)im->n);
    wdr_put_u32(pl + 4, wdr_crc32(0, im->p, im->n));
    int st = th_request(&fw, WDR_CMD_FW_BEGIN, pl, WDR_BEGIN_SIZE, NULL, 0);
    for (uint32_t off = 0; !st && off < im->n; off += chunk) {
        uint32_t n = (uint32_t)im->n - off < chunk ? (uint32_t)im->n - off : chunk;
        wdr_put_u32(pl, off);
        memcpy(pl + 4, im->p + off, n);
        st = th_request(&fw, WDR_CMD_FW_CHUNK, pl, 4 + n, NULL, 0);
    }
    return st ? st : th_request(&fw, WDR_CMD_FW_COMMIT, NULL, 0, reply, WDR_FW_COMMIT_REPLY_SIZE);
}

static wdr_fw_status_report fw_status(void)
{
    uint8_t out[WDR_FW_STATUS_SIZE];
    wdr_fw_status_report r;
    memset(&r, 0, sizeof r);
    assert_int_equal(th_request(&fw, WDR_CMD_FW_STATUS, NULL, 0, out, sizeof out), WDR_ST_OK);
    assert_int_equal(wdr_fw_status_unpack(out, sizeof out, &r), WDR_OK);
    return r;
}

static wdr_info info(void)
{
    uint8_t ver[4], out[WDR_INFO_SIZE];
    wdr_info in;
    wdr_put_u16(ver, WDR_PROTO_VERSION_MAJOR);
    wdr_put_u16(ver + 2, WDR_PROTO_VERSION_MINOR);
    assert_int_equal(th_request(&fw, WDR_CMD_INFO, ver, sizeof ver, out, sizeof out), WDR_ST_OK);
    assert_int_equal(wdr_info_unpack(out, sizeof out, &in), WDR_OK);
    return in;
}

static int simple(uint8_t op) { return th_request(&fw, op, NULL, 0, NULL, 0); }

/* A REBOOT: answered first, then one software reset, then the next boot. */
static int reboot(void)
{
    int resets = fb_resets();
    assert_int_equal(simple(WDR_CMD_REBOOT), WDR_ST_OK);
    assert_int_equal(fb_resets(), resets + 1);
    assert_int_equal(fb_last_reset_cause(), WDR_RESET_SOFTWARE);
    assert_int_equal(fb_tx_bytes_at_reset(), fb_tx_bytes()); /* the answer had left */
    return reset_board(WDR_RESET_SOFTWARE);
}

/* v1 factory image running from slot A. */
static void board_with_v1(void)
{
    image v1 = sign_v(1, 1);
    flash_factory(&v1);
    free(v1.p);
    assert_int_equal(reset_board(WDR_RESET_POWER_ON), 0);
}

/* ---- Tests ------------------------------------------------------------------------------------------ */

static void unbooted_board_runs_unversioned(void **state)
{
    (void)state;
    fb_init();
    th_boot(&fw);
    wdr_info in = info();
    assert_int_equal(in.fw_major, WDR_FW_VERSION_MAJOR);
    assert_int_equal(in.fw_minor, WDR_FW_VERSION_MINOR);
    assert_int_equal(in.fw_build, 0);
    assert_int_equal(in.fw_slot, WDR_SLOT_NONE);
    wdr_fw_status_report r = fw_status();
    assert_true(r.flags & WDR_FW_STATUS_F_NO_BOOT);
    assert_true(r.flags & WDR_FW_STATUS_F_DEV_KEY);
    assert_int_equal(r.running, WDR_SLOT_NONE);
    assert_int_equal(r.slot[0].state, WDR_SLOT_EMPTY);
    assert_int_equal(r.slot[1].state, WDR_SLOT_EMPTY);
    assert_int_equal(r.max_attempts, WDR_BOOT_MAX_ATTEMPTS);
    assert_int_equal(simple(WDR_CMD_FW_CONFIRM), WDR_ST_BAD_STATE);
    assert_int_equal(simple(WDR_CMD_FW_REVERT), WDR_ST_BAD_STATE);
    assert_true(fb_watchdog_feeds() > 0); /* the task loop feeds it */
}

static void factory_image_boots_confirmed(void **state)
{
    (void)state;
    board_with_v1();
    wdr_info in = info();
    assert_int_equal(in.fw_major, 1);
    assert_int_equal(in.fw_build, 7);
    assert_int_equal(in.fw_slot, 0);
    assert_int_equal(in.fw_flags, 0);
    wdr_fw_status_report r = fw_status();
    assert_int_equal(r.running, 0);
    assert_int_equal(r.reset_cause, WDR_RESET_POWER_ON);
    assert_false(r.flags & (WDR_FW_STATUS_F_NO_BOOT | WDR_FW_STATUS_F_TESTING));
    assert_int_equal(r.slot[0].state, WDR_SLOT_CONFIRMED);
    assert_int_equal(r.slot[0].ver_major, 1);
    assert_int_equal(r.slot[0].image_size, APP_BYTES);
    assert_int_equal(simple(WDR_CMD_FW_CONFIRM), WDR_ST_OK); /* already confirmed: OK */
    assert_int_equal(simple(WDR_CMD_FW_REVERT), WDR_ST_BAD_STATE); /* nothing to go back to */
}

/* The whole update: upload v2 into B, reboot into a test boot, confirm, reboot: still v2. */
static void upload_test_boot_confirm(void **state)
{
    (void)state;
    board_with_v1();
    image v2 = sign_v(2, 3);
    uint8_t reply[WDR_FW_COMMIT_REPLY_SIZE];
    wdr_image_header h;
    assert_int_equal(upload(&v2, 4096, reply), WDR_ST_OK);
    assert_int_equal(reply[0], 1);
    assert_int_equal(wdr_image_header_parse(reply + 4, WDR_IMAGE_MAX_SIZE, &h), WDR_OK);
    assert_int_equal(h.version.major, 2);
    assert_int_equal(fw_status().slot[1].state, WDR_SLOT_PENDING);
    assert_int_equal(info().fw_major, 1); /* still running v1 */

    assert_int_equal(reboot(), 1);
    wdr_info in = info();
    assert_int_equal(in.fw_major, 2);
    assert_int_equal(in.fw_flags, 1);
    wdr_fw_status_report r = fw_status();
    assert_true(r.flags & WDR_FW_STATUS_F_TESTING);
    assert_int_equal(r.reset_cause, WDR_RESET_SOFTWARE);
    assert_int_equal(r.slot[1].state, WDR_SLOT_TESTING);
    assert_int_equal(r.slot[1].attempts, 1);
    assert_int_equal(upload(&v2, 4096, NULL), WDR_ST_BAD_STATE); /* confirm or revert first */

    assert_int_equal(simple(WDR_CMD_FW_CONFIRM), WDR_ST_OK);
    r = fw_status();
    assert_false(r.flags & WDR_FW_STATUS_F_TESTING);
    assert_int_equal(r.slot[1].state, WDR_SLOT_CONFIRMED);
    assert_int_equal(r.floor, 3);
    assert_int_equal(reboot(), 1);
    assert_int_equal(info().fw_major, 2);
    assert_int_equal(info().fw_flags, 0);
    free(v2.p);
}

static void unconfirmed_image_reverts_after_its_attempts(void **state)
{
    (void)state;
    board_with_v1();
    image v2 = sign_v(2, 1);
    assert_int_equal(upload(&v2, 1000, NULL), WDR_ST_OK);
    for (unsigned i = 1; i <= WDR_BOOT_MAX_ATTEMPTS; i++) {
        assert_int_equal(reboot(), 1);
        assert_int_equal(fw_status().slot[1].attempts, i);
        assert_int_equal(info().fw_flags, 1);
    }
    assert_int_equal(reboot(), 0);
    wdr_fw_status_report r = fw_status();
    assert_int_equal(r.slot[1].state, WDR_SLOT_REJECTED);
    assert_int_equal(r.slot[1].reject_reason, WDR_REJECT_UNCONFIRMED);
    assert_int_equal(info().fw_major, 1);
    free(v2.p);
}

static void revert_goes_back_to_the_confirmed_image(void **state)
{
    (void)state;
    board_with_v1();
    image v2 = sign_v(2, 1);
    assert_int_equal(upload(&v2, 4096, NULL), WDR_ST_OK);
    assert_int_equal(reboot(), 1);
    assert_int_equal(simple(WDR_CMD_FW_CONFIRM), WDR_ST_OK);
    assert_int_equal(simple(WDR_CMD_FW_REVERT), WDR_ST_OK); /* a confirmed image may be left too */
    /* until the reboot, slot A is the only way back: an upload there would erase it */
    assert_int_equal(upload(&v2, 4096, NULL), WDR_ST_BAD_STATE);
    assert_int_equal(fw_status().slot[0].state, WDR_SLOT_CONFIRMED);
    assert_int_equal(reboot(), 0);
    wdr_fw_status_report r = fw_status();
    assert_int_equal(r.slot[1].state, WDR_SLOT_REJECTED);
    assert_int_equal(r.slot[1].reject_reason, WDR_REJECT_REVERTED);
    assert_int_equal(simple(WDR_CMD_FW_REVERT), WDR_ST_BAD_STATE); /* B is no way back */
    free(v2.p);
}

/* Every image refusal: its status, slot B left incomplete (never booted), v1 still what boots. */
static void refuse(const image *im, int status)
{
    assert_int_equal(upload(im, 4096, NULL), status);
    assert_int_equal(fw_status().slot[1].state, WDR_SLOT_INCOMPLETE);
    assert_int_equal(reboot(), 0);
    assert_int_equal(info().fw_major, 1);
}

static void each_bad_image_is_refused_with_its_reason(void **state)
{
    (void)state;
    board_with_v1();
    image im = sign_as(2, 0, 1, FB_BOARD_NAME, &other_key);
    refuse(&im, WDR_ST_BAD_KEY);
    free(im.p);
    im = sign_as(2, 0, 1, "other-board", &dev_key);
    refuse(&im, WDR_ST_BAD_BOARD);
    free(im.p);
    im = sign_v(2, 1);
    im.p[WDR_IMAGE_HEADER_SIZE + 100] ^= 1; /* one application byte */
    refuse(&im, WDR_ST_BAD_HASH);
    im.p[WDR_IMAGE_HEADER_SIZE + 100] ^= 1;
    im.p[im.n - 1] ^= 0x80; /* the signature's last byte */
    refuse(&im, WDR_ST_BAD_SIGNATURE);
    im.p[im.n - 1] ^= 0x80;
    im.p[im.n - WDR_IMAGE_TRAILER_SIZE] ^= 1; /* the trailer's magic */
    refuse(&im, WDR_ST_BAD_IMAGE);
    im.p[im.n - WDR_IMAGE_TRAILER_SIZE] ^= 1;
    im.p[6] = 2; /* format major */
    refuse(&im, WDR_ST_BAD_VERSION);
    im.p[6] = WDR_IMAGE_VERSION_MAJOR;
    im.p[48] = 1; /* a reserved byte */
    refuse(&im, WDR_ST_BAD_IMAGE);
    im.p[48] = 0;
    image cut = {im.p, im.n - 16}; /* the trailer cut short, declared as such */
    refuse(&cut, WDR_ST_BAD_IMAGE);
    assert_int_equal(upload(&im, 4096, NULL), WDR_ST_OK); /* the bytes restored: accepted */
    free(im.p);
}

static void downgrade_below_the_floor_is_refused(void **state)
{
    (void)state;
    board_with_v1();
    image v2 = sign_v(2, 5), v3 = sign_v(3, 4);
    assert_int_equal(upload(&v2, 4096, NULL), WDR_ST_OK);
    assert_int_equal(reboot(), 1);
    assert_int_equal(simple(WDR_CMD_FW_CONFIRM), WDR_ST_OK);
    assert_int_equal(fw_status().floor, 5);
    assert_int_equal(upload(&v3, 4096, NULL), WDR_ST_DOWNGRADE); /* newer version, older counter */
    assert_int_equal(fw_status().slot[0].state, WDR_SLOT_INCOMPLETE);
    assert_int_equal(reboot(), 1);
    assert_int_equal(info().fw_major, 2);
    free(v2.p);
    free(v3.p);
}

static int begin(uint32_t len, uint32_t crc)
{
    uint8_t pl[8];
    wdr_put_u32(pl, len);
    wdr_put_u32(pl + 4, crc);
    return th_request(&fw, WDR_CMD_FW_BEGIN, pl, sizeof pl, NULL, 0);
}

static int chunk(const image *im, uint32_t off, uint32_t n)
{
    static uint8_t pl[WDR_PROTO_MAX_PAYLOAD];
    wdr_put_u32(pl, off);
    memcpy(pl + 4, im->p + off, n);
    return th_request(&fw, WDR_CMD_FW_CHUNK, pl, 4 + n, NULL, 0);
}

static void upload_protocol_refusals(void **state)
{
    (void)state;
    board_with_v1();
    image v2 = sign_v(2, 1);
    uint32_t crc = wdr_crc32(0, v2.p, v2.n);
    assert_int_equal(chunk(&v2, 0, 100), WDR_ST_BAD_SEQUENCE); /* no upload begun */
    assert_int_equal(simple(WDR_CMD_FW_COMMIT), WDR_ST_BAD_SEQUENCE);
    assert_int_equal(begin(layout().image_capacity + 1, crc), WDR_ST_TOO_LARGE);
    assert_int_equal(begin(0, crc), WDR_ST_BAD_LENGTH);
    assert_int_equal(th_request(&fw, WDR_CMD_FW_BEGIN, "abc", 3, NULL, 0), WDR_ST_BAD_LENGTH);
    assert_int_equal(th_request(&fw, WDR_CMD_FW_COMMIT, "x", 1, NULL, 0), WDR_ST_BAD_LENGTH);

    assert_int_equal(begin((uint32_t)v2.n, crc), WDR_ST_OK);
    assert_int_equal(chunk(&v2, 0, 4096), WDR_ST_OK);
    assert_int_equal(chunk(&v2, 100, 100), WDR_ST_BAD_SEQUENCE); /* the upload stays at 4096 */
    assert_int_equal(th_status(&fw).upload_kind, WDR_KIND_FW);
    assert_int_equal(th_status(&fw).upload_received, 4096);
    uint8_t lut_chunk[8] = {0};
    assert_int_equal(th_request(&fw, WDR_CMD_LUT_CHUNK, lut_chunk, sizeof lut_chunk, NULL, 0), WDR_ST_BAD_KIND);
    assert_int_equal(chunk(&v2, 4096, 4096), WDR_ST_OK);
    assert_int_equal(simple(WDR_CMD_FW_COMMIT), WDR_ST_TRUNCATED);
    assert_int_equal(fw_status().slot[1].state, WDR_SLOT_INCOMPLETE);
    assert_int_equal(simple(WDR_CMD_FW_COMMIT), WDR_ST_BAD_SEQUENCE); /* the failure ended it */

    assert_int_equal(begin((uint32_t)v2.n, crc ^ 1), WDR_ST_OK);
    for (uint32_t off = 0; off < v2.n; off += 4096)
        assert_int_equal(chunk(&v2, off, v2.n - off < 4096 ? (uint32_t)(v2.n - off) : 4096), WDR_ST_OK);
    assert_int_equal(chunk(&v2, (uint32_t)v2.n, 1), WDR_ST_TOO_LARGE);
    assert_int_equal(simple(WDR_CMD_FW_COMMIT), WDR_ST_BAD_CRC);
    assert_int_equal(fw_status().slot[1].state, WDR_SLOT_INCOMPLETE);

    assert_int_equal(begin((uint32_t)v2.n, crc), WDR_ST_OK);
    assert_int_equal(simple(WDR_CMD_ABORT), WDR_ST_OK); /* drops it */
    assert_int_equal(chunk(&v2, 0, 100), WDR_ST_BAD_SEQUENCE);
    assert_int_equal(upload(&v2, 4096, NULL), WDR_ST_OK);
    free(v2.p);
}

/* BEGIN and COMMIT wait for the sensor to stop; chunks flow while it streams. */
static void stream_and_upload(void **state)
{
    (void)state;
    static uint8_t lut[WDR_FW_LUT_MAX_BYTES];
    board_with_v1();
    image v2 = sign_v(2, 1);
    uint32_t crc = wdr_crc32(0, v2.p, v2.n);
    size_t lut_len = th_make_lut(lut, 64, 100, FB_DAC_BITS);
    uint8_t on = 1, off = 0;
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, lut, (uint32_t)lut_len, 4096, NULL), WDR_ST_OK);
    assert_int_equal(th_request(&fw, WDR_CMD_STREAM, &on, 1, NULL, 0), WDR_ST_OK);
    assert_int_equal(begin((uint32_t)v2.n, crc), WDR_ST_BUSY);
    assert_int_equal(th_request(&fw, WDR_CMD_STREAM, &off, 1, NULL, 0), WDR_ST_OK);
    assert_int_equal(begin((uint32_t)v2.n, crc), WDR_ST_OK);
    assert_int_equal(th_request(&fw, WDR_CMD_STREAM, &on, 1, NULL, 0), WDR_ST_OK);
    for (uint32_t o = 0; o < v2.n; o += 4096) {
        assert_int_equal(chunk(&v2, o, v2.n - o < 4096 ? (uint32_t)(v2.n - o) : 4096), WDR_ST_OK);
        assert_int_not_equal(th_status(&fw).state, WDR_FW_IDLE); /* the stream goes on */
    }
    assert_int_equal(simple(WDR_CMD_FW_COMMIT), WDR_ST_BUSY);
    assert_int_equal(th_request(&fw, WDR_CMD_STREAM, &off, 1, NULL, 0), WDR_ST_OK);
    assert_int_equal(simple(WDR_CMD_FW_COMMIT), WDR_ST_OK);
    free(v2.p);
}

/* A factory image nobody trusts: the boot rejects it, nothing is bootable, and the firmware
 * still runs (unversioned) and answers, so a good image can be uploaded. */
static void nothing_bootable_keeps_answering(void **state)
{
    (void)state;
    image bad = sign_as(1, 0, 1, FB_BOARD_NAME, &other_key), v2 = sign_v(2, 1);
    flash_factory(&bad);
    assert_int_equal(reset_board(WDR_RESET_POWER_ON), -1);
    assert_int_equal(info().fw_slot, WDR_SLOT_NONE);
    wdr_fw_status_report r = fw_status();
    assert_true(r.flags & WDR_FW_STATUS_F_NO_BOOT);
    assert_int_equal(r.slot[0].state, WDR_SLOT_REJECTED);
    assert_int_equal(r.slot[0].reject_reason, WDR_REJECT_INVALID);
    assert_int_equal(upload(&v2, 4096, NULL), WDR_ST_OK); /* into A: B holds no confirmed image either */
    assert_int_equal(reboot(), 0);
    assert_int_equal(info().fw_major, 2);
    assert_int_equal(info().fw_flags, 1);
    free(bad.p);
    free(v2.p);
}

static void board_without_image_flash(void **state)
{
    (void)state;
    fb_init();
    fb_set_image_flash(0);
    th_boot(&fw);
    assert_int_equal(begin(1000, 0), WDR_ST_UNSUPPORTED);
    assert_int_equal(simple(WDR_CMD_FW_STATUS), WDR_ST_UNSUPPORTED);
    assert_int_equal(simple(WDR_CMD_FW_CONFIRM), WDR_ST_UNSUPPORTED);
    assert_int_equal(info().fw_slot, WDR_SLOT_NONE);
    assert_int_equal(simple(WDR_CMD_REBOOT), WDR_ST_OK); /* a reset is always possible */
    assert_int_equal(fb_last_reset_cause(), WDR_RESET_SOFTWARE);
    fb_set_image_flash(1);
}

static int setup(void **state)
{
    (void)state;
    bt_key_dev(&dev_key);
    bt_key_generate(&other_key);
    return 0;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(unbooted_board_runs_unversioned),
        cmocka_unit_test(factory_image_boots_confirmed),
        cmocka_unit_test(upload_test_boot_confirm),
        cmocka_unit_test(unconfirmed_image_reverts_after_its_attempts),
        cmocka_unit_test(revert_goes_back_to_the_confirmed_image),
        cmocka_unit_test(each_bad_image_is_refused_with_its_reason),
        cmocka_unit_test(downgrade_below_the_floor_is_refused),
        cmocka_unit_test(upload_protocol_refusals),
        cmocka_unit_test(stream_and_upload),
        cmocka_unit_test(nothing_bootable_keeps_answering),
        cmocka_unit_test(board_without_image_flash),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
