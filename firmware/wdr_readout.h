/* The per-row path of READOUT, free of the HAL so that a benchmark can time exactly what the
 * firmware runs: correct one row of ADC codes with the calibration table, in place inside an
 * outgoing ROW frame, and seal the frame. float32 only. */
#ifndef WDR_READOUT_H
#define WDR_READOUT_H
#include "wdr_cal.h"
#include <stdint.h>

/* Build the ROW frame for `row` of frame `frame_no` in out (4-byte aligned, room for
 * WDR_PROTO_MAX_FRAME bytes). row_block: that row's coefficient block of a stored table
 * (4-byte aligned), or NULL when cal is the identity. *frame_len gets the frame's bytes.
 * @retval WDR_OK  @retval WDR_E_TOO_LARGE row wider than a ROW packet
 * @retval WDR_E_INVAL  the kernel refused the row (row out of range, no coefficients) */
int wdr_readout_row(const wdr_cal_view *cal, const uint32_t *row_block, uint16_t row, uint32_t frame_no,
                    uint16_t seq, const uint16_t *raw, uint8_t *out, uint32_t *frame_len);

#endif
