/* Power-loss safety on the simulated board of hal/sim (its own strict flash, 128-byte program
 * unit, and its power-cut injection: the cut operation leaves its first half done). Requests
 * go straight into the firmware's packet handler (this board has no USB link here), so the
 * outcome is read from the firmware's state: the old or the new table is active after every
 * cut and reboot, the active slot's bytes are untouched, and a new upload then succeeds. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "board.h"
#include "crc32.h"
#include "hal_sim_emul.h"
#include "table_builders.h"
#include "wdr_fw.h"
#include <stdio.h>
#include <string.h>

#define W 64
#define H 48
#define SENSOR 4242u

static wdr_fw fw;
static wdr_board board;
static uint8_t lut_t[3][WDR_FW_LUT_MAX_BYTES], cal_t[3][64 + H * (W * 12 + W)];
static size_t lut_len, cal_len;
static uint8_t before[1u << 20];
static long fault_points;

static void request(uint8_t op, const uint8_t *payload, uint32_t len)
{
    static uint16_t seq;
    wdr_packet pkt = {{op, 0, ++seq, 0, len, 0}, payload}; /* a repeated seq would be a retry */
    wdr_fw_handle(&fw, &pkt);
    while (wdr_fw_task(&fw)) {
    }
}

static void upload(int kind, const uint8_t *t, size_t len)
{
    static uint8_t pl[WDR_PROTO_MAX_PAYLOAD];
    uint8_t base = kind == WDR_KIND_LUT ? WDR_CMD_LUT_BEGIN : WDR_CMD_CAL_BEGIN;
    wdr_put_u32(pl, (uint32_t)len);
    wdr_put_u32(pl + 4, wdr_crc32(0, t, len));
    request(base, pl, 8);
    for (uint32_t off = 0; off < len; off += 3000) {
        uint32_t n = len - off < 3000 ? (uint32_t)len - off : 3000;
        wdr_put_u32(pl, off);
        memcpy(pl + 4, t + off, n);
        request(base + 1, pl, 4 + n);
    }
    request(base + 2, NULL, 0);
}

static uint32_t active_crc(int kind)
{
    wdr_status_report r;
    wdr_fw_status(&fw, &r);
    if (kind == WDR_KIND_LUT)
        return r.lut_slot == WDR_SLOT_NONE ? 0 : r.lut_crc;
    return r.cal_slot == WDR_SLOT_NONE ? 0 : r.cal_crc;
}

static void reboot(void)
{
    hal_sim_reboot();
    assert_int_equal(wdr_fw_init(&fw), WDR_OK);
}

typedef struct scenario {
    const char *name;
    int kind;
    const uint8_t *older, *old, *fresh;
    size_t len;
} scenario;

/* Factory-new flash, then older and old tables of the kind: old active, older in the other slot. */
static void fresh_board(const scenario *sc)
{
    hal_sim_flash_reset();
    reboot();
    if (sc->kind == WDR_KIND_CAL)
        upload(WDR_KIND_LUT, lut_t[0], lut_len);
    upload(sc->kind, sc->older, sc->len);
    upload(sc->kind, sc->old, sc->len);
    assert_int_equal(active_crc(sc->kind), wdr_crc32(0, sc->old, sc->len));
}

static const wdr_slot *active_slot(int kind)
{
    int s = kind == WDR_KIND_LUT ? fw.lut_slot : fw.cal_slot;
    assert_true(s >= 0);
    return &fw.store.slot[kind - 1][s];
}

static void cut_at(const scenario *sc, uint64_t k, uint64_t total)
{
    size_t size;
    fresh_board(sc);
    wdr_slot old = *active_slot(sc->kind);
    uint32_t span = WDR_SLOT_DATA_OFFSET + old.length;
    assert_true(span <= sizeof before);
    memcpy(before, hal_sim_flash_bytes(&size) + old.addr, span);
    hal_sim_cut_power_at(k);
    upload(sc->kind, sc->fresh, sc->len);
    assert_true(hal_sim_power_lost());
    reboot();
    assert_memory_equal(hal_sim_flash_bytes(&size) + old.addr, before, span);
    uint32_t crc = active_crc(sc->kind), crc_new = wdr_crc32(0, sc->fresh, sc->len);
    assert_true(crc == crc_new || crc == wdr_crc32(0, sc->old, sc->len));
    if (k < total)
        assert_int_equal(crc != crc_new, 1); /* the commit marker is the last operation */
    upload(sc->kind, sc->fresh, sc->len);
    reboot();
    assert_int_equal(active_crc(sc->kind), crc_new);
    fault_points++;
}

static void run(const scenario *sc)
{
    fresh_board(sc);
    uint64_t ops0 = hal_sim_flash_ops();
    upload(sc->kind, sc->fresh, sc->len);
    assert_int_equal(active_crc(sc->kind), wdr_crc32(0, sc->fresh, sc->len));
    uint64_t total = hal_sim_flash_ops() - ops0;
    long before_points = fault_points;
    for (uint64_t k = 1; k <= total; k++)
        cut_at(sc, k, total);
    printf("powerloss (hal/sim) %s upload: %llu flash operations, %ld fault points tested\n", sc->name,
           (unsigned long long)total, fault_points - before_points);
}

static void lut_on_sim_board(void **state)
{
    (void)state;
    scenario sc = {"LUT", WDR_KIND_LUT, lut_t[0], lut_t[1], lut_t[2], lut_len};
    run(&sc);
}

static void cal_on_sim_board(void **state)
{
    (void)state;
    scenario sc = {"calibration", WDR_KIND_CAL, cal_t[0], cal_t[1], cal_t[2], cal_len};
    run(&sc);
}

static int setup(void **state)
{
    (void)state;
    char err[256];
    wdr_board_defaults(&board);
    board.width = W;
    board.height = H;
    board.sensor_id = SENSOR;
    hal_sim_config cfg = {&board, 1, 1, NULL, NULL, 4096, 128, 128, NULL, NULL};
    if (hal_sim_setup(&cfg, err, sizeof err)) {
        fprintf(stderr, "hal_sim_setup: %s\n", err);
        return -1;
    }
    if (hal_init())
        return -1;
    for (int i = 0; i < 3; i++) {
        lut_len = th_make_lut(lut_t[i], 4000, (uint16_t)i, (uint8_t)board.dac_bits);
        cal_len = th_make_cal(cal_t[i], 0.5f + 0.25f * i, 1.0f, SENSOR, W, H);
    }
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    hal_sim_teardown();
    printf("powerloss (hal/sim): %ld fault points tested in all\n", fault_points);
    return 0;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(lut_on_sim_board),
        cmocka_unit_test(cal_on_sim_board),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
