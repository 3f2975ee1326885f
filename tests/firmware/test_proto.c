/* Wire protocol codec: round trips, resynchronisation on garbage, CRC and length errors. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "crc32.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include "wdr_proto.h"
#include <string.h>

static uint8_t payload[WDR_PROTO_MAX_PAYLOAD];
static uint8_t stream[4 * WDR_PROTO_MAX_FRAME + 1024];

static size_t frame(uint8_t *out, uint8_t op, uint16_t seq, uint32_t len)
{
    for (uint32_t i = 0; i < len; i++)
        payload[i] = (uint8_t)(i * 7 + seq);
    wdr_proto_header h = {op, 0, seq, 0, 0, 0};
    return wdr_proto_encode(out, WDR_PROTO_MAX_FRAME, &h, payload, len);
}

/* Feed everything; record each result with its seq. Returns how many results. */
static int feed_all(wdr_proto_decoder *d, const uint8_t *p, size_t n, size_t chunk, int *results, uint16_t *seqs)
{
    int count = 0;
    for (size_t off = 0; off < n;) {
        size_t len = n - off < chunk ? n - off : chunk, used;
        wdr_packet pkt;
        int r = wdr_proto_feed(d, p + off, len, &used, &pkt);
        off += used;
        if (r != WDR_FEED_MORE) {
            if (r == WDR_FEED_PACKET)
                assert_int_equal(wdr_crc32(0, pkt.payload, pkt.h.length), pkt.h.payload_crc);
            results[count] = r;
            seqs[count++] = pkt.h.seq;
        }
    }
    return count;
}

static void round_trip_sizes(void **state)
{
    (void)state;
    static const uint32_t sizes[] = {0, 1, 2, 19, 20, 21, 1000, WDR_PROTO_MAX_PAYLOAD};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        wdr_proto_decoder d;
        wdr_proto_decoder_init(&d);
        uint8_t f[WDR_PROTO_MAX_FRAME];
        size_t n = frame(f, WDR_CMD_LUT_CHUNK, (uint16_t)(100 + i), sizes[i]);
        assert_int_equal(n, WDR_PROTO_HEADER_SIZE + sizes[i]);
        wdr_packet pkt;
        size_t used;
        assert_int_equal(wdr_proto_feed(&d, f, n, &used, &pkt), WDR_FEED_PACKET);
        assert_int_equal(used, n);
        assert_int_equal(pkt.h.opcode, WDR_CMD_LUT_CHUNK);
        assert_int_equal(pkt.h.seq, 100 + i);
        assert_int_equal(pkt.h.length, sizes[i]);
        if (sizes[i])
            assert_memory_equal(pkt.payload, payload, sizes[i]);
        assert_int_equal(d.skipped, 0);
    }
}

static void byte_by_byte_and_back_to_back(void **state)
{
    (void)state;
    size_t n = 0;
    for (int i = 0; i < 3; i++)
        n += frame(stream + n, WDR_CMD_STATUS, (uint16_t)i, (uint32_t)(i * 500));
    int results[8];
    uint16_t seqs[8];
    for (size_t chunk = 1; chunk <= 4096; chunk *= 8) {
        wdr_proto_decoder d;
        wdr_proto_decoder_init(&d);
        assert_int_equal(feed_all(&d, stream, n, chunk, results, seqs), 3);
        for (int i = 0; i < 3; i++) {
            assert_int_equal(results[i], WDR_FEED_PACKET);
            assert_int_equal(seqs[i], i);
        }
    }
}

static void garbage_is_skipped(void **state)
{
    (void)state;
    /* Garbage with false sync pairs and a plausible-looking header before, between, after. */
    static const uint8_t junk[] = {0x00, 'W', 'D', 0x01, 0xff, 'W', 'W', 'D', 'D', 0x57, 0x44, 0x00, 0x00,
                                   0x00, 0x00, 0x00, 0x10, 0x00, 0x00, 0x00, 0x13, 'W'};
    size_t n = 0;
    memcpy(stream + n, junk, sizeof junk);
    n += sizeof junk;
    n += frame(stream + n, WDR_CMD_INFO, 1, 4);
    memcpy(stream + n, junk, sizeof junk);
    n += sizeof junk;
    n += frame(stream + n, WDR_CMD_INFO, 2, 64);
    memcpy(stream + n, junk, 5);
    n += 5;
    wdr_proto_decoder d;
    wdr_proto_decoder_init(&d);
    int results[8];
    uint16_t seqs[8];
    assert_int_equal(feed_all(&d, stream, n, 7, results, seqs), 2);
    assert_int_equal(results[0], WDR_FEED_PACKET);
    assert_int_equal(seqs[0], 1);
    assert_int_equal(results[1], WDR_FEED_PACKET);
    assert_int_equal(seqs[1], 2);
    assert_true(d.skipped >= 2 * sizeof junk);
}

