/* State records and the floor: the record codec, the fold of a slot's log into its state
 * (SPEC.md, "Slot state"), torn units skipped and the next append after them, a full log, and
 * the floor's raise and compaction, with a power cut at every operation of a compaction. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "boot_test_util.h"
#include "wdr_err.h"
#include <string.h>

static bt_flash fl;
static bt_key dev;
static uint8_t img[8192];
static size_t img_len;
static wdr_boot_policy pol;

static void fresh(void)
{
    bt_flash_init(&fl, 1024, 16);
    bt_flash_image(&fl, 1, img, img_len);
}

static wdr_boot_slot slot_b(uint32_t floor)
{
    wdr_boot_slot s;
    assert_int_equal(wdr_boot_slot_read(&fl.f, &fl.l, 1, &pol, floor, &s), WDR_OK);
    return s;
}

static void append(uint8_t type, uint32_t value)
{
    assert_int_equal(wdr_boot_log_append(&fl.f, &fl.l, 1, type, value), WDR_OK);
}

static void layout_from_geometry(void **state)
{
    (void)state;
    wdr_boot_layout l;
    hal_flash_geometry g = {.block_size = 4096, .block_count = 512, .prog_size = 16};
    assert_int_equal(wdr_boot_layout_init(&l, &g), WDR_OK);
    assert_int_equal(l.floor_addr[1], 4096);
    assert_int_equal(l.slot_addr[0], 2 * 4096);
    assert_int_equal(l.state_addr[0], 256 * 4096);
    assert_int_equal(l.slot_addr[1], 257 * 4096);
    assert_int_equal(l.state_addr[1], 511 * 4096);
    assert_int_equal(l.image_capacity, 254 * 4096);
    g.block_count = 5;
    assert_int_equal(wdr_boot_layout_init(&l, &g), WDR_E_UNSUPPORTED);
    g = (hal_flash_geometry){.block_size = 4096, .block_count = 64, .prog_size = 32};
    assert_int_equal(wdr_boot_layout_init(&l, &g), WDR_E_UNSUPPORTED);
}

static void log_folds_into_states(void **state)
{
    (void)state;
    fresh();
    assert_int_equal(slot_b(0).state, WDR_SLOT_CONFIRMED); /* empty log, valid image: factory */
    append(WDR_REC_BEGIN, (uint32_t)img_len);
    assert_int_equal(slot_b(0).state, WDR_SLOT_INCOMPLETE);
    append(WDR_REC_PENDING, 1);
    assert_int_equal(slot_b(0).state, WDR_SLOT_PENDING);
    append(WDR_REC_ATTEMPT, 1);
    append(WDR_REC_ATTEMPT, 2);
    wdr_boot_slot s = slot_b(0);
    assert_int_equal(s.state, WDR_SLOT_TESTING);
    assert_int_equal(s.attempts, 2);
    assert_int_equal(s.log_next, 4 * WDR_BOOT_RECORD_SIZE);
    append(WDR_REC_CONFIRMED, 0);
    assert_int_equal(slot_b(0).state, WDR_SLOT_CONFIRMED);
    assert_int_equal(slot_b(2).state, WDR_SLOT_INVALID); /* counter 1 under floor 2 */
    assert_int_equal(slot_b(2).verify_err, WDR_E_DOWNGRADE);
    append(WDR_REC_REJECTED, WDR_REJECT_REVERTED);
    s = slot_b(0);
    assert_int_equal(s.state, WDR_SLOT_REJECTED);
    assert_int_equal(s.reject_reason, WDR_REJECT_REVERTED);
    assert_true(s.has_header); /* fw status still shows what it was */
    assert_int_equal(s.hdr.version.major, 2);
}

static void empty_and_invalid_slots(void **state)
{
    (void)state;
    bt_flash_init(&fl, 1024, 16);
    wdr_boot_slot s = slot_b(0);
    assert_int_equal(s.state, WDR_SLOT_EMPTY);
    assert_false(s.has_header);
    fresh();
    append(WDR_REC_BEGIN, (uint32_t)img_len);
    append(WDR_REC_PENDING, 1);
    fl.bytes[fl.l.slot_addr[1] + 100] ^= 1; /* the image changed after it was verified */
    s = slot_b(0);
    assert_int_equal(s.state, WDR_SLOT_INVALID);
    assert_int_equal(s.verify_err, WDR_E_HASH);
}

/* A cut during an append, with every tear: the unit is skipped, the state unchanged, and the
 * next append lands after it. */
static void torn_units_are_skipped(void **state)
{
    (void)state;
    for (int tear = NOR_TEAR_NONE; tear <= NOR_TEAR_BITS; tear++) {
        fresh();
        append(WDR_REC_BEGIN, (uint32_t)img_len);
        append(WDR_REC_PENDING, 1);
        nor_emul_cut_power_at(&fl.nor, fl.nor.ops + 1, tear);
        assert_int_equal(wdr_boot_log_append(&fl.f, &fl.l, 1, WDR_REC_ATTEMPT, 1), WDR_E_POWER);
        nor_emul_reboot(&fl.nor);
        wdr_boot_slot s = slot_b(0);
        assert_int_equal(s.state, WDR_SLOT_PENDING);
        assert_int_equal(s.log_next, (tear == NOR_TEAR_NONE ? 2 : 3) * WDR_BOOT_RECORD_SIZE);
        append(WDR_REC_ATTEMPT, 1);
        s = slot_b(0);
        assert_int_equal(s.state, WDR_SLOT_TESTING);
        assert_int_equal(s.attempts, 1);
    }
}

