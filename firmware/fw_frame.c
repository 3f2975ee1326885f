/* The frame state machine: IDLE -> RESET -> INTEGRATE (ramp playback) -> READOUT -> IDLE.
 * Timing follows from the LUT (integration time) and the board (row time); the HAL's timer
 * and ramp-done events move it on, so the task loop never spins waiting. */
#include "fw_internal.h"
#include "wdr_readout.h"
#include <string.h>

bool wdr_fw_busy(const wdr_fw *fw)
{
    return fw->state != WDR_FW_IDLE || fw->frames_left || fw->streaming;
}

/* ---- Integration time ----------------------------------------------------------------------- */

static uint32_t ns_to_ticks(const wdr_lut_view *lut, uint64_t ns)
{
    uint64_t t = ns * 1000u / lut->h.tick_ps;
    return t > UINT32_MAX ? UINT32_MAX : (uint32_t)t;
}

static uint32_t ticks_to_ns(const wdr_lut_view *lut, uint32_t ticks)
{
    uint64_t ns = wdr_lut_ticks_ps(lut, ticks) / 1000u;
    return ns > UINT32_MAX ? UINT32_MAX : (uint32_t)ns;
}

static uint32_t last_step_ticks(const wdr_lut_view *lut)
{
    uint32_t t;
    uint16_t code;
    wdr_lut_entry(lut, lut->h.entry_count - 1u, &t, &code);
    return t;
}

/* ns must leave room for the whole ramp: the ramp holds its last code until integration ends. */
int wdr_fw_set_integration(wdr_fw *fw, uint32_t ns)
{
    if (fw->lut_slot < 0)
        return WDR_E_NO_TABLE;
    if (ns > WDR_PROTO_MAX_INTEGRATION_NS || (ns && ns_to_ticks(&fw->lut, ns) <= last_step_ticks(&fw->lut)))
        return WDR_E_INVAL;
    fw->integration_ns = ns;
    return WDR_OK;
}

/* Auto exposure retimes the whole ramp, integration included (the override is for fixed exposure). */
static void prepare_play(wdr_fw *fw)
{
    fw->play = fw->lut;
    if (fw->expo_auto) {
        fw->play.h.tick_ps = (uint32_t)(fw->expo_tick_q16 >> 16);
        fw->play.tick_frac_q16 = (uint16_t)(fw->expo_tick_q16 & 0xffffu);
    } else if (fw->integration_ns)
        fw->play.h.t_integration_ticks = ns_to_ticks(&fw->lut, fw->integration_ns);
    wdr_fw_expo_frame_start(fw);
}

/* ---- Start and stop ------------------------------------------------------------------------- */

int wdr_fw_frame_start(wdr_fw *fw, uint32_t frames, bool stream, uint16_t seq)
{
    if (wdr_fw_busy(fw))
        return WDR_E_BUSY;
    if (fw->lut_slot < 0)
        return WDR_E_NO_TABLE;
    if (fw->cal.h.width != fw->board.width || fw->board.width == 0)
        return WDR_E_UNSUPPORTED;
    fw->frames_left = frames;
    fw->streaming = stream;
    fw->capture_seq = seq;
    fw->state = WDR_FW_RESET;
    return WDR_OK;
}

void wdr_fw_frame_stop(wdr_fw *fw)
{
    if (fw->state == WDR_FW_INTEGRATE)
        hal_ramp_stop();
    hal_row_deselect();
    fw->state = WDR_FW_IDLE;
    fw->frames_left = 0;
    fw->streaming = false;
    fw->frame_end_due = false;
}

/* ---- Steps ------------------------------------------------------------------------------------ */

/* Reset pulse, then the release of reset is t = 0 of the ramp. */
static int step_reset(wdr_fw *fw)
{
    prepare_play(fw);
    int err = hal_pixel_reset(true);
    hal_delay_ns(WDR_FW_RESET_NS);
    if (!err)
        err = hal_pixel_reset(false);
    fw->t_start = hal_time_ns();
    if (!err)
        err = hal_ramp_start(&fw->play);
    fw->row = 0;
    fw->state = err ? WDR_FW_READOUT : WDR_FW_INTEGRATE;
    fw->frame_end_due = err != 0; /* a frame that could not start ends at once, with 0 rows */
    return 1;
}

