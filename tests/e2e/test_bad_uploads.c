/* Bad uploads over the real socket to wdr-simboard: each is refused with its status, and the
 * table that was active before stays active (same slot, same CRC, the same captured frame).
 * Corrupted, truncated, oversized, out of sequence, wrong geometry, wrong kind. */
#include "e2e_board.h"
#include "crc32.h"
#include "wdr_cal.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>

static e2e_board rig;
static uint8_t *lut;
static size_t lut_len;
static uint16_t *reference; /* the frame under the good LUT */
static wdr_status_report before;

static size_t frame_size(void) { return (size_t)rig.board.width * rig.board.height; }

static int setup(void **state)
{
    (void)state;
    wdr_commit_reply reply;
    if (e2e_start(&rig, "sim-qvga") != 0 || e2e_reinhard_lut(&rig.board, &lut, &lut_len) != WDR_OK)
        return -1;
    reference = malloc(frame_size() * sizeof *reference);
    if (!reference || wdr_client_upload(rig.c, WDR_KIND_LUT, lut, lut_len, NULL, NULL, &reply) != WDR_OK ||
        wdr_client_capture(rig.c, 1, reference, NULL, NULL) != WDR_OK || wdr_client_status(rig.c, &before) != WDR_OK)
        return -1;
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    e2e_stop(&rig);
    free(lut);
    free(reference);
    return 0;
}

/* The good LUT is still the one in force: STATUS and a fresh frame say so. */
static void assert_previous_table_active(void)
{
    wdr_status_report now;
    assert_int_equal(wdr_client_status(rig.c, &now), WDR_OK);
    assert_int_equal(now.lut_slot, before.lut_slot);
    assert_int_equal(now.lut_crc, before.lut_crc);
    assert_int_equal(now.lut_seq, before.lut_seq);
    assert_int_equal(now.upload_kind, 0);
    uint16_t *frame = malloc(frame_size() * sizeof *frame);
    assert_int_equal(wdr_client_capture(rig.c, 1, frame, NULL, NULL), WDR_OK);
    assert_memory_equal(frame, reference, frame_size() * sizeof *frame);
    free(frame);
}

/* ---- Raw protocol steps ----------------------------------------------------------------------- */

static int begin(uint8_t op, uint32_t len, uint32_t crc)
{
    uint8_t p[WDR_BEGIN_SIZE];
    wdr_put_u32(p, len);
    wdr_put_u32(p + 4, crc);
    return wdr_client_request(rig.c, op, p, sizeof p);
}

static int chunk(uint8_t op, uint32_t offset, const uint8_t *data, uint32_t n)
{
    static uint8_t p[WDR_CHUNK_OFFSET_SIZE + WDR_PROTO_CHUNK_DATA_MAX];
    wdr_put_u32(p, offset);
    memcpy(p + WDR_CHUNK_OFFSET_SIZE, data, n);
    return wdr_client_request(rig.c, op, p, WDR_CHUNK_OFFSET_SIZE + n);
}

/* Send bytes[0..len) in order after a BEGIN that declared `declared` bytes with crc. */
static int send_all_chunks(uint8_t op_begin, const uint8_t *bytes, size_t len)
{
    for (size_t off = 0; off < len; off += WDR_PROTO_CHUNK_DATA_MAX) {
        uint32_t n = (uint32_t)(len - off < WDR_PROTO_CHUNK_DATA_MAX ? len - off : WDR_PROTO_CHUNK_DATA_MAX);
        int rc = chunk((uint8_t)(op_begin + 1), (uint32_t)off, bytes + off, n);
        if (rc != WDR_OK)
            return rc;
    }
    return WDR_OK;
}

static void assert_refused(int rc, int status)
{
    assert_int_equal(rc, WDR_E_STATUS);
    assert_int_equal(rig.c->status, status);
}

/* ---- Cases ------------------------------------------------------------------------------------------ */

static void corrupted_data_bad_crc(void **state)
{
    (void)state;
    uint8_t *bad = malloc(lut_len);
    memcpy(bad, lut, lut_len);
    bad[lut_len / 2] ^= 0x5a; /* a flipped byte on the way: the declared CRC no longer holds */
    assert_int_equal(begin(WDR_CMD_LUT_BEGIN, (uint32_t)lut_len, wdr_crc32(0, lut, lut_len)), WDR_OK);
    assert_int_equal(send_all_chunks(WDR_CMD_LUT_BEGIN, bad, lut_len), WDR_OK);
    assert_refused(wdr_client_request(rig.c, WDR_CMD_LUT_COMMIT, NULL, 0), WDR_ST_BAD_CRC);
    free(bad);
    assert_previous_table_active();
}

static void truncated_upload(void **state)
{
    (void)state;
    assert_int_equal(begin(WDR_CMD_LUT_BEGIN, (uint32_t)lut_len, wdr_crc32(0, lut, lut_len)), WDR_OK);
    assert_int_equal(send_all_chunks(WDR_CMD_LUT_BEGIN, lut, lut_len / 2), WDR_OK);
    assert_refused(wdr_client_request(rig.c, WDR_CMD_LUT_COMMIT, NULL, 0), WDR_ST_TRUNCATED);
    assert_previous_table_active();
}

static void oversized_upload(void **state)
{
    (void)state;
    assert_refused(begin(WDR_CMD_LUT_BEGIN, rig.c->info.lut_capacity + 1, 0), WDR_ST_TOO_LARGE);
    /* A chunk past what BEGIN declared is too large as well. */
    assert_int_equal(begin(WDR_CMD_LUT_BEGIN, 100, wdr_crc32(0, lut, 100)), WDR_OK);
    assert_refused(chunk(WDR_CMD_LUT_CHUNK, 0, lut, 200), WDR_ST_TOO_LARGE);
    assert_int_equal(wdr_client_request(rig.c, WDR_CMD_ABORT, NULL, 0), WDR_OK);
    assert_previous_table_active();
}

