/* Tables in flash: slot selection at boot, and every bad upload rejected with the right
 * status while the previously active table stays active. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "crc32.h"
#include "harness.h"
#include <math.h>
#include <string.h>

static wdr_fw fw;
static uint8_t lut_a[WDR_FW_LUT_MAX_BYTES], lut_b[WDR_FW_LUT_MAX_BYTES], bad[WDR_FW_LUT_MAX_BYTES * 2];
static uint8_t cal_a[64 + 48 * (64 * 12 + 64)], cal_b[sizeof cal_a];
static size_t lut_a_len, lut_b_len, cal_len;

static int setup(void **state)
{
    (void)state;
    fb_init();
    th_boot(&fw);
    lut_a_len = th_make_lut(lut_a, 256, 0, FB_DAC_BITS);
    lut_b_len = th_make_lut(lut_b, 1000, 7, FB_DAC_BITS);
    cal_len = th_make_cal(cal_a, 0.5f, 0.0f, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT);
    th_make_cal(cal_b, 2.0f, 1.0f, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT);
    return 0;
}

static void reboot(void)
{
    fb_power_cycle();
    th_boot(&fw);
}

/* The LUT the board plays is exactly these bytes. */
static void assert_active_lut(const uint8_t *lut, size_t len)
{
    wdr_status_report s = th_status(&fw);
    assert_int_not_equal(s.lut_slot, WDR_SLOT_NONE);
    assert_int_equal(s.lut_crc, wdr_crc32(0, lut, len));
    assert_memory_equal(fw.lut_ram[fw.lut_buf], lut, len);
}

static void assert_active_cal(const uint8_t *cal)
{
    wdr_status_report s = th_status(&fw);
    if (!cal) {
        assert_int_equal(s.cal_slot, WDR_SLOT_NONE);
        return;
    }
    assert_int_equal(s.cal_crc, wdr_crc32(0, cal, cal_len));
}

/* ---- Boot and slot selection ------------------------------------------------------------------ */

static void empty_flash_boots_without_tables(void **state)
{
    (void)state;
    wdr_status_report s = th_status(&fw);
    assert_int_equal(s.lut_slot, WDR_SLOT_NONE);
    assert_int_equal(s.cal_slot, WDR_SLOT_NONE);
    assert_int_equal(th_capture_frames(&fw, 1), WDR_ST_NO_TABLE);
}

static void upload_answers_stored_crc_and_survives_reboot(void **state)
{
    (void)state;
    wdr_commit_reply c;
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, lut_a, (uint32_t)lut_a_len, 4096, &c), WDR_ST_OK);
    assert_int_equal(c.crc, wdr_crc32(0, lut_a, lut_a_len));
    assert_int_equal(c.slot, 0);
    assert_int_equal(c.seq, 1);
    reboot();
    assert_active_lut(lut_a, lut_a_len);
}

static void newest_slot_wins_and_alternates(void **state)
{
    (void)state;
    wdr_commit_reply c;
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, lut_b, (uint32_t)lut_b_len, 1000, &c), WDR_ST_OK);
    assert_int_equal(c.slot, 1);
    assert_int_equal(c.seq, 2);
    reboot();
    assert_active_lut(lut_b, lut_b_len);
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, lut_a, (uint32_t)lut_a_len, 333, &c), WDR_ST_OK);
    assert_int_equal(c.slot, 0); /* the active slot (B) was not touched */
    assert_int_equal(c.seq, 3);
    reboot();
    assert_active_lut(lut_a, lut_a_len);
}

static void broken_newest_slot_falls_back(void **state)
{
    (void)state;
    /* Slot A (seq 3) is newest: corrupt one byte of its table in flash. */
    fb_flash()[fw.store.slot[0][0].addr + WDR_SLOT_DATA_OFFSET + 100] ^= 0x10;
    reboot();
    assert_active_lut(lut_b, lut_b_len);
    assert_int_equal(fw.store.slot[0][0].valid, 0);
    /* Without a commit marker a complete table is not a table either. */
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, lut_a, (uint32_t)lut_a_len, 4096, NULL), WDR_ST_OK);
    memset(fb_flash() + fw.store.slot[0][0].addr + WDR_SLOT_MARKER_OFFSET, 0xff, 8);
    reboot();
    assert_active_lut(lut_b, lut_b_len);
}

