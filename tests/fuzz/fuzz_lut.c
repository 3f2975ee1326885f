/* Target lut: the LUT parser (firmware/lut.c), on the input as a table, then what the host
 * does with a LUT that parses (entries read, the calibration margin added). */
#include "cal_engine.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    wdr_lut_view v;
    if (wdr_lut_parse(data, size, &v) != WDR_OK)
        return 0;
    uint32_t t, last_t = 0;
    uint16_t c;
    for (uint32_t i = 0; i < v.h.entry_count; i++) {
        wdr_lut_entry(&v, i, &t, &c);
        if (i && t <= last_t)
            abort(); /* the parser promised rising times */
        last_t = t;
    }
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
    return 0;
}