static int read_row(wdr_fw *fw)
{
    int err = hal_row_select(fw->row);
    if (!err)
        err = hal_adc_convert();
    if (!err)
        err = hal_adc_read_row(fw->raw, fw->board.width);
    hal_row_deselect();
    return err || fw->raw_frames ? err : wdr_fw_load_cal_row(fw, fw->row);
}

/* The table a row goes through: the active one, or for a raw capture the identity. */
static const wdr_cal_view *row_table(const wdr_fw *fw, wdr_cal_view *identity)
{
    if (!fw->raw_frames)
        return &fw->cal;
    uint16_t top = (uint16_t)((1u << fw->board.adc_bits) - 1u);
    if (wdr_cal_identity(identity, fw->board.sensor_id, fw->board.width, fw->board.height, 1.0f, top, top))
        return &fw->cal; /* not reached: wdr_fw_init refused such a board */
    return identity;
}

/* One row: ADC, correction in place in the outgoing frame, send. */
static int step_row(wdr_fw *fw)
{
    uint8_t *frame = wdr_fw_tx_reserve(fw);
    uint32_t len;
    int err = read_row(fw);
    wdr_cal_view identity;
    int corrected = fw->cal_slot >= 0 && !fw->raw_frames;
    if (!err)
        err = wdr_readout_row(row_table(fw, &identity), corrected ? fw->cal_row : NULL, fw->row, fw->frame_no,
                              fw->capture_seq, fw->raw, frame, &len);
    if (err) {
        fw->frame_end_due = true; /* FRAME_END reports the rows that made it */
        return 1;
    }
    wdr_fw_expo_row(fw, (const uint16_t *)(void *)(frame + WDR_PROTO_HEADER_SIZE + WDR_PROTO_ROW_HEADER),
                    fw->board.width); /* the corrected codes, as readout wrote them (LE targets) */
    wdr_fw_tx_commit_raw(fw, len);
    fw->row++;
    fw->row_deadline += fw->board.row_time_ns;
    fw->frame_end_due = fw->row == fw->board.height;
    return 1;
}

static int step_frame_end(wdr_fw *fw)
{
    uint8_t *pl = wdr_fw_tx_reserve(fw) + WDR_PROTO_HEADER_SIZE;
    int complete = fw->row == fw->board.height;
    wdr_frame_end fe = {fw->frame_no, fw->row, (uint16_t)((fw->cal_slot >= 0 && !fw->raw_frames) | (!complete << 1)),
                        ticks_to_ns(&fw->play, fw->play.h.t_integration_ticks), fw->t_start};
    wdr_frame_end_pack(&fe, pl);
    wdr_proto_header h = {WDR_CMD_FRAME_END, WDR_FLAG_EVENT, fw->capture_seq, 0, 0, 0};
    wdr_fw_tx_commit(fw, &h, WDR_FRAME_END_SIZE);
    fw->frame_no++;
    wdr_fw_expo_frame_end(fw, complete);
    fw->frame_time_ns = (uint32_t)(hal_time_ns() - fw->t_start) + WDR_FW_RESET_NS;
    fw->frame_end_due = false;
    if (!fw->streaming && fw->frames_left)
        fw->frames_left--;
    if (!complete) { /* the sensor failed: stop rather than stream broken frames */
        fw->frames_left = 0;
        fw->streaming = false;
    }
    fw->state = fw->frames_left || fw->streaming ? WDR_FW_RESET : WDR_FW_IDLE;
    return 1;
}

static int step_readout(wdr_fw *fw)
{
    if (!wdr_fw_tx_free(fw))
        return 0; /* HAL_EV_USB_TX_DONE wakes us */
    if (fw->frame_end_due)
        return step_frame_end(fw);
    if (hal_time_ns() < fw->row_deadline) {
        hal_timer_arm(fw->row_deadline);
        return 0;
    }
    return step_row(fw);
}

int wdr_fw_frame_step(wdr_fw *fw)
{
    switch (fw->state) {
    case WDR_FW_RESET: return step_reset(fw);
    case WDR_FW_READOUT: return step_readout(fw);
    default: return 0; /* IDLE, or INTEGRATE waiting for HAL_EV_RAMP_DONE */
    }
}

void wdr_fw_frame_event(wdr_fw *fw, const hal_event *ev)
{
    if (ev->type == HAL_EV_RAMP_DONE && fw->state == WDR_FW_INTEGRATE) {
        fw->state = WDR_FW_READOUT;
        fw->row_deadline = hal_time_ns();
    }
}
