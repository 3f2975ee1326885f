/* The boot decision (SPEC.md, "Boot decision"): a factory image runs confirmed; a pending
 * image gets its test boots, each recorded before the answer, and is rejected after 3; an
 * image that fails verification is rejected; the newer confirmed version wins (A on a tie);
 * nothing bootable is -1; the floor follows the confirmed image that runs. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "boot_test_util.h"
#include "wdr_err.h"
#include <string.h>

static bt_flash fl;
static bt_key dev;
static wdr_boot_policy pol;
static uint8_t v1[8192], v2[8192];
static size_t v1_len, v2_len;

static wdr_boot_decision decide(void)
{
    wdr_boot_decision d;
    assert_int_equal(wdr_boot_decide(&fl.f, &fl.l, &pol, &d), WDR_OK);
    return d;
}

static void factory(void)
{
    bt_flash_init(&fl, 1024, 16);
    bt_flash_image(&fl, 0, v1, v1_len);
}

static uint32_t floor_now(void)
{
    uint32_t v;
    assert_int_equal(wdr_boot_floor_read(&fl.f, &fl.l, &v), WDR_OK);
    return v;
}

static void factory_image_runs_confirmed(void **state)
{
    (void)state;
    factory();
    wdr_boot_decision d = decide();
    assert_int_equal(d.slot, 0);
    assert_false(d.testing);
    assert_int_equal(d.slots[0].state, WDR_SLOT_CONFIRMED);
    assert_int_equal(d.slots[1].state, WDR_SLOT_EMPTY);
    assert_int_equal(floor_now(), 1); /* its counter is the first floor */
    uint64_t ops = fl.nor.ops;
    assert_int_equal(decide().slot, 0);
    assert_int_equal(fl.nor.ops, ops); /* a steady boot writes nothing */
}

static void pending_gets_three_test_boots_then_falls_back(void **state)
{
    (void)state;
    factory();
    assert_int_equal(bt_upload(&fl, 1, v2, v2_len, 512, &pol), WDR_OK);
    for (unsigned a = 1; a <= WDR_BOOT_MAX_ATTEMPTS; a++) {
        wdr_boot_decision d = decide();
        assert_int_equal(d.slot, 1);
        assert_true(d.testing);
        assert_int_equal(d.slots[1].attempts, a);
        assert_int_equal(d.slots[1].state, WDR_SLOT_TESTING);
    }
    wdr_boot_decision d = decide();
    assert_int_equal(d.slot, 0);
    assert_false(d.testing);
    assert_int_equal(d.slots[1].state, WDR_SLOT_REJECTED);
    assert_int_equal(d.slots[1].reject_reason, WDR_REJECT_UNCONFIRMED);
    assert_int_equal(decide().slot, 0);
    assert_int_equal(floor_now(), 1); /* the unconfirmed image never raised it */
}

static void confirmed_newer_version_wins(void **state)
{
    (void)state;
    factory();
    assert_int_equal(bt_upload(&fl, 1, v2, v2_len, 512, &pol), WDR_OK);
    assert_int_equal(decide().slot, 1);
    assert_int_equal(wdr_boot_confirm(&fl.f, &fl.l, &pol, 1), WDR_OK);
    wdr_boot_decision d = decide();
    assert_int_equal(d.slot, 1);
    assert_false(d.testing);
    assert_int_equal(d.slots[0].state, WDR_SLOT_CONFIRMED); /* same counter: v1 still valid */
    /* the older version in B, the newer in A: A */
    bt_flash_init(&fl, 1024, 16);
    bt_flash_image(&fl, 0, v2, v2_len);
    bt_flash_image(&fl, 1, v1, v1_len);
    assert_int_equal(decide().slot, 0);
    /* a tie: A */
    bt_flash_init(&fl, 1024, 16);
    bt_flash_image(&fl, 0, v1, v1_len);
    bt_flash_image(&fl, 1, v1, v1_len);
    assert_int_equal(decide().slot, 0);
    bt_flash_init(&fl, 1024, 16);
    bt_flash_image(&fl, 1, v1, v1_len);
    assert_int_equal(decide().slot, 1);
}

static void invalid_images_are_rejected(void **state)
{
    (void)state;
    factory();
    assert_int_equal(bt_upload(&fl, 1, v2, v2_len, 512, &pol), WDR_OK);
    fl.bytes[fl.l.slot_addr[1] + 200] ^= 4; /* bit rot after the upload verified */
    wdr_boot_decision d = decide();
    assert_int_equal(d.slot, 0);
    assert_int_equal(d.slots[1].state, WDR_SLOT_REJECTED);
    assert_int_equal(d.slots[1].reject_reason, WDR_REJECT_INVALID);
    wdr_boot_slot b;
    assert_int_equal(wdr_boot_slot_read(&fl.f, &fl.l, 1, &pol, 0, &b), WDR_OK);
    assert_int_equal(b.state, WDR_SLOT_REJECTED); /* on flash too */
    /* a factory image that fails: rejected, and nothing left to boot */
    factory();
    fl.bytes[fl.l.slot_addr[0] + 100] ^= 4;
    d = decide();
    assert_int_equal(d.slot, -1);
    assert_int_equal(d.slots[0].state, WDR_SLOT_REJECTED);
    assert_int_equal(d.slots[0].reject_reason, WDR_REJECT_INVALID);
}

