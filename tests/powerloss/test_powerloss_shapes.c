/* Power-loss cases the plain cut-at-every-operation tests leave out, on the simulated board
 * (hal/sim: 128-byte program units, so a slot's 64-byte header sits in one unit and a cut that
 * leaves the first half done never tears it). At every erase and program of an upload:
 *   - a cut that leaves nothing done, the second half done, or every byte's bits partly
 *     programmed or erased;
 *   - an I/O error (the firmware keeps running: checked before and after a reboot);
 *   - a cut in the second of two uploads in a row;
 *   - a cut, a reboot, and a cut again at every operation of the retry.
 * After every reboot both slots of the kind are checked: each valid slot holds exactly one of
 * the tables ever uploaded, the active one is the newest valid one and holds the old or the new
 * table, and the slot that was active before the upload is byte for byte untouched. Prints the
 * number of fault points. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "board.h"
#include "crc32.h"
#include "hal_sim_emul.h"
#include "nor_emul.h"
#include "table_builders.h"
#include "wdr_fw.h"
#include <stdio.h>
#include <string.h>

#define W 64
#define H 48
#define SENSOR 4242u
#define TABLES 4 /* older, old, x (the first of two uploads), fresh */

static wdr_fw fw;
static wdr_board board;
static uint8_t lut_t[TABLES][WDR_FW_LUT_MAX_BYTES], cal_t[TABLES][64 + H * (W * 12 + W)];
static size_t lut_len, cal_len;
static uint8_t before[1u << 20];
static long fault_points;

typedef struct scenario {
    const char *name;
    int kind;
    const uint8_t *t[TABLES];
    size_t len;
} scenario;

enum { OLDER, OLD, X, FRESH };

static int request(uint8_t op, const uint8_t *payload, uint32_t len)
{
    static uint16_t seq;
    wdr_packet pkt = {{op, 0, ++seq, 0, len, 0}, payload};
    wdr_fw_handle(&fw, &pkt);
    while (wdr_fw_task(&fw)) {
    }
    return fw.last_response_len >= WDR_PROTO_HEADER_SIZE ? fw.last_response[6] : -1; /* the status byte (SPEC.md) */
}

/* The whole upload; 0 if it was committed. */
static int upload(int kind, const uint8_t *t, size_t len)
{
    static uint8_t pl[WDR_PROTO_MAX_PAYLOAD];
    uint8_t base = kind == WDR_KIND_LUT ? WDR_CMD_LUT_BEGIN : WDR_CMD_CAL_BEGIN;
    wdr_put_u32(pl, (uint32_t)len);
    wdr_put_u32(pl + 4, wdr_crc32(0, t, len));
    int st = request(base, pl, 8);
    for (uint32_t off = 0; !st && off < len; off += 3000) {
        uint32_t n = len - off < 3000 ? (uint32_t)len - off : 3000;
        wdr_put_u32(pl, off);
        memcpy(pl + 4, t + off, n);
        st = request(base + 1, pl, 4 + n);
    }
    return st ? st : request(base + 2, NULL, 0);
}

static int active(int kind) { return kind == WDR_KIND_LUT ? fw.lut_slot : fw.cal_slot; }

static uint32_t active_crc(int kind)
{
    wdr_status_report r;
    wdr_fw_status(&fw, &r);
    return kind == WDR_KIND_LUT ? r.lut_crc : r.cal_crc;
}

static void reboot(void)
{
    hal_sim_reboot();
    assert_int_equal(wdr_fw_init(&fw), WDR_OK);
}

/* Which of the scenario's tables has this CRC; -1 if none. */
static int table_of(const scenario *sc, uint32_t crc)
{
    for (int i = 0; i < TABLES; i++)
        if (crc == wdr_crc32(0, sc->t[i], sc->len))
            return i;
    return -1;
}

/* Factory-new flash; older and old uploaded (old active); x too when `second` is set. */
static void prepare(const scenario *sc, int second)
{
    hal_sim_flash_reset();
    reboot();
    if (sc->kind == WDR_KIND_CAL)
        assert_int_equal(upload(WDR_KIND_LUT, lut_t[OLDER], lut_len), 0);
    assert_int_equal(upload(sc->kind, sc->t[OLDER], sc->len), 0);
    assert_int_equal(upload(sc->kind, sc->t[OLD], sc->len), 0);
    if (second)
        assert_int_equal(upload(sc->kind, sc->t[X], sc->len), 0);
}

/* Remember the active slot's bytes, which no later upload may touch. */
static wdr_slot keep_active(const scenario *sc)
{
    size_t size;
    wdr_slot s = fw.store.slot[sc->kind - 1][active(sc->kind)];
    assert_true(WDR_SLOT_DATA_OFFSET + s.length <= sizeof before);
    memcpy(before, hal_sim_flash_bytes(&size) + s.addr, WDR_SLOT_DATA_OFFSET + s.length);
    return s;
}

