/* LUT binary format: write, read, CRC, and refusal of damaged tables. */
#include "crc32.h"
#include "wdr_lut.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "test_support.h"
#include <string.h>

static uint8_t *make_lut(size_t *len, uint32_t n)
{
    uint32_t ticks[64];
    uint16_t codes[64];
    for (uint32_t i = 0; i < n; i++) {
        ticks[i] = i * 10;
        codes[i] = (uint16_t)(100 + i);
    }
    wdr_lut_header h = {.operator_id = WDR_OP_REINHARD, .dac_bits = 12, .timing = WDR_TIMING_STAMPED,
                        .entry_count = n, .tick_ps = 1000, .t_integration_ticks = n * 10, .dac_lo_v = 0,
                        .dac_hi_v = 3.3f, .params = {0.18f}};
    *len = wdr_lut_size(n);
    uint8_t *buf = malloc(*len);
    wdr_lut_encode(&h, ticks, codes, buf);
    return buf;
}

static void round_trip(void **state)
{
    (void)state;
    size_t len;
    uint8_t *buf = make_lut(&len, 40);
    wdr_lut_view v;
    assert_int_equal(wdr_lut_parse(buf, len, &v), WDR_OK);
    assert_int_equal(v.h.entry_count, 40);
    assert_int_equal(v.h.operator_id, WDR_OP_REINHARD);
    assert_true(v.h.params[0] == 0.18f && v.h.dac_hi_v == 3.3f);
    for (uint32_t i = 0; i < 40; i++) {
        uint32_t t;
        uint16_t c;
        wdr_lut_entry(&v, i, &t, &c);
        assert_int_equal(t, i * 10);
        assert_int_equal(c, 100 + i);
    }
    assert_int_equal(wdr_crc32(0, "123456789", 9), 0xCBF43926u); /* the CRC-32 check value */
    free(buf);
}

static void damaged_tables_are_refused(void **state)
{
    (void)state;
    size_t len;
    uint8_t *buf = make_lut(&len, 40);
    wdr_lut_view v;
    for (size_t cut = 0; cut < len; cut += 7) /* every truncation */
        assert_int_equal(wdr_lut_parse(buf, cut, &v), WDR_E_TRUNCATED);
    for (size_t i = 0; i < len; i++) { /* every single-bit flip */
        buf[i] ^= 0x10;
        assert_int_equal(wdr_lut_parse(buf, len, &v), WDR_E_CORRUPT);
        buf[i] ^= 0x10;
    }
    buf[4] = 2; /* major version 2, with a valid header CRC */
    wdr_put_u32(buf + 60, wdr_crc32(0, buf, 60));
    assert_int_equal(wdr_lut_parse(buf, len, &v), WDR_E_VERSION);
    free(buf);
}

/* Valid CRCs but impossible content: entries not rising in time, codes beyond the DAC. */
static void inconsistent_content_is_refused(void **state)
{
    (void)state;
    uint32_t ticks[3] = {0, 20, 10};
    uint16_t codes[3] = {1, 2, 3};
    wdr_lut_header h = {.dac_bits = 12, .entry_count = 3, .tick_ps = 1000, .t_integration_ticks = 30,
                        .dac_hi_v = 3.3f};
    uint8_t buf[64 + 3 * 8];
    wdr_lut_view v;
    wdr_lut_encode(&h, ticks, codes, buf);
    assert_int_equal(wdr_lut_parse(buf, sizeof buf, &v), WDR_E_INVAL);
    ticks[2] = 25;
    codes[2] = 4096;
    wdr_lut_encode(&h, ticks, codes, buf);
    assert_int_equal(wdr_lut_parse(buf, sizeof buf, &v), WDR_E_INVAL);
    codes[2] = 4095;
    h.t_integration_ticks = 25;
    wdr_lut_encode(&h, ticks, codes, buf);
    assert_int_equal(wdr_lut_parse(buf, sizeof buf, &v), WDR_E_INVAL);
    h.t_integration_ticks = 26;
    wdr_lut_encode(&h, ticks, codes, buf);
    assert_int_equal(wdr_lut_parse(buf, sizeof buf, &v), WDR_OK);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(round_trip),
        cmocka_unit_test(damaged_tables_are_refused),
        cmocka_unit_test(inconsistent_content_is_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