static void nothing_bootable(void **state)
{
    (void)state;
    bt_flash_init(&fl, 1024, 16);
    assert_int_equal(decide().slot, -1);
    /* an incomplete upload never boots */
    wdr_boot_upload u;
    assert_int_equal(wdr_boot_upload_begin(&fl.f, &fl.l, &u, 1, (uint32_t)v2_len, 0), WDR_OK);
    assert_int_equal(wdr_boot_upload_chunk(&fl.f, &fl.l, &u, 0, v2, (uint32_t)v2_len), WDR_OK);
    wdr_boot_decision d = decide();
    assert_int_equal(d.slot, -1);
    assert_int_equal(d.slots[1].state, WDR_SLOT_INCOMPLETE);
    /* an image under the floor never boots */
    factory();
    assert_int_equal(wdr_boot_floor_raise(&fl.f, &fl.l, 2), WDR_OK);
    d = decide();
    assert_int_equal(d.slot, -1);
    assert_int_equal(d.slots[0].reject_reason, WDR_REJECT_INVALID);
}

/* A confirm cut between CONFIRMED and the floor raise: the next boot raises the floor. */
static void boot_completes_a_cut_confirm(void **state)
{
    (void)state;
    bt_image_spec s = bt_spec(3, 5, 2048);
    uint8_t v3[8192];
    size_t v3_len = bt_image_build(v3, sizeof v3, &s, &dev, NULL);
    factory();
    assert_int_equal(decide().slot, 0);
    assert_int_equal(bt_upload(&fl, 1, v3, v3_len, 512, &pol), WDR_OK);
    assert_int_equal(decide().slot, 1);
    nor_emul_cut_power_at(&fl.nor, fl.nor.ops + 2, NOR_TEAR_NONE); /* CONFIRMED lands, the floor does not */
    assert_int_equal(wdr_boot_confirm(&fl.f, &fl.l, &pol, 1), WDR_E_POWER);
    nor_emul_reboot(&fl.nor);
    assert_int_equal(floor_now(), 1);
    wdr_boot_decision d = decide();
    assert_int_equal(d.slot, 1);
    assert_false(d.testing);
    assert_int_equal(d.floor, 5);
    assert_int_equal(floor_now(), 5);
    d = decide(); /* v1 is now below the floor */
    assert_int_equal(d.slots[0].state, WDR_SLOT_REJECTED);
    assert_int_equal(d.slot, 1);
}

/* A state block that refuses every program: the board still boots, never the uncounted test. */
static void refused_records_still_boot(void **state)
{
    (void)state;
    factory();
    assert_int_equal(decide().slot, 0);
    assert_int_equal(bt_upload(&fl, 1, v2, v2_len, 512, &pol), WDR_OK);
    for (uint64_t op = 1; op <= 3; op++) { /* the ATTEMPT, then two more boots' */
        nor_emul_fail_at(&fl.nor, fl.nor.ops + 1);
        wdr_boot_decision d = decide();
        assert_int_equal(d.slot, 0);
        assert_false(d.testing);
    }
    wdr_boot_decision d = decide(); /* the flash works again: the test boot happens, counted */
    assert_int_equal(d.slot, 1);
    assert_int_equal(d.slots[1].attempts, 1);
    /* a floor raise that fails: the confirmed image boots, the next boot raises the floor */
    bt_image_spec s = bt_spec(3, 5, 2048);
    uint8_t v3[8192];
    size_t v3_len = bt_image_build(v3, sizeof v3, &s, &dev, NULL);
    factory();
    bt_flash_image(&fl, 1, v3, v3_len);
    nor_emul_fail_at(&fl.nor, fl.nor.ops + 1);
    d = decide();
    assert_int_equal(d.slot, 1);
    assert_int_equal(floor_now(), 0);
    assert_int_equal(decide().floor, 5);
    assert_int_equal(floor_now(), 5);
}

/* Both slots on test (only a hostile or odd flash has that), the newer one's log full: the
 * other is tested rather than nothing booting. */
static void full_log_passes_to_the_other_test(void **state)
{
    (void)state;
    bt_flash_init(&fl, 1024, 16);
    assert_int_equal(bt_upload(&fl, 0, v1, v1_len, 512, &pol), WDR_OK);
    assert_int_equal(bt_upload(&fl, 1, v2, v2_len, 512, &pol), WDR_OK);
    uint8_t junk[16];
    memset(junk, 0x33, sizeof junk);
    for (uint32_t at = 2 * 16; at < fl.l.block_size; at += 16)
        assert_int_equal(nor_emul_prog(&fl.nor, fl.l.state_addr[1] + at, junk, 16), WDR_OK);
    wdr_boot_decision d = decide();
    assert_int_equal(d.slot, 0);
    assert_true(d.testing);
}

int main(void)
{
    bt_key_dev(&dev);
    pol = bt_policy(&dev);
    bt_image_spec s = bt_spec(1, 1, 2048);
    v1_len = bt_image_build(v1, sizeof v1, &s, &dev, NULL);
    s = bt_spec(2, 1, 3000 / 16 * 16);
    v2_len = bt_image_build(v2, sizeof v2, &s, &dev, NULL);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(factory_image_runs_confirmed),
        cmocka_unit_test(pending_gets_three_test_boots_then_falls_back),
        cmocka_unit_test(confirmed_newer_version_wins),
        cmocka_unit_test(invalid_images_are_rejected),
        cmocka_unit_test(nothing_bootable),
        cmocka_unit_test(boot_completes_a_cut_confirm),
        cmocka_unit_test(refused_records_still_boot),
        cmocka_unit_test(full_log_passes_to_the_other_test),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
