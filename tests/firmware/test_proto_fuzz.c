/* Random and mutated bytes into the decoder and into the whole firmware: nothing may crash
 * (run under ASan+UBSan in CI), every packet handed out must carry good CRCs, and afterwards
 * the firmware still answers a clean request. Seeded: the same bytes every run. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "crc32.h"
#include "harness.h"
#include <string.h>

static uint64_t rng = 0x9e3779b97f4a7c15ull;

static uint32_t next_rand(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return (uint32_t)(rng >> 16);
}

static uint8_t buf[1 << 16];

/* A stream of valid frames, then flips, cuts, duplicated and inserted garbage. */
static size_t mutated_stream(void)
{
    size_t n = 0;
    while (n + WDR_PROTO_MAX_FRAME < sizeof buf / 2) {
        static uint8_t pl[WDR_PROTO_MAX_PAYLOAD];
        uint32_t len = next_rand() % 3 ? next_rand() % 64 : next_rand() % WDR_PROTO_MAX_PAYLOAD;
        for (uint32_t i = 0; i < len; i++)
            pl[i] = (uint8_t)next_rand();
        wdr_proto_header h = {(uint8_t)(next_rand() % 0x80), 0, (uint16_t)next_rand(), 0, 0, 0};
        n += wdr_proto_encode(buf + n, sizeof buf - n, &h, pl, len);
    }
    for (int m = (int)(next_rand() % 20); m > 0; m--) {
        size_t at = next_rand() % n;
        switch (next_rand() % 4) {
        case 0: buf[at] ^= (uint8_t)(1u << (next_rand() % 8)); break;
        case 1: buf[at] = next_rand() % 2 ? WDR_PROTO_SYNC0 : WDR_PROTO_SYNC1; break;
        case 2: n = at + 1; break; /* cut */
        default: memset(buf + at, (int)next_rand(), (n - at) < 30 ? n - at : 30); break;
        }
    }
    return n;
}

static size_t random_stream(void)
{
    size_t n = 1 + next_rand() % (sizeof buf / 4);
    for (size_t i = 0; i < n; i++)
        buf[i] = (uint8_t)(next_rand() % 4 ? next_rand() : (i & 1 ? WDR_PROTO_SYNC1 : WDR_PROTO_SYNC0));
    return n;
}

static void decoder_survives(void **state)
{
    (void)state;
    static wdr_proto_decoder d;
    long packets = 0, errors = 0;
    for (int round = 0; round < 2000; round++) {
        size_t n = round % 2 ? mutated_stream() : random_stream();
        wdr_proto_decoder_init(&d);
        for (size_t off = 0; off < n;) {
            size_t slice = 1 + next_rand() % 700, used;
            wdr_packet p;
            int r = wdr_proto_feed(&d, buf + off, slice < n - off ? slice : n - off, &used, &p);
            off += used;
            assert_true(d.fill <= WDR_PROTO_MAX_FRAME);
            if (r == WDR_FEED_PACKET) {
                assert_true(p.h.length <= WDR_PROTO_MAX_PAYLOAD);
                assert_int_equal(wdr_crc32(0, p.payload, p.h.length), p.h.payload_crc);
                packets++;
            } else if (r != WDR_FEED_MORE) {
                errors++;
            }
        }
    }
    print_message("decoder: %ld packets, %ld framing errors\n", packets, errors);
    assert_true(packets > 1000);
}

static wdr_fw fw;

static void firmware_survives(void **state)
{
    (void)state;
    static uint8_t lut[WDR_FW_LUT_MAX_BYTES];
    fb_init();
    th_boot(&fw);
    size_t lut_len = th_make_lut(lut, 64, 0, FB_DAC_BITS);
    assert_int_equal(th_upload(&fw, WDR_KIND_LUT, lut, (uint32_t)lut_len, 4096, NULL), WDR_ST_OK);
    for (int round = 0; round < 200; round++) {
        size_t n = round % 2 ? mutated_stream() : random_stream();
        th_send_raw(&fw, buf, n);
        uint8_t off = 0;
        th_request(&fw, WDR_CMD_STREAM, &off, 1, NULL, 0); /* a random STREAM 1 may have started one */
        uint8_t ver[4] = {WDR_PROTO_VERSION_MAJOR, 0, 0, 0};
        /* Enough zero bytes to end any frame the garbage left open, then a clean request. */
        static const uint8_t flush[WDR_PROTO_MAX_FRAME];
        th_send_raw(&fw, flush, sizeof flush);
        assert_int_equal(th_request(&fw, WDR_CMD_INFO, ver, 4, NULL, 0), WDR_ST_OK);
    }
    /* Random opcodes could have uploaded or selected nothing valid: the LUT is still there. */
    wdr_status_report s = th_status(&fw);
    assert_int_equal(s.lut_crc, wdr_crc32(0, lut, lut_len));
    print_message("firmware: %u bytes skipped, %u bad payloads\n", s.rx_skipped, s.rx_bad_crc);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(decoder_survives),
        cmocka_unit_test(firmware_survives),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