/* Both slots, after a reboot: see the file's comment. `was` is the table active before. */
static void check_slots(const scenario *sc, const wdr_slot *kept, int was)
{
    size_t size;
    assert_memory_equal(hal_sim_flash_bytes(&size) + kept->addr, before, WDR_SLOT_DATA_OFFSET + kept->length);
    for (int s = 0; s < 2; s++) {
        const wdr_slot *sl = &fw.store.slot[sc->kind - 1][s];
        if (sl->valid) { /* the bytes themselves, not only what the store says of them */
            assert_int_equal(sl->length, sc->len);
            const uint8_t *data = hal_sim_flash_bytes(&size) + sl->addr + WDR_SLOT_DATA_OFFSET;
            assert_true(table_of(sc, wdr_crc32(0, data, sl->length)) >= 0); /* never a mix */
            assert_int_equal(wdr_crc32(0, data, sl->length), sl->crc);
        }
    }
    int a = active(sc->kind);
    assert_true(a >= 0);
    assert_int_equal(a, wdr_store_newest(&fw.store, sc->kind, -1));
    int now = table_of(sc, active_crc(sc->kind));
    assert_true(now == was || now == FRESH);
}

/* The board still takes the new table, and keeps it over a reboot. */
static void check_recovers(const scenario *sc)
{
    assert_int_equal(upload(sc->kind, sc->t[FRESH], sc->len), 0);
    reboot();
    assert_int_equal(table_of(sc, active_crc(sc->kind)), FRESH);
}

static uint64_t ops_of_upload(const scenario *sc, int second)
{
    prepare(sc, second);
    uint64_t ops0 = hal_sim_flash_ops();
    assert_int_equal(upload(sc->kind, sc->t[FRESH], sc->len), 0);
    return hal_sim_flash_ops() - ops0;
}

static void cut_with_tear(const scenario *sc, uint64_t k, int tear, int second)
{
    prepare(sc, second);
    int was = second ? X : OLD;
    wdr_slot kept = keep_active(sc);
    hal_sim_cut_power_tear(k, tear);
    assert_int_not_equal(upload(sc->kind, sc->t[FRESH], sc->len), 0);
    assert_true(hal_sim_power_lost());
    reboot();
    check_slots(sc, &kept, was);
    check_recovers(sc);
    fault_points++;
}

static void io_error_at(const scenario *sc, uint64_t k)
{
    prepare(sc, 0);
    wdr_slot kept = keep_active(sc);
    hal_sim_fail_flash_at(k);
    assert_int_not_equal(upload(sc->kind, sc->t[FRESH], sc->len), 0);
    assert_false(hal_sim_power_lost());
    assert_int_equal(table_of(sc, active_crc(sc->kind)), OLD); /* still running on the old table */
    reboot();
    check_slots(sc, &kept, OLD);
    check_recovers(sc);
    fault_points++;
}

/* Cut at k1, reboot, retry cut at k2, reboot, then finish. */
static void cut_twice(const scenario *sc, uint64_t k1, uint64_t k2)
{
    prepare(sc, 0);
    wdr_slot kept = keep_active(sc);
    hal_sim_cut_power_at(k1);
    upload(sc->kind, sc->t[FRESH], sc->len);
    reboot();
    check_slots(sc, &kept, OLD);
    int first = table_of(sc, active_crc(sc->kind));
    if (first == OLD) { /* the retry again writes the other slot: the old one stays untouched */
        hal_sim_cut_power_at(k2);
        upload(sc->kind, sc->t[FRESH], sc->len);
        reboot();
        check_slots(sc, &kept, OLD);
    }
    check_recovers(sc);
    fault_points++;
}

static void run(const scenario *sc)
{
    long p0 = fault_points;
    uint64_t total = ops_of_upload(sc, 0), total2 = ops_of_upload(sc, 1);
    for (int tear = NOR_TEAR_NONE; tear <= NOR_TEAR_BITS; tear++)
        for (uint64_t k = 1; k <= total; k++)
            if (tear != NOR_TEAR_FIRST_HALF) /* first half: test_powerloss_sim.c */
                cut_with_tear(sc, k, tear, 0);
    long shapes = fault_points - p0;
    for (uint64_t k = 1; k <= total; k++)
        io_error_at(sc, k);
    for (uint64_t k = 1; k <= total2; k++)
        cut_with_tear(sc, k, NOR_TEAR_FIRST_HALF, 1);
    long before_twice = fault_points;
    for (uint64_t k1 = 1; k1 <= total; k1++)
        for (uint64_t k2 = 1; k2 <= total; k2 += 3)
            cut_twice(sc, k1, k2);
    printf("powerloss shapes (hal/sim) %s: %llu operations; %ld tears (none, second half, bits), %llu I/O errors, "
           "%llu cuts in a second upload, %ld cut-reboot-cut pairs\n",
           sc->name, (unsigned long long)total, shapes, (unsigned long long)total, (unsigned long long)total2,
           fault_points - before_twice);
}

static void lut_shapes(void **state)
{
    (void)state;
    scenario sc = {"LUT", WDR_KIND_LUT, {lut_t[0], lut_t[1], lut_t[2], lut_t[3]}, lut_len};
    run(&sc);
}

static void cal_shapes(void **state)
{
    (void)state;
    scenario sc = {"calibration", WDR_KIND_CAL, {cal_t[0], cal_t[1], cal_t[2], cal_t[3]}, cal_len};
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
    for (int i = 0; i < TABLES; i++) {
        lut_len = th_make_lut(lut_t[i], 4000, (uint16_t)i, (uint8_t)board.dac_bits);
        cal_len = th_make_cal(cal_t[i], 0.5f + 0.25f * (float)i, 1.0f, SENSOR, W, H);
    }
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    hal_sim_teardown();
    printf("powerloss shapes (hal/sim): %ld fault points tested in all\n", fault_points);
    return 0;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(lut_shapes),
        cmocka_unit_test(cal_shapes),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