static void out_of_sequence(void **state)
{
    (void)state;
    assert_refused(chunk(WDR_CMD_LUT_CHUNK, 0, lut, 64), WDR_ST_BAD_SEQUENCE); /* no BEGIN */
    assert_int_equal(begin(WDR_CMD_LUT_BEGIN, (uint32_t)lut_len, wdr_crc32(0, lut, lut_len)), WDR_OK);
    assert_refused(chunk(WDR_CMD_LUT_CHUNK, WDR_PROTO_CHUNK_DATA_MAX, lut + WDR_PROTO_CHUNK_DATA_MAX, 64),
                   WDR_ST_BAD_SEQUENCE);
    assert_int_equal(wdr_client_request(rig.c, WDR_CMD_ABORT, NULL, 0), WDR_OK);
    assert_previous_table_active();
}

static void lut_for_another_dac(void **state)
{
    (void)state;
    wdr_board other = rig.board;
    other.dac_bits = 10;
    uint8_t *bytes;
    size_t len;
    assert_int_equal(e2e_reinhard_lut(&other, &bytes, &len), WDR_OK);
    assert_refused(wdr_client_upload(rig.c, WDR_KIND_LUT, bytes, len, NULL, NULL, NULL), WDR_ST_BAD_GEOMETRY);
    free(bytes);
    assert_previous_table_active();
}

/* An identity polynomial (v = y) table of the given sensor id and size. */
static uint8_t *poly_table(uint32_t sensor_id, uint16_t w, uint16_t h, size_t *len)
{
    size_t n = (size_t)w * h;
    float *coeffs = calloc(2 * n, sizeof *coeffs);
    uint8_t *flags = calloc(n, 1);
    for (size_t i = 0; i < n; i++)
        coeffs[n + i] = 1.0f;
    uint16_t full = (uint16_t)((1u << rig.board.adc_bits) - 1u);
    wdr_cal_header hd = {.sensor_id = sensor_id, .width = w, .height = h, .form = WDR_FORM_POLY, .n_coeffs = 2,
                         .in_scale = 1.0f, .out_scale = 1.0f, .out_max = full, .raw_max = full};
    *len = wdr_cal_size(w, h, 2);
    uint8_t *out = malloc(*len);
    wdr_cal_encode(&hd, coeffs, flags, out);
    free(coeffs);
    free(flags);
    return out;
}

static void calibration_for_another_sensor(void **state)
{
    (void)state;
    size_t len;
    uint8_t *cal = poly_table(rig.board.sensor_id + 1, rig.board.width, rig.board.height, &len);
    assert_refused(wdr_client_upload(rig.c, WDR_KIND_CAL, cal, len, NULL, NULL, NULL), WDR_ST_BAD_GEOMETRY);
    free(cal);
    cal = poly_table(rig.board.sensor_id, rig.board.width, (uint16_t)(rig.board.height - 1), &len);
    assert_refused(wdr_client_upload(rig.c, WDR_KIND_CAL, cal, len, NULL, NULL, NULL), WDR_ST_BAD_GEOMETRY);
    free(cal);
    wdr_status_report now;
    assert_int_equal(wdr_client_status(rig.c, &now), WDR_OK);
    assert_int_equal(now.cal_slot, before.cal_slot);
    assert_previous_table_active();
}

static void wrong_kind(void **state)
{
    (void)state;
    assert_refused(wdr_client_upload(rig.c, WDR_KIND_CAL, lut, lut_len, NULL, NULL, NULL), WDR_ST_BAD_KIND);
    size_t len;
    uint8_t *cal = poly_table(rig.board.sensor_id, rig.board.width, rig.board.height, &len);
    /* A calibration table outgrows a LUT slot: BEGIN refuses it before its kind can be seen. */
    assert_true(len > rig.c->info.lut_capacity);
    assert_refused(wdr_client_upload(rig.c, WDR_KIND_LUT, cal, len, NULL, NULL, NULL), WDR_ST_TOO_LARGE);
    free(cal);
    assert_previous_table_active();
}

/* After all that, a good table still goes in, into the other slot, and is used. */
static void good_upload_still_works(void **state)
{
    (void)state;
    size_t len;
    uint8_t *cal = poly_table(rig.board.sensor_id, rig.board.width, rig.board.height, &len);
    wdr_commit_reply reply;
    assert_int_equal(wdr_client_upload(rig.c, WDR_KIND_CAL, cal, len, NULL, NULL, &reply), WDR_OK);
    assert_int_equal(reply.crc, wdr_crc32(0, cal, len));
    wdr_status_report now;
    assert_int_equal(wdr_client_status(rig.c, &now), WDR_OK);
    assert_int_equal(now.cal_slot, reply.slot);
    free(cal);
    assert_previous_table_active(); /* the identity polynomial changes no code */
}

/* SIGTERM ends the board cleanly (status 0) and promptly. */
static void board_exits_on_sigterm(void **state)
{
    (void)state;
    wdr_transport_close(rig.t);
    rig.t = NULL;
    kill(rig.pid, SIGTERM);
    assert_int_equal(e2e_wait_exit(&rig, 10000), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(corrupted_data_bad_crc), cmocka_unit_test(truncated_upload),
        cmocka_unit_test(oversized_upload),       cmocka_unit_test(out_of_sequence),
        cmocka_unit_test(lut_for_another_dac),    cmocka_unit_test(calibration_for_another_sensor),
        cmocka_unit_test(wrong_kind),             cmocka_unit_test(good_upload_still_works),
        cmocka_unit_test(board_exits_on_sigterm),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
