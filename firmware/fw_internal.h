/* The firmware's internal interface: what its files (fw_*.c) call of each other. Nothing
 * outside firmware/ includes it; programs and tests use wdr_fw.h. */
#ifndef WDR_FW_INTERNAL_H
#define WDR_FW_INTERNAL_H
#include "wdr_fw.h"

/* Content checks and activation (fw_tables.c). */
void wdr_fw_tables_boot(wdr_fw *fw);
int wdr_fw_table_check(wdr_fw *fw, int kind, int slot, uint32_t len);
void wdr_fw_table_activate(wdr_fw *fw, int kind, int slot);
int wdr_fw_load_cal_row(wdr_fw *fw, uint16_t row);

/* Outgoing frames (fw_link.c). */
uint8_t *wdr_fw_tx_reserve(wdr_fw *fw);
void wdr_fw_tx_commit(wdr_fw *fw, const wdr_proto_header *h, uint32_t len);
void wdr_fw_tx_commit_raw(wdr_fw *fw, uint32_t frame_len);
int wdr_fw_tx_free(const wdr_fw *fw);
void wdr_fw_tx_kick(wdr_fw *fw);
void wdr_fw_tx_done(wdr_fw *fw);
int wdr_fw_rx_service(wdr_fw *fw);

/* Requests (fw_cmd.c) and frames (fw_frame.c). */
void wdr_fw_reply(wdr_fw *fw, const wdr_proto_header *req, int status, const uint8_t *payload, uint32_t len);
int wdr_fw_frame_start(wdr_fw *fw, uint32_t frames, bool stream, uint16_t seq);
void wdr_fw_frame_stop(wdr_fw *fw);
int wdr_fw_frame_step(wdr_fw *fw);
bool wdr_fw_busy(const wdr_fw *fw);
void wdr_fw_frame_event(wdr_fw *fw, const hal_event *ev);
int wdr_fw_set_integration(wdr_fw *fw, uint32_t ns);

/* Firmware images (fw_update.c): the image flash and the boot record at boot, the FW_* and
 * REBOOT requests, INFO's image fields, and the reset once REBOOT's answer has left. */
void wdr_fw_update_boot(wdr_fw *fw);
void wdr_fw_update_abort(wdr_fw *fw);
bool wdr_fw_update_open(const wdr_fw *fw);
void wdr_fw_update_info(const wdr_fw *fw, wdr_info *in);
void wdr_fw_cmd_fw_begin(wdr_fw *fw, const wdr_packet *pkt);
void wdr_fw_cmd_fw_chunk(wdr_fw *fw, const wdr_packet *pkt);
void wdr_fw_cmd_fw_commit(wdr_fw *fw, const wdr_packet *pkt);
void wdr_fw_cmd_fw_status(wdr_fw *fw, const wdr_packet *pkt);
void wdr_fw_cmd_fw_confirm(wdr_fw *fw, const wdr_packet *pkt);
void wdr_fw_cmd_fw_revert(wdr_fw *fw, const wdr_packet *pkt);
void wdr_fw_cmd_reboot(wdr_fw *fw, const wdr_packet *pkt);
int wdr_fw_reboot_service(wdr_fw *fw);

#endif
