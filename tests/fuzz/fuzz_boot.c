/* Target boot: the slot/flash image at boot. The input is records applied to a fresh fake
 * board's flash, then a reboot, STATUS and one frame:
 *   [0][kind u8][len u16][table]   a table sealed into the next slot past the content check
 *   [1][addr u16 x 4 B][n u8][bytes] bytes written over flash at addr * 4 (torn headers,
 *                                  markers, sequence numbers, stray programmed bits)
 * so boot meets valid, half-valid and hostile slots of both kinds. */
#include "fuzz_board.h"
#include "fuzz_input.h"
#include "wdr_proto.h"
#include <string.h>

static wdr_fw fw;

static void apply(fz_input *in)
{
    while (in->left) {
        uint8_t what = fz_u8(in);
        if (what & 1) {
            uint32_t addr = (uint32_t)fz_u16(in) * 4u;
            size_t got;
            const uint8_t *p = fz_bytes(in, fz_u8(in), &got);
            if (addr + got <= (size_t)FB_BLOCK_SIZE * FB_BLOCK_COUNT)
                memcpy(fb_flash() + addr, p, got);
        } else {
            int kind = fz_u8(in) & 1 ? WDR_KIND_CAL : WDR_KIND_LUT;
            size_t got;
            const uint8_t *p = fz_bytes(in, fz_u16(in), &got);
            if (got)
                fz_board_store_raw(&fw, kind, p, (uint32_t)got);
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_input in = {data, size};
    fz_board_fresh(&fw);
    apply(&in);
    fz_board_reboot(&fw);
    fz_board_request(&fw, WDR_CMD_STATUS, NULL, 0);
    uint8_t one[4] = {1, 0, 0, 0}, newest = WDR_SLOT_NEWEST;
    fz_board_request(&fw, WDR_CMD_CAPTURE, one, 4);
    fz_board_request(&fw, WDR_CMD_LUT_SELECT, &newest, 1);
    fz_board_request(&fw, WDR_CMD_CAPTURE, one, 4);
    return 0;
}
