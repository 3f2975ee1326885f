/* Boot and the task loop: the two entry points a program's main calls. */
#include "fw_internal.h"
#include <string.h>

/* What the store must match, from the board; 0 if the firmware can drive this sensor. */
static int board_supported(const hal_board_info *b)
{
    if (b->width == 0 || b->height == 0 || b->width > WDR_FW_MAX_WIDTH)
        return WDR_E_UNSUPPORTED;
    if (b->adc_bits < 1 || b->adc_bits > 16 || b->dac_bits < 4 || b->dac_bits > 16)
        return WDR_E_UNSUPPORTED;
    return WDR_OK;
}

int wdr_fw_init(wdr_fw *fw)
{
    memset(fw, 0, sizeof *fw);
    wdr_proto_decoder_init(&fw->dec);
    fw->boot_err = hal_board_info_get(&fw->board);
    if (!fw->boot_err)
        fw->boot_err = board_supported(&fw->board);
    if (!fw->boot_err) {
        wdr_store_id id = {fw->board.sensor_id, fw->board.width, fw->board.height, fw->board.dac_bits,
                           fw->board.adc_bits};
        fw->boot_err = wdr_store_init(&fw->store, &id, WDR_FW_LUT_MAX_BYTES);
    }
    wdr_fw_tables_boot(fw);
    wdr_fw_update_boot(fw);
    return fw->boot_err;
}

/* The host went away or reset the bus: half a packet and queued answers mean nothing now. */
static void link_reset(wdr_fw *fw)
{
    wdr_proto_decoder_init(&fw->dec);
    fw->rx_pos = fw->rx_len = 0;
    fw->last_response_len = 0;
}

static void dispatch(wdr_fw *fw, const hal_event *ev)
{
    switch (ev->type) {
    case HAL_EV_USB_TX_DONE: wdr_fw_tx_done(fw); break;
    case HAL_EV_RAMP_DONE: case HAL_EV_TIMER: wdr_fw_frame_event(fw, ev); break;
    case HAL_EV_USB_RESET: link_reset(fw); break;
    default: break; /* HAL_EV_USB_RX: wdr_fw_rx_service polls the endpoint anyway */
    }
}

int wdr_fw_task(wdr_fw *fw)
{
    int worked = 0;
    hal_event ev;
    hal_watchdog_feed(); /* a loop that stops coming here is a hang: the watchdog resets the board */
    while (hal_event_poll(&ev)) {
        dispatch(fw, &ev);
        worked = 1;
        /* REBOOT's answer has just left: reset before the link is polled again, as a real
         * board vanishes from the bus (a host reconnecting must meet the new boot) */
        if (wdr_fw_reboot_service(fw))
            return 0;
    }
    if (!fw->reboot_due) /* resetting: a request now would be answered by a board about to vanish */
        worked |= wdr_fw_rx_service(fw);
    worked |= wdr_fw_frame_step(fw);
    if (wdr_fw_reboot_service(fw))
        return 0; /* the answer was dropped (no host): reset all the same */
    return worked;
}

void wdr_fw_status(const wdr_fw *fw, wdr_status_report *r)
{
    memset(r, 0, sizeof *r);
    r->state = fw->state;
    r->lut_slot = fw->lut_slot < 0 ? WDR_SLOT_NONE : (uint8_t)fw->lut_slot;
    r->cal_slot = fw->cal_slot < 0 ? WDR_SLOT_NONE : (uint8_t)fw->cal_slot;
    r->upload_kind = wdr_fw_update_open(fw) ? (uint8_t)WDR_KIND_FW : fw->store.up_kind;
    r->lut_seq = fw->lut_slot < 0 ? 0 : fw->store.slot[0][fw->lut_slot].seq;
    r->cal_seq = fw->cal_slot < 0 ? 0 : fw->store.slot[1][fw->cal_slot].seq;
    r->lut_crc = fw->lut_slot < 0 ? 0 : fw->store.slot[0][fw->lut_slot].crc;
    r->cal_crc = fw->cal_slot < 0 ? 0 : fw->store.slot[1][fw->cal_slot].crc;
    r->upload_received = wdr_fw_update_open(fw) ? fw->img_up.received : fw->store.up_received;
    r->frames = fw->frame_no;
    r->integration_ns = fw->expo_auto ? 0 : fw->integration_ns;
    /* the wire's tick is whole picoseconds (rounded); the integration counts the fraction */
    uint64_t tick_q16 = fw->expo_auto ? fw->expo_tick_q16 : fw->lut_slot >= 0 ? (uint64_t)fw->lut.h.tick_ps << 16 : 0;
    r->tick_ps = (uint32_t)((tick_q16 + 32768u) >> 16);
    if (!r->integration_ns && fw->lut_slot >= 0)
        r->integration_ns = (uint32_t)(wdr_ticks_ps(fw->lut.h.t_integration_ticks, (uint32_t)(tick_q16 >> 16),
                                                    (uint16_t)(tick_q16 & 0xffffu)) /
                                       1000u);
    r->exposure_auto = fw->expo_auto;
    r->exposure_flags = (uint8_t)(fw->expo_has_table | (fw->expo_auto ? fw->expo_held : 0u));
    r->key_gain_q8 = fw->expo_gain_q8;
    r->last_error_q8 = fw->expo_last_q8;
    r->frame_time_ns = fw->frame_time_ns;
    r->time_ns = hal_time_ns();
    r->rx_skipped = fw->dec.skipped;
    r->rx_bad_crc = fw->dec.bad_payloads;
}
