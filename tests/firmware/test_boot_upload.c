/* Uploads, confirm and revert (SPEC.md, "Upload", "Confirm", "Revert"): chunks of any size
 * reach the flash byte for byte; out-of-order and oversize chunks are refused and the upload
 * stays open; every bad image ends the upload with its reason and nothing pending; the old
 * header goes before the old log; confirm raises the floor; revert needs a confirmed fallback. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "boot_test_util.h"
#include "crc32.h"
#include "wdr_err.h"
#include <string.h>

static bt_flash fl;
static bt_key dev, other;
static wdr_boot_policy pol;
static uint8_t v1[8192], v2[8192], img[8192];
static size_t v1_len, v2_len;

static void factory(void)
{
    bt_flash_init(&fl, 1024, 16);
    bt_flash_image(&fl, 0, v1, v1_len);
}

static wdr_boot_slot slot_state(int s)
{
    wdr_boot_slot out;
    uint32_t floor;
    assert_int_equal(wdr_boot_floor_read(&fl.f, &fl.l, &floor), WDR_OK);
    assert_int_equal(wdr_boot_slot_read(&fl.f, &fl.l, s, &pol, floor, &out), WDR_OK);
    return out;
}

static wdr_boot_decision decide(void)
{
    wdr_boot_decision d;
    assert_int_equal(wdr_boot_decide(&fl.f, &fl.l, &pol, &d), WDR_OK);
    return d;
}

static void chunks_of_any_size_reach_flash(void **state)
{
    (void)state;
    uint32_t sizes[] = {1, 7, 16, 100, 333, 1024, 4096};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        factory();
        wdr_boot_upload u;
        assert_int_equal(wdr_boot_upload_begin(&fl.f, &fl.l, &u, 1, (uint32_t)v2_len, wdr_crc32(0, v2, v2_len)), WDR_OK);
        for (size_t off = 0; off < v2_len; off += sizes[i]) {
            uint32_t n = (uint32_t)(v2_len - off < sizes[i] ? v2_len - off : sizes[i]);
            assert_int_equal(wdr_boot_upload_chunk(&fl.f, &fl.l, &u, (uint32_t)off, v2 + off, n), WDR_OK);
        }
        wdr_image_header h;
        assert_int_equal(wdr_boot_upload_finish(&fl.f, &fl.l, &u, &pol, &h), WDR_OK);
        assert_int_equal(h.version.major, 2);
        assert_memory_equal(fl.bytes + fl.l.slot_addr[1], v2, v2_len);
        assert_int_equal(slot_state(1).state, WDR_SLOT_PENDING);
        assert_int_equal(slot_state(0).state, WDR_SLOT_CONFIRMED);
        assert_int_equal(u.slot, -1);
    }
}

static void out_of_order_and_oversize_chunks(void **state)
{
    (void)state;
    factory();
    wdr_boot_upload u;
    wdr_boot_upload_abort(&u); /* what a firmware's boot does: no upload in progress */
    assert_int_equal(wdr_boot_upload_chunk(&fl.f, &fl.l, &u, 0, v2, 16), WDR_E_SEQUENCE); /* none begun */
    assert_int_equal(wdr_boot_upload_begin(&fl.f, &fl.l, &u, 1, (uint32_t)v2_len, wdr_crc32(0, v2, v2_len)), WDR_OK);
    assert_int_equal(wdr_boot_upload_chunk(&fl.f, &fl.l, &u, 0, v2, 500), WDR_OK);
    assert_int_equal(wdr_boot_upload_chunk(&fl.f, &fl.l, &u, 1000, v2 + 1000, 500), WDR_E_SEQUENCE);
    assert_int_equal(wdr_boot_upload_chunk(&fl.f, &fl.l, &u, 0, v2, 500), WDR_E_SEQUENCE); /* a repeat */
    assert_int_equal(wdr_boot_upload_chunk(&fl.f, &fl.l, &u, 500, v2 + 500, (uint32_t)v2_len), WDR_E_TOO_LARGE);
    assert_int_equal(u.received, 500); /* still open where it was */
    assert_int_equal(wdr_boot_upload_chunk(&fl.f, &fl.l, &u, 500, v2 + 500, (uint32_t)v2_len - 500), WDR_OK);
    assert_int_equal(wdr_boot_upload_finish(&fl.f, &fl.l, &u, &pol, NULL), WDR_OK);
    assert_int_equal(wdr_boot_upload_finish(&fl.f, &fl.l, &u, &pol, NULL), WDR_E_SEQUENCE); /* it ended */
}