static void lut_select_picks_a_slot(void **state)
{
    (void)state;
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, lut_a, (uint32_t)lut_a_len, 4096, NULL), WDR_ST_OK);
    uint8_t which = 1;
    assert_int_equal(th_request(&fw, WDR_CMD_LUT_SELECT, &which, 1, NULL, 0), WDR_ST_OK);
    assert_active_lut(lut_b, lut_b_len);
    which = WDR_SLOT_NEWEST;
    assert_int_equal(th_request(&fw, WDR_CMD_LUT_SELECT, &which, 1, NULL, 0), WDR_ST_OK);
    assert_active_lut(lut_a, lut_a_len);
    which = 7;
    assert_int_equal(th_request(&fw, WDR_CMD_LUT_SELECT, &which, 1, NULL, 0), WDR_ST_BAD_ARG);
    assert_int_equal(th_request(&fw, WDR_CMD_LUT_SELECT, NULL, 0, NULL, 0), WDR_ST_BAD_LENGTH);
}

static void calibration_upload_and_reboot(void **state)
{
    (void)state;
    wdr_commit_reply c;
    assert_active_cal(NULL);
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, cal_a, (uint32_t)cal_len, 4096, &c), WDR_ST_OK);
    assert_int_equal(c.crc, wdr_crc32(0, cal_a, cal_len));
    reboot();
    assert_active_cal(cal_a);
    assert_active_lut(lut_a, lut_a_len);
}

/* ---- Bad uploads: right status, old table active ----------------------------------------------- */

/* Send BEGIN with a declared length and CRC. */
static int begin(int kind, uint32_t len, uint32_t crc)
{
    uint8_t pl[8];
    wdr_put_u32(pl, len);
    wdr_put_u32(pl + 4, crc);
    return th_request(&fw, kind == WDR_KIND_LUT ? WDR_CMD_LUT_BEGIN : WDR_CMD_CAL_BEGIN, pl, 8, NULL, 0);
}

static int chunk(int kind, uint32_t off, const uint8_t *data, uint32_t n)
{
    static uint8_t pl[WDR_PROTO_MAX_PAYLOAD];
    wdr_put_u32(pl, off);
    memcpy(pl + 4, data, n);
    return th_request(&fw, kind == WDR_KIND_LUT ? WDR_CMD_LUT_CHUNK : WDR_CMD_CAL_CHUNK, pl, 4 + n, NULL, 0);
}

static int commit(int kind)
{
    return th_request(&fw, kind == WDR_KIND_LUT ? WDR_CMD_LUT_COMMIT : WDR_CMD_CAL_COMMIT, NULL, 0, NULL, 0);
}

static void assert_old_tables_active(void)
{
    assert_active_lut(lut_a, lut_a_len);
    assert_active_cal(cal_a);
    reboot();
    assert_active_lut(lut_a, lut_a_len);
    assert_active_cal(cal_a);
}

static void corrupted_rejected(void **state)
{
    (void)state;
    /* A byte flipped in transit: the declared CRC catches it. */
    memcpy(bad, lut_b, lut_b_len);
    uint32_t crc = wdr_crc32(0, lut_b, lut_b_len);
    bad[300] ^= 0x01;
    assert_int_equal(begin(WDR_KIND_LUT, (uint32_t)lut_b_len, crc), WDR_ST_OK);
    assert_int_equal(chunk(WDR_KIND_LUT, 0, bad, 4000), WDR_ST_OK);
    assert_int_equal(chunk(WDR_KIND_LUT, 4000, bad + 4000, (uint32_t)lut_b_len - 4000), WDR_ST_OK);
    assert_int_equal(commit(WDR_KIND_LUT), WDR_ST_BAD_CRC);
    /* A table corrupted before it was sent: its own CRC catches it. */
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, bad, (uint32_t)lut_b_len, 4096, NULL), WDR_ST_BAD_CRC);
    memcpy(bad, cal_b, cal_len);
    bad[5000] ^= 0x80;
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, bad, (uint32_t)cal_len, 4096, NULL), WDR_ST_BAD_CRC);
    assert_old_tables_active();
}

