/* Target fw_rx: the firmware's receive path, bytes as from USB, through all of its command
 * handling on the fake board. First byte even: the rest is the raw byte stream. Odd: the rest
 * is records the harness frames with valid CRCs (so the fuzzer gets past the codec):
 *   [op u8][len u16][payload]       one request (op 0xff: upload, payload = kind u8 + table)
 * A good LUT and calibration table are active first, so frames and corrections run too. */
#include "fuzz_board.h"
#include "fuzz_input.h"
#include "table_builders.h"
#include "wdr_proto.h"
#include <stdint.h>
#include <string.h>

static wdr_fw fw;

static void preload_tables(void)
{
    static _Alignas(4) uint8_t lut[8192], cal[64 + FB_HEIGHT * (FB_WIDTH * 12 + FB_WIDTH)];
    static size_t lut_len, cal_len;
    if (!lut_len) {
        lut_len = th_make_lut(lut, 256, 0, FB_DAC_BITS);
        cal_len = th_make_cal(cal, 0.5f, 3.0f, FB_SENSOR_ID, FB_WIDTH, FB_HEIGHT);
    }
    fz_board_upload(&fw, WDR_KIND_LUT, lut, (uint32_t)lut_len);
    fz_board_upload(&fw, WDR_KIND_CAL, cal, (uint32_t)cal_len);
}

static void structured(fz_input *in)
{
    while (in->left) {
        uint8_t op = fz_u8(in);
        uint16_t len = fz_u16(in);
        size_t got;
        const uint8_t *p = fz_bytes(in, len, &got);
        if (op == 0xff && got >= 1)
            fz_board_upload(&fw, p[0] & 1 ? WDR_KIND_CAL : WDR_KIND_LUT, p + 1, (uint32_t)got - 1);
        else
            fz_board_request(&fw, op, p, (uint32_t)got);
    }
}

/* The board with both tables, from a flash image taken once (uploading them every time cost
 * most of each run): a reboot then checks and activates them as on a real board. */
static void board_with_tables(void)
{
    static uint8_t image[FB_BLOCK_SIZE * FB_BLOCK_COUNT];
    static int have_image;
    if (!have_image) {
        fz_board_fresh(&fw);
        preload_tables();
        memcpy(image, fb_flash(), sizeof image);
        have_image = 1;
    }
    fb_init();
    memcpy(fb_flash(), image, sizeof image);
    fz_board_reboot(&fw);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_input in = {data, size};
    uint8_t mode = fz_u8(&in);
    board_with_tables();
    if (mode & 1)
        structured(&in);
    else
        fz_board_send_raw(&fw, in.p, in.left);
    /* Whatever came before, the board still answers and survives a reboot. */
    fz_board_request(&fw, WDR_CMD_STATUS, NULL, 0);
    fz_board_reboot(&fw);
    return 0;
}