static void begin_refuses_bad_lengths(void **state)
{
    (void)state;
    factory();
    wdr_boot_upload u;
    assert_int_equal(wdr_boot_upload_begin(&fl.f, &fl.l, &u, 1, 0, 0), WDR_E_INVAL);
    assert_int_equal(wdr_boot_upload_begin(&fl.f, &fl.l, &u, 2, 100, 0), WDR_E_INVAL);
    assert_int_equal(wdr_boot_upload_begin(&fl.f, &fl.l, &u, 1, fl.l.image_capacity + 1, 0), WDR_E_TOO_LARGE);
    assert_int_equal(wdr_boot_upload_begin(&fl.f, &fl.l, &u, 1, fl.l.image_capacity, 0), WDR_OK);
}

/* Upload img (len bytes, declared CRC crc) into B; the finish's result. */
static int upload_raw(const uint8_t *p, size_t len, uint32_t crc, size_t send)
{
    wdr_boot_upload u;
    int rc = wdr_boot_upload_begin(&fl.f, &fl.l, &u, 1, (uint32_t)len, crc);
    if (rc == WDR_OK && send)
        rc = wdr_boot_upload_chunk(&fl.f, &fl.l, &u, 0, p, (uint32_t)send);
    if (rc == WDR_OK)
        rc = wdr_boot_upload_finish(&fl.f, &fl.l, &u, &pol, NULL);
    return rc;
}

static void expect_refused(const uint8_t *p, size_t len, uint32_t crc, size_t send, int err)
{
    factory();
    assert_int_equal(upload_raw(p, len, crc, send), err);
    wdr_boot_slot b = slot_state(1);
    assert_int_equal(b.state, WDR_SLOT_INCOMPLETE); /* nothing pending */
    wdr_boot_decision d = decide();
    assert_int_equal(d.slot, 0);
}

static void bad_uploads_mark_nothing_pending(void **state)
{
    (void)state;
    expect_refused(v2, v2_len, wdr_crc32(0, v2, v2_len), v2_len - 16, WDR_E_TRUNCATED);
    expect_refused(v2, v2_len, wdr_crc32(0, v2, v2_len) ^ 1, v2_len, WDR_E_CORRUPT);
    expect_refused(v2, v2_len - 100, wdr_crc32(0, v2, v2_len - 100), v2_len - 100, WDR_E_INVAL); /* a cut file */
    bt_image_spec s = bt_spec(2, 1, 2048);
    size_t n = bt_image_build(img, sizeof img, &s, &other, NULL);
    expect_refused(img, n, wdr_crc32(0, img, n), n, WDR_E_KEY);
    n = bt_image_build(img, sizeof img, &s, &other, &dev);
    expect_refused(img, n, wdr_crc32(0, img, n), n, WDR_E_SIGNATURE);
    s.board = "mps2-an500";
    n = bt_image_build(img, sizeof img, &s, &dev, NULL);
    expect_refused(img, n, wdr_crc32(0, img, n), n, WDR_E_BOARD);
    memcpy(img, v2, v2_len);
    img[300] ^= 1;
    expect_refused(img, v2_len, wdr_crc32(0, img, v2_len), v2_len, WDR_E_HASH);
    s = bt_spec(2, 1, 2048);
    factory();
    assert_int_equal(wdr_boot_floor_raise(&fl.f, &fl.l, 2), WDR_OK);
    n = bt_image_build(img, sizeof img, &s, &dev, NULL);
    assert_int_equal(upload_raw(img, n, wdr_crc32(0, img, n), n), WDR_E_DOWNGRADE);
    assert_int_equal(slot_state(1).state, WDR_SLOT_INCOMPLETE);
}

/* The old header goes before the old log: a cut between leaves no factory-looking slot. */
static void begin_erases_the_header_first(void **state)
{
    (void)state;
    for (int tear = NOR_TEAR_NONE; tear <= NOR_TEAR_BITS; tear++)
        for (uint64_t op = 1; op <= 3; op++) {
            bt_flash_init(&fl, 1024, 16);
            bt_flash_image(&fl, 0, v1, v1_len);
            bt_flash_image(&fl, 1, v2, v2_len); /* B: v2, a factory image (empty log) */
            assert_int_equal(wdr_boot_log_append(&fl.f, &fl.l, 1, WDR_REC_REJECTED, WDR_REJECT_REVERTED), WDR_OK);
            wdr_boot_upload u;
            nor_emul_cut_power_at(&fl.nor, fl.nor.ops + op, tear);
            assert_int_equal(wdr_boot_upload_begin(&fl.f, &fl.l, &u, 1, (uint32_t)v2_len, 0), WDR_E_POWER);
            nor_emul_reboot(&fl.nor);
            assert_int_equal(decide().slot, 0); /* the rejected v2 never comes back */
        }
}