static void hostile_logs(void **state)
{
    (void)state;
    fresh();
    append(WDR_REC_ATTEMPT, 1);   /* before any PENDING: no test boot to count */
    append(WDR_REC_CONFIRMED, 0); /* nothing pending to confirm */
    append(7, 0);                 /* a type this version does not know */
    append(WDR_REC_FLOOR, 99);    /* floor records belong in the floor log */
    assert_int_equal(slot_b(0).state, WDR_SLOT_CONFIRMED); /* still the factory image */
    append(WDR_REC_REJECTED, WDR_REJECT_INVALID);
    append(WDR_REC_BEGIN, 1);
    append(WDR_REC_PENDING, 1);
    assert_int_equal(slot_b(0).state, WDR_SLOT_REJECTED); /* REJECTED is never forgotten */
}

static void full_log_is_refused(void **state)
{
    (void)state;
    fresh();
    append(WDR_REC_BEGIN, (uint32_t)img_len);
    append(WDR_REC_PENDING, 1);
    for (uint32_t i = 2; i < fl.l.block_size / WDR_BOOT_RECORD_SIZE; i++)
        append(WDR_REC_ATTEMPT, i);
    assert_int_equal(wdr_boot_log_append(&fl.f, &fl.l, 1, WDR_REC_CONFIRMED, 0), WDR_E_TOO_LARGE);
    assert_int_equal(slot_b(0).attempts, 62);
}

static uint32_t floor_now(void)
{
    uint32_t v;
    assert_int_equal(wdr_boot_floor_read(&fl.f, &fl.l, &v), WDR_OK);
    return v;
}

static void floor_raises_and_compacts(void **state)
{
    (void)state;
    bt_flash_init(&fl, 1024, 16);
    assert_int_equal(floor_now(), 0);
    assert_int_equal(wdr_boot_floor_raise(&fl.f, &fl.l, 3), WDR_OK);
    assert_int_equal(floor_now(), 3);
    uint64_t ops = fl.nor.ops;
    assert_int_equal(wdr_boot_floor_raise(&fl.f, &fl.l, 2), WDR_OK); /* never lowered */
    assert_int_equal(wdr_boot_floor_raise(&fl.f, &fl.l, 3), WDR_OK);
    assert_int_equal(fl.nor.ops, ops); /* and nothing written for it */
    assert_int_equal(floor_now(), 3);
    /* 64 records per block: 300 raises compact several times, the floor always the last. */
    for (uint32_t v = 4; v < 300; v++) {
        assert_int_equal(wdr_boot_floor_raise(&fl.f, &fl.l, v), WDR_OK);
        assert_int_equal(floor_now(), v);
    }
    /* after a compaction one block holds everything, the other is erased */
    int erased = 0;
    for (int b = 0; b < 2; b++) {
        int all = 1;
        for (uint32_t i = 0; i < fl.l.block_size; i++)
            all &= fl.bytes[fl.l.floor_addr[b] + i] == 0xFF;
        erased += all;
    }
    assert_int_equal(erased, 1);
}

/* A cut at every operation of a compaction, every tear: the floor is the old or the new one. */
static void floor_compaction_survives_cuts(void **state)
{
    (void)state;
    uint32_t per_block = fl.l.block_size / WDR_BOOT_RECORD_SIZE;
    for (int tear = NOR_TEAR_NONE; tear <= NOR_TEAR_BITS; tear++)
        for (uint64_t op = 1; op <= 3; op++) {
            bt_flash_init(&fl, 1024, 16);
            for (uint32_t v = 1; v <= per_block; v++) /* block 0 full */
                assert_int_equal(wdr_boot_floor_raise(&fl.f, &fl.l, v), WDR_OK);
            nor_emul_cut_power_at(&fl.nor, fl.nor.ops + op, tear);
            assert_int_equal(wdr_boot_floor_raise(&fl.f, &fl.l, per_block + 1), WDR_E_POWER);
            nor_emul_reboot(&fl.nor);
            uint32_t v = floor_now();
            assert_true(v == per_block || v == per_block + 1);
            if (op >= 3)
                assert_int_equal(v, per_block + 1); /* the new value is in before the erase */
            assert_int_equal(wdr_boot_floor_raise(&fl.f, &fl.l, per_block + 2), WDR_OK);
            assert_int_equal(floor_now(), per_block + 2);
        }
}

static void boot_record_and_names(void **state)
{
    (void)state;
    wdr_boot_record r;
    memset(&r, 0, sizeof r);
    r.slot = 1;
    r.reset_cause = WDR_RESET_WATCHDOG;
    wdr_boot_record_seal(&r);
    assert_true(wdr_boot_record_ok(&r));
    r.boots++;
    assert_false(wdr_boot_record_ok(&r));
    wdr_boot_record_seal(&r);
    r.magic ^= 1;
    assert_false(wdr_boot_record_ok(&r));
    assert_string_equal(wdr_slot_state_name(WDR_SLOT_TESTING), "testing");
    assert_string_equal(wdr_slot_state_name(99), "unknown");
    assert_string_equal(wdr_reset_cause_name(WDR_RESET_FAULT), "fault");
    assert_string_equal(wdr_reset_cause_name(-1), "unknown");
}

int main(void)
{
    bt_key_dev(&dev);
    pol = bt_policy(&dev);
    bt_image_spec s = bt_spec(2, 1, 2048);
    img_len = bt_image_build(img, sizeof img, &s, &dev, NULL);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(layout_from_geometry),
        cmocka_unit_test(log_folds_into_states),
        cmocka_unit_test(empty_and_invalid_slots),
        cmocka_unit_test(torn_units_are_skipped),
        cmocka_unit_test(hostile_logs),
        cmocka_unit_test(full_log_is_refused),
        cmocka_unit_test(floor_raises_and_compacts),
        cmocka_unit_test(floor_compaction_survives_cuts),
        cmocka_unit_test(boot_record_and_names),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