static void truncated_rejected(void **state)
{
    (void)state;
    uint32_t crc = wdr_crc32(0, lut_b, lut_b_len);
    assert_int_equal(begin(WDR_KIND_LUT, (uint32_t)lut_b_len, crc), WDR_ST_OK);
    assert_int_equal(chunk(WDR_KIND_LUT, 0, lut_b, 4000), WDR_ST_OK);
    assert_int_equal(commit(WDR_KIND_LUT), WDR_ST_TRUNCATED);
    assert_int_equal(commit(WDR_KIND_LUT), WDR_ST_BAD_SEQUENCE); /* the failed upload is gone */
    /* A file cut short but sent whole: the format's own length check. */
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, lut_b, (uint32_t)lut_b_len - 8, 4096, NULL), WDR_ST_TRUNCATED);
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, cal_b, (uint32_t)cal_len - 100, 4096, NULL), WDR_ST_TRUNCATED);
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, cal_b, 40, 4096, NULL), WDR_ST_TRUNCATED);
    assert_old_tables_active();
}

static void oversized_rejected(void **state)
{
    (void)state;
    assert_int_equal(begin(WDR_KIND_LUT, fw.store.slot[0][0].capacity + 1, 0), WDR_ST_TOO_LARGE);
    assert_int_equal(begin(WDR_KIND_CAL, fw.store.slot[1][0].capacity + 1, 0), WDR_ST_TOO_LARGE);
    /* More bytes than declared. */
    assert_int_equal(begin(WDR_KIND_LUT, 100, 0), WDR_ST_OK);
    assert_int_equal(chunk(WDR_KIND_LUT, 0, lut_b, 101), WDR_ST_TOO_LARGE);
    /* A LUT with more entries than the firmware's RAM buffer, within the slot's capacity. */
    size_t n = th_make_lut(bad, WDR_FW_LUT_MAX_ENTRIES + 1, 0, FB_DAC_BITS);
    int st = th_upload(&fw, WDR_KIND_LUT, bad, (uint32_t)n, 4096, NULL);
    assert_int_equal(st, WDR_ST_TOO_LARGE);
    /* A packet longer than the protocol allows. */
    static uint8_t f[WDR_PROTO_MAX_FRAME + 64];
    wdr_proto_header h = {WDR_CMD_LUT_CHUNK, 0, 4242, 0, 0, 0};
    size_t len = wdr_proto_encode(f, sizeof f, &h, bad, 64);
    wdr_put_u32(f + 8, WDR_PROTO_MAX_PAYLOAD + 64);
    wdr_put_u32(f + 16, wdr_crc32(0, f, 16));
    th_send_raw(&fw, f, len);
    assert_old_tables_active();
}

static void out_of_sequence_rejected(void **state)
{
    (void)state;
    assert_int_equal(chunk(WDR_KIND_LUT, 0, lut_b, 100), WDR_ST_BAD_SEQUENCE); /* no BEGIN */
    assert_int_equal(commit(WDR_KIND_CAL), WDR_ST_BAD_SEQUENCE);
    uint32_t crc = wdr_crc32(0, lut_b, lut_b_len);
    assert_int_equal(begin(WDR_KIND_LUT, (uint32_t)lut_b_len, crc), WDR_ST_OK);
    assert_int_equal(chunk(WDR_KIND_LUT, 0, lut_b, 1000), WDR_ST_OK);
    assert_int_equal(chunk(WDR_KIND_LUT, 2000, lut_b + 2000, 1000), WDR_ST_BAD_SEQUENCE); /* gap */
    assert_int_equal(chunk(WDR_KIND_LUT, 0, lut_b, 1000), WDR_ST_BAD_SEQUENCE);           /* repeat */
    /* The upload is still open at 1000: the host can resend the right chunk, but we drop it. */
    assert_int_equal(th_request(&fw, WDR_CMD_ABORT, NULL, 0, NULL, 0), WDR_ST_OK);
    assert_int_equal(commit(WDR_KIND_LUT), WDR_ST_BAD_SEQUENCE);
    assert_old_tables_active();
}

