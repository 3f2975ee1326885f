/* Target lut: the LUT parser (firmware/lut.c), on the input as a table, then what the host
 * does with a LUT that parses (entries read, the exposure block parsed, the calibration margin
 * added). The harness writes the CRCs the input's layout calls for (the entries' CRC in the
 * header, the header's own, and an exposure block's when the length says there is one), so
 * mutations reach the checks behind them: with raw bytes, 20 M executions stayed at 60 edges,
 * stopped by the header CRC. The CRC refusals themselves are tested by tests/firmware. */
#include "cal_engine.h"
#include "crc32.h"
#include "wdr_bytes.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <stdlib.h>
#include <string.h>

/* A copy of the input with its CRCs right; NULL if too short for a header (parsed as is). */
static uint8_t *with_crcs(const uint8_t *data, size_t size)
{
    if (size < WDR_LUT_HEADER_SIZE)
        return NULL;
    uint8_t *p = malloc(size);
    if (!p)
        return NULL;
    memcpy(p, data, size);
    uint32_t entries = wdr_get_u32(p + 12);
    size_t body = size - WDR_LUT_HEADER_SIZE;
    size_t table = entries <= body / WDR_LUT_ENTRY_SIZE ? (size_t)entries * WDR_LUT_ENTRY_SIZE : body;
    wdr_put_u32(p + 56, wdr_crc32(0, p + WDR_LUT_HEADER_SIZE, table));
    wdr_put_u32(p + 60, wdr_crc32(0, p, WDR_LUT_HEADER_SIZE - 4));
    if (body == table + WDR_LUT_EXPO_SIZE) {
        uint8_t *ex = p + WDR_LUT_HEADER_SIZE + table;
        wdr_put_u32(ex + WDR_LUT_EXPO_SIZE - 4, wdr_crc32(0, ex, WDR_LUT_EXPO_SIZE - 4));
    }
    return p;
}

static void use_lut(const uint8_t *data, size_t size)
{
    wdr_lut_view v;
    if (wdr_lut_parse(data, size, &v) != WDR_OK)
        return;
    uint32_t t, last_t = 0;
    uint16_t c;
    for (uint32_t i = 0; i < v.h.entry_count; i++) {
        wdr_lut_entry(&v, i, &t, &c);
        if (i && t <= last_t)
            abort(); /* the parser promised rising times */
        last_t = t;
    }
    size_t end = wdr_lut_size(v.h.entry_count);
    wdr_lut_exposure ex;
    if (size == end + WDR_LUT_EXPO_SIZE && wdr_lut_exposure_parse(data + end, WDR_LUT_EXPO_SIZE, &ex) == WDR_OK)
        for (uint32_t b = 0; b < WDR_LUT_EXPO_BINS; b++)
            if (ex.ln_q8[b] < -WDR_LUT_EXPO_MAX_LN_Q8 || ex.ln_q8[b] > WDR_LUT_EXPO_MAX_LN_Q8)
                abort(); /* the parser promised bounded exposure values */
    uint8_t *out = NULL;
    size_t out_len = 0;
    double added, done;
    char err[256];
    if (wdr_cal_lut_extend(data, size, 0.01, 0.5, &out, &out_len, &added, &done, err, sizeof err) == WDR_OK) {
        wdr_lut_view e;
        if (wdr_lut_parse(out, out_len, &e) != WDR_OK)
            abort(); /* an extension of a valid LUT must be a valid LUT */
    }
    free(out);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    uint8_t *fixed = with_crcs(data, size);
    use_lut(fixed ? fixed : data, size);
    free(fixed);
    return 0;
}
