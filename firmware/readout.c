/* READOUT's per-row work: correction into the frame buffer, then the frame header. */
#include "wdr_readout.h"
#include "correct.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include "wdr_proto.h"

/* A stored table's row block seen as row 0 of a one-row table: the kernel indexes rows from
 * the payload, and only this row is in RAM. */
static int correct_block(const wdr_cal_view *cal, const uint32_t *row_block, const uint16_t *raw, uint16_t *px)
{
    wdr_cal_view rv = *cal;
    rv.h.height = 1;
    rv.payload = (const uint8_t *)row_block;
    return wdr_correct_row(&rv, 0, raw, px);
}

int wdr_readout_row(const wdr_cal_view *cal, const uint32_t *row_block, uint16_t row, uint32_t frame_no,
                    uint16_t seq, const uint16_t *raw, uint8_t *out, uint32_t *frame_len)
{
    if (cal->h.width > WDR_PROTO_MAX_ROW_WIDTH)
        return WDR_E_TOO_LARGE;
    uint8_t *pl = out + WDR_PROTO_HEADER_SIZE;
    uint16_t *px = (uint16_t *)(void *)(pl + WDR_PROTO_ROW_HEADER); /* LE targets: wdr_fw_config.h */
    int err = row_block ? correct_block(cal, row_block, raw, px) : wdr_correct_row(cal, row, raw, px);
    if (err)
        return err;
    wdr_put_u32(pl, frame_no);
    wdr_put_u16(pl + 4, row);
    wdr_put_u16(pl + 6, cal->h.width);
    wdr_proto_header h = {WDR_CMD_ROW, WDR_FLAG_EVENT, seq, 0, 0, 0};
    *frame_len = (uint32_t)wdr_proto_seal(out, &h, WDR_PROTO_ROW_HEADER + 2u * cal->h.width);
    return WDR_OK;
}
