/* Target cal: the calibration table parser (wdr_cal_parse) and the correction kernel on a table
 * that parses; then the firmware's own stored-table check: the bytes written straight into a
 * calibration slot of the fake board, and a boot that must check them (row by row, from flash)
 * before any frame is corrected with them. */
#include "correct.h"
#include "fuzz_board.h"
#include "table_builders.h"
#include "wdr_cal.h"
#include <stdlib.h>
#include <string.h>

static wdr_fw fw;

static void correct_every_row(const wdr_cal_view *v)
{
    static uint16_t raw[WDR_CAL_MAX_WIDTH], out[WDR_CAL_MAX_WIDTH];
    static float rawf[WDR_CAL_MAX_WIDTH], outf[WDR_CAL_MAX_WIDTH];
    for (int i = 0; i < v->h.width; i++)
        raw[i] = (uint16_t)(i * 37u % (v->h.raw_max + 1u)), rawf[i] = raw[i];
    for (int r = 0; r < v->h.height && r < 64; r++) {
        wdr_correct_row(v, r, raw, out);
        wdr_correct_row_f32(v, r, rawf, outf);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    uint8_t *copy = malloc(size ? size : 1); /* 4-byte aligned, as the parser requires */
    memcpy(copy, data, size);
    wdr_cal_view v;
    if (wdr_cal_parse(copy, size, &v) == WDR_OK)
        correct_every_row(&v);
    free(copy);
    fz_board_fresh(&fw);
    if (size <= 0xffffffffu && fz_board_store_raw(&fw, WDR_KIND_CAL, data, (uint32_t)size) == WDR_OK) {
        static _Alignas(4) uint8_t lut[8192];
        size_t lut_len = th_make_lut(lut, 256, 0, FB_DAC_BITS);
        fz_board_reboot(&fw); /* the check at boot, on the stored bytes */
        fz_board_upload(&fw, WDR_KIND_LUT, lut, (uint32_t)lut_len);
        uint8_t one[4] = {1, 0, 0, 0};
        fz_board_request(&fw, WDR_CMD_CAPTURE, one, 4); /* a frame through whatever is active */
    }
    return 0;
}
