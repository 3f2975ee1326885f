/* Power-loss safety of table uploads. For a LUT upload and for a calibration upload, cut
 * power at every flash erase and program of the upload in turn (cleanly, and torn: the cut
 * operation does half its work), reboot, and check that the old or the new table is valid and
 * active, never a mix, that the active slot's bytes were never touched, and that the board
 * takes a new upload afterwards. Prints the number of fault points tested. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "crc32.h"
#include "harness.h"
#include <stdio.h>
#include <string.h>

#define CAL_BYTES (64 + FB_HEIGHT * (FB_WIDTH * 12 + FB_WIDTH))

static wdr_fw fw;
static uint8_t snapshot[FB_BLOCK_SIZE * FB_BLOCK_COUNT];
static uint8_t lut_old[WDR_FW_LUT_MAX_BYTES], lut_new[WDR_FW_LUT_MAX_BYTES], lut_older[WDR_FW_LUT_MAX_BYTES];
static uint8_t cal_old[CAL_BYTES], cal_new[CAL_BYTES], cal_older[CAL_BYTES];
static size_t lut_len, cal_len;
static long fault_points;

typedef struct scenario {
    const char *name;
    int kind;
    const uint8_t *older, *old, *fresh; /* fresh: the upload that power cuts interrupt */
    size_t len;
    uint32_t chunk;
    float old_gain, new_gain;           /* calibration: output = gain * raw + 3 */
} scenario;

static void reboot(void)
{
    fb_power_cycle();
    th_boot(&fw);
}

static void upload_ok(int kind, const uint8_t *t, size_t len, uint32_t chunk)
{
    assert_int_equal(th_upload(&fw, kind, t, (uint32_t)len, chunk, NULL), WDR_ST_OK);
}

/* Flash with two tables of the kind (older in one slot, old active in the other). */
static void prepare(const scenario *sc)
{
    fb_init();
    th_boot(&fw);
    if (sc->kind == WDR_KIND_CAL)
        upload_ok(WDR_KIND_LUT, lut_old, lut_len, 4096);
    upload_ok(sc->kind, sc->older, sc->len, sc->chunk);
    upload_ok(sc->kind, sc->old, sc->len, sc->chunk);
    memcpy(snapshot, fb_flash(), sizeof snapshot);
}

static void restore_and_boot(void)
{
    memcpy(fb_flash(), snapshot, sizeof snapshot);
    reboot();
}

/* Flash operations a complete upload of sc->fresh takes. */
static long count_ops(const scenario *sc)
{
    restore_and_boot();
    long before = fb_flash_ops();
    upload_ok(sc->kind, sc->fresh, sc->len, sc->chunk);
    return fb_flash_ops() - before;
}

static int active_slot(int kind)
{
    wdr_status_report s = th_status(&fw);
    return kind == WDR_KIND_LUT ? s.lut_slot : s.cal_slot;
}

/* Which table is active: 0 old, 1 new; fails on anything else, or on a mixed frame. */
static int active_table(const scenario *sc)
{
    wdr_status_report s = th_status(&fw);
    uint32_t crc = sc->kind == WDR_KIND_LUT ? s.lut_crc : s.cal_crc;
    int which = crc == wdr_crc32(0, sc->fresh, sc->len) ? 1 : 0;
    assert_true(which || crc == wdr_crc32(0, sc->old, sc->len));
    if (sc->kind == WDR_KIND_LUT) {
        assert_memory_equal(fw.lut_ram[fw.lut_buf], which ? sc->fresh : sc->old, sc->len);
        return which;
    }
    /* Every pixel of a captured frame comes from the same table. */
    float gain = which ? sc->new_gain : sc->old_gain;
    assert_int_equal(th_capture_frames(&fw, 1), WDR_ST_OK);
    assert_int_equal(th_cap.rows, FB_HEIGHT);
    for (int r = 0; r < FB_HEIGHT; r++)
        for (int c = 0; c < FB_WIDTH; c++) {
            float v = gain * fb_pattern(r, c) + 3.0f;
            assert_int_equal(th_cap.px[r][c], (uint16_t)((v < 4095.0f ? v : 4095.0f) + 0.5f));
        }
    return which;
}

static void assert_slot_untouched(const wdr_slot *s, uint32_t bytes)
{
    assert_memory_equal(fb_flash() + s->addr, snapshot + s->addr, bytes);
}

/* One fault point: cut at op, reboot, check, then prove the board still takes uploads. */
static void cut_at(const scenario *sc, long op, long total, int torn)
{
    restore_and_boot();
    int old_slot = active_slot(sc->kind);
    wdr_slot old = fw.store.slot[sc->kind - 1][old_slot];
    fb_cut_power_at(op, torn);
    assert_int_not_equal(th_upload(&fw, sc->kind, sc->fresh, (uint32_t)sc->len, sc->chunk, NULL), WDR_ST_OK);
    assert_true(fb_power_lost());
    reboot();
    assert_slot_untouched(&old, WDR_SLOT_DATA_OFFSET + old.length);
    int which = active_table(sc);
    if (op < total - 1)
        assert_int_equal(which, 0); /* the commit marker is the last operation */
    upload_ok(sc->kind, sc->fresh, sc->len, sc->chunk);
    reboot();
    assert_int_equal(active_table(sc), 1);
    fault_points++;
}

static void run_scenario(const scenario *sc)
{
    prepare(sc);
    long total = count_ops(sc), before = fault_points;
    for (int torn = 0; torn < 2; torn++)
        for (long op = 0; op < total; op++)
            cut_at(sc, op, total, torn);
    printf("powerloss %s upload: %ld flash operations, %ld fault points tested (clean and torn cuts)\n",
           sc->name, total, fault_points - before);
}

static void lut_upload_survives_every_cut(void **state)
{
    (void)state;
    scenario sc = {"LUT", WDR_KIND_LUT, lut_older, lut_old, lut_new, lut_len, 1000, 0, 0};
    run_scenario(&sc);
}

static void cal_upload_survives_every_cut(void **state)
{
    (void)state;
    scenario sc = {"calibration", WDR_KIND_CAL, cal_older, cal_old, cal_new, cal_len, 4096, 0.5f, 0.75f};
    run_scenario(&sc);
}

static int setup(void **state)
{
    (void)state;
    lut_len = th_make_lut(lut_older, 4096, 1, FB_DAC_BITS);
    th_make_lut(lut_old, 4096, 2, FB_DAC_BITS);
    th_make_lut(lut_new, 4096, 3, FB_DAC_BITS);
    cal_len = th_make_cal(cal_older, 0.25f, 3.0f, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT);
    th_make_cal(cal_old, 0.5f, 3.0f, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT);
    th_make_cal(cal_new, 0.75f, 3.0f, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    printf("powerloss: %ld fault points tested in all\n", fault_points);
    return 0;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(lut_upload_survives_every_cut),
        cmocka_unit_test(cal_upload_survives_every_cut),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