static void wrong_geometry_rejected(void **state)
{
    (void)state;
    size_t n = th_make_lut(bad, 256, 0, 10); /* a 10-bit DAC ramp on a 12-bit DAC */
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, bad, (uint32_t)n, 4096, NULL), WDR_ST_BAD_GEOMETRY);
    n = th_make_cal(bad, 1.0f, 0.0f, FB_SENSOR_ID + 1, FB_WIDTH, FB_HEIGHT);
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, bad, (uint32_t)n, 4096, NULL), WDR_ST_BAD_GEOMETRY);
    n = th_make_cal(bad, 1.0f, 0.0f, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT - 1);
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, bad, (uint32_t)n, 4096, NULL), WDR_ST_BAD_GEOMETRY);
    n = th_make_cal(bad, 1.0f, 0.0f, FB_SENSOR_ID, FB_WIDTH / 2, FB_HEIGHT * 2);
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, bad, (uint32_t)n, 4096, NULL), WDR_ST_BAD_GEOMETRY);
    assert_old_tables_active();
}

static void wrong_kind_rejected(void **state)
{
    (void)state;
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, lut_b, (uint32_t)lut_b_len, 4096, NULL), WDR_ST_BAD_KIND);
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, cal_b, (uint32_t)cal_len, 4096, NULL), WDR_ST_BAD_KIND);
    uint32_t crc = wdr_crc32(0, lut_b, lut_b_len);
    assert_int_equal(begin(WDR_KIND_LUT, (uint32_t)lut_b_len, crc), WDR_ST_OK);
    assert_int_equal(chunk(WDR_KIND_CAL, 0, lut_b, 100), WDR_ST_BAD_KIND);
    assert_int_equal(commit(WDR_KIND_CAL), WDR_ST_BAD_KIND);
    assert_old_tables_active();
}

static void bad_content_rejected(void **state)
{
    (void)state;
    /* Valid CRCs around entries whose times do not rise. */
    static uint32_t t[4] = {0, 10, 10, 30};
    static uint16_t codes[4] = {1, 2, 3, 4};
    wdr_lut_header h;
    memset(&h, 0, sizeof h);
    h.dac_bits = FB_DAC_BITS;
    h.entry_count = 4;
    h.tick_ps = 1000;
    h.t_integration_ticks = 100;
    h.dac_hi_v = 3.3f;
    wdr_lut_encode(&h, t, codes, bad);
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, bad, (uint32_t)wdr_lut_size(4), 4096, NULL), WDR_ST_BAD_TABLE);
    /* A calibration table with a NaN coefficient, CRCs recomputed by the encoder. */
    size_t n = th_make_cal(bad, NAN, 0.0f, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT);
    assert_int_equal(th_upload(&fw, WDR_KIND_CAL, bad, (uint32_t)n, 4096, NULL), WDR_ST_BAD_TABLE);
    /* Zero length, and a BEGIN with a short payload. */
    assert_int_equal(begin(WDR_KIND_LUT, 0, 0), WDR_ST_BAD_LENGTH);
    assert_int_equal(th_request(&fw, WDR_CMD_CAL_BEGIN, bad, 4, NULL, 0), WDR_ST_BAD_LENGTH);
    assert_old_tables_active();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(empty_flash_boots_without_tables),
        cmocka_unit_test(upload_answers_stored_crc_and_survives_reboot),
        cmocka_unit_test(newest_slot_wins_and_alternates),
        cmocka_unit_test(broken_newest_slot_falls_back),
        cmocka_unit_test(lut_select_picks_a_slot),
        cmocka_unit_test(calibration_upload_and_reboot),
        cmocka_unit_test(corrupted_rejected),
        cmocka_unit_test(truncated_rejected),
        cmocka_unit_test(oversized_rejected),
        cmocka_unit_test(out_of_sequence_rejected),
        cmocka_unit_test(wrong_geometry_rejected),
        cmocka_unit_test(wrong_kind_rejected),
        cmocka_unit_test(bad_content_rejected),
    };
    /* The tests build on each other's flash state, in this order. */
    return cmocka_run_group_tests(tests, setup, NULL);
}