static void confirm_raises_the_floor(void **state)
{
    (void)state;
    bt_image_spec s = bt_spec(3, 4, 2048);
    size_t n = bt_image_build(img, sizeof img, &s, &dev, NULL);
    factory();
    assert_int_equal(wdr_boot_confirm(&fl.f, &fl.l, &pol, 1), WDR_E_STATE); /* empty */
    assert_int_equal(decide().slot, 0);
    assert_int_equal(bt_upload(&fl, 1, img, n, 512, &pol), WDR_OK);
    assert_int_equal(decide().slot, 1);
    assert_int_equal(wdr_boot_confirm(&fl.f, &fl.l, &pol, 1), WDR_OK);
    uint32_t floor;
    assert_int_equal(wdr_boot_floor_read(&fl.f, &fl.l, &floor), WDR_OK);
    assert_int_equal(floor, 4);
    assert_int_equal(slot_state(1).state, WDR_SLOT_CONFIRMED);
    assert_int_equal(wdr_boot_confirm(&fl.f, &fl.l, &pol, 1), WDR_OK); /* again: OK, nothing new */
    wdr_boot_decision d = decide();
    assert_int_equal(d.slot, 1);
    assert_false(d.testing);
    /* v1 (counter 1) is below the floor now: no revert to it */
    assert_int_equal(wdr_boot_revert(&fl.f, &fl.l, &pol, 1), WDR_E_STATE);
    assert_int_equal(wdr_boot_confirm(&fl.f, &fl.l, &pol, 0), WDR_E_STATE); /* rejected */
}

static void revert_needs_a_confirmed_fallback(void **state)
{
    (void)state;
    factory();
    assert_int_equal(decide().slot, 0);
    assert_int_equal(wdr_boot_revert(&fl.f, &fl.l, &pol, 0), WDR_E_STATE); /* B empty */
    wdr_boot_upload u;
    assert_int_equal(wdr_boot_upload_begin(&fl.f, &fl.l, &u, 1, (uint32_t)v2_len, 0), WDR_OK);
    assert_int_equal(wdr_boot_revert(&fl.f, &fl.l, &pol, 0), WDR_E_STATE); /* B incomplete */
    assert_int_equal(bt_upload(&fl, 1, v2, v2_len, 700, &pol), WDR_OK);
    assert_int_equal(wdr_boot_revert(&fl.f, &fl.l, &pol, 0), WDR_E_STATE); /* B pending */
    assert_int_equal(decide().slot, 1);
    assert_int_equal(wdr_boot_confirm(&fl.f, &fl.l, &pol, 1), WDR_OK);
    assert_int_equal(decide().slot, 1);
    assert_int_equal(wdr_boot_revert(&fl.f, &fl.l, &pol, 1), WDR_OK);
    wdr_boot_decision d = decide();
    assert_int_equal(d.slot, 0);
    assert_int_equal(d.slots[1].state, WDR_SLOT_REJECTED);
    assert_int_equal(d.slots[1].reject_reason, WDR_REJECT_REVERTED);
    /* a test boot can be reverted too */
    factory();
    assert_int_equal(bt_upload(&fl, 1, v2, v2_len, 700, &pol), WDR_OK);
    assert_int_equal(decide().slot, 1);
    assert_int_equal(wdr_boot_revert(&fl.f, &fl.l, &pol, 1), WDR_OK);
    assert_int_equal(decide().slot, 0);
}

int main(void)
{
    bt_key_dev(&dev);
    bt_key_generate(&other);
    pol = bt_policy(&dev);
    bt_image_spec s = bt_spec(1, 1, 2048);
    v1_len = bt_image_build(v1, sizeof v1, &s, &dev, NULL);
    s = bt_spec(2, 1, 4000 / 16 * 16);
    v2_len = bt_image_build(v2, sizeof v2, &s, &dev, NULL);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(chunks_of_any_size_reach_flash),
        cmocka_unit_test(out_of_order_and_oversize_chunks),
        cmocka_unit_test(begin_refuses_bad_lengths),
        cmocka_unit_test(bad_uploads_mark_nothing_pending),
        cmocka_unit_test(begin_erases_the_header_first),
        cmocka_unit_test(confirm_raises_the_floor),
        cmocka_unit_test(revert_needs_a_confirmed_fallback),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