static void bad_header_crc_skipped(void **state)
{
    (void)state;
    size_t a = frame(stream, WDR_CMD_INFO, 1, 8);
    size_t b = frame(stream + a, WDR_CMD_INFO, 2, 8);
    stream[5] ^= 0x40; /* seq byte of the first header: header CRC fails */
    wdr_proto_decoder d;
    wdr_proto_decoder_init(&d);
    int results[4];
    uint16_t seqs[4];
    assert_int_equal(feed_all(&d, stream, a + b, 3, results, seqs), 1);
    assert_int_equal(seqs[0], 2);
}

static void bad_payload_crc_reported(void **state)
{
    (void)state;
    size_t a = frame(stream, WDR_CMD_LUT_CHUNK, 7, 100);
    size_t b = frame(stream + a, WDR_CMD_STATUS, 8, 0);
    stream[WDR_PROTO_HEADER_SIZE + 50] ^= 1;
    wdr_proto_decoder d;
    wdr_proto_decoder_init(&d);
    int results[4];
    uint16_t seqs[4];
    assert_int_equal(feed_all(&d, stream, a + b, 64, results, seqs), 2);
    assert_int_equal(results[0], WDR_FEED_BAD_CRC);
    assert_int_equal(seqs[0], 7); /* the header told us which request failed */
    assert_int_equal(results[1], WDR_FEED_PACKET);
    assert_int_equal(seqs[1], 8);
    assert_int_equal(d.bad_payloads, 1);
}

/* A frame cut short: the next frame sits inside what the first claimed as payload. */
static void frame_hidden_in_cut_payload(void **state)
{
    (void)state;
    size_t a = frame(stream, WDR_CMD_LUT_CHUNK, 1, 200);
    size_t cut = WDR_PROTO_HEADER_SIZE + 30;
    size_t b = frame(stream + cut, WDR_CMD_STATUS, 2, 10);
    size_t c = frame(stream + cut + b, WDR_CMD_STATUS, 3, 300);
    (void)a;
    wdr_proto_decoder d;
    wdr_proto_decoder_init(&d);
    int results[4];
    uint16_t seqs[4];
    int n = feed_all(&d, stream, cut + b + c, 4096, results, seqs);
    assert_int_equal(n, 3);
    assert_int_equal(results[0], WDR_FEED_BAD_CRC);
    assert_int_equal(seqs[1], 2);
    assert_int_equal(seqs[2], 3);
}

static void too_large_reported_then_resync(void **state)
{
    (void)state;
    size_t a = frame(stream, WDR_CMD_LUT_CHUNK, 5, 16);
    wdr_put_u32(stream + 8, WDR_PROTO_MAX_PAYLOAD + 1); /* lie about the length, fix the header CRC */
    wdr_put_u32(stream + 16, wdr_crc32(0, stream, 16));
    size_t b = frame(stream + a, WDR_CMD_STATUS, 6, 0);
    wdr_proto_decoder d;
    wdr_proto_decoder_init(&d);
    int results[4];
    uint16_t seqs[4];
    assert_int_equal(feed_all(&d, stream, a + b, 1, results, seqs), 2);
    assert_int_equal(results[0], WDR_FEED_TOO_LARGE);
    assert_int_equal(seqs[0], 5);
    assert_int_equal(results[1], WDR_FEED_PACKET);
    assert_int_equal(seqs[1], 6);
}

static void encode_limits(void **state)
{
    (void)state;
    uint8_t f[WDR_PROTO_MAX_FRAME + 8];
    wdr_proto_header h = {WDR_CMD_INFO, 0, 1, 0, 0, 0};
    assert_int_equal(wdr_proto_encode(f, sizeof f, &h, payload, WDR_PROTO_MAX_PAYLOAD + 1), 0);
    assert_int_equal(wdr_proto_encode(f, WDR_PROTO_HEADER_SIZE + 3, &h, payload, 4), 0);
    assert_int_equal(wdr_proto_encode(f, WDR_PROTO_HEADER_SIZE + 4, &h, payload, 4), WDR_PROTO_HEADER_SIZE + 4);
    assert_int_equal(f[0], WDR_PROTO_SYNC0);
    assert_int_equal(f[1], WDR_PROTO_SYNC1);
}

static void payload_records_round_trip(void **state)
{
    (void)state;
    uint8_t buf[128];
    wdr_info in = {1, 0, 1, 0, 0xdeadbeef, 640, 480, 12, 12, 1, 4128, 65600, 999999, 20000, "sim-vga", 7, 1, 1, 42}, io;
    wdr_info_pack(&in, buf);
    assert_int_equal(wdr_info_unpack(buf, WDR_INFO_SIZE, &io), WDR_OK);
    assert_memory_equal(&in.sensor_id, &io.sensor_id, sizeof in.sensor_id);
    assert_int_equal(io.width, 640);
    assert_int_equal(io.cal_capacity, 999999);
    assert_string_equal(io.name, "sim-vga");
    assert_int_equal(wdr_info_unpack(buf, WDR_INFO_SIZE_1_3 - 1, &io), WDR_E_TRUNCATED);

    wdr_status_report s = {3, 1, 0xff, 2, 5, 6, 7, 8, 9, 10, 11, 12, 0x123456789abcull, 13, 14, 0, 0, 0, 0, 0}, so;
    wdr_status_pack(&s, buf);
    assert_int_equal(wdr_status_unpack(buf, WDR_STATUS_SIZE, &so), WDR_OK);
    assert_true(so.time_ns == 0x123456789abcull && so.rx_bad_crc == 14 && so.cal_slot == 0xff);
    assert_int_equal(wdr_status_unpack(buf, 10, &so), WDR_E_TRUNCATED);
    /* 1.1: the exposure fields travel; a 1.0 board's 52 bytes read them as 0 */
    s.exposure_auto = 1, s.exposure_flags = 1, s.key_gain_q8 = -1179, s.tick_ps = 100000, s.last_error_q8 = 37;
    wdr_status_pack(&s, buf);
    assert_int_equal(wdr_status_unpack(buf, WDR_STATUS_SIZE, &so), WDR_OK);
    assert_true(so.exposure_auto == 1 && so.exposure_flags == 1 && so.key_gain_q8 == -1179 && so.tick_ps == 100000 &&
                so.last_error_q8 == 37);
    assert_int_equal(wdr_status_unpack(buf, WDR_STATUS_SIZE_1_0, &so), WDR_OK);
    assert_true(so.exposure_auto == 0 && so.key_gain_q8 == 0 && so.tick_ps == 0 && so.rx_bad_crc == 14);

    wdr_frame_end fe = {42, 480, 1, 1500000, 99999999999ull}, fo;
    wdr_frame_end_pack(&fe, buf);
    assert_int_equal(wdr_frame_end_unpack(buf, WDR_FRAME_END_SIZE, &fo), WDR_OK);
    assert_true(fo.frame == 42 && fo.rows == 480 && fo.t_start_ns == 99999999999ull);

    wdr_commit_reply c = {0xcafef00d, 17, 1}, co;
    wdr_commit_pack(&c, buf);
    assert_int_equal(wdr_commit_unpack(buf, WDR_COMMIT_REPLY_SIZE, &co), WDR_OK);
    assert_true(co.crc == 0xcafef00d && co.seq == 17 && co.slot == 1);
}

static void status_names_and_errors(void **state)
{
    (void)state;
    assert_string_equal(wdr_status_name(WDR_ST_BAD_SEQUENCE), "bad sequence");
    assert_string_equal(wdr_status_name(99), "unknown status");
    assert_int_equal(wdr_status_from_err(WDR_E_CORRUPT), WDR_ST_BAD_CRC);
    assert_int_equal(wdr_status_from_err(WDR_E_GEOMETRY), WDR_ST_BAD_GEOMETRY);
    assert_int_equal(wdr_status_from_err(WDR_E_KIND), WDR_ST_BAD_KIND);
    assert_int_equal(wdr_status_from_err(WDR_E_POWER), WDR_ST_FLASH);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(round_trip_sizes),
        cmocka_unit_test(byte_by_byte_and_back_to_back),
        cmocka_unit_test(garbage_is_skipped),
        cmocka_unit_test(bad_header_crc_skipped),
        cmocka_unit_test(bad_payload_crc_reported),
        cmocka_unit_test(frame_hidden_in_cut_payload),
        cmocka_unit_test(too_large_reported_then_resync),
        cmocka_unit_test(encode_limits),
        cmocka_unit_test(payload_records_round_trip),
        cmocka_unit_test(status_names_and_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
