/* The firmware on the fake board of tests/firmware, driven the way the fuzz harnesses need:
 * bounded runs (a stream never goes idle), requests with valid framing, uploads with the right
 * CRC, and tables written straight into a slot past the firmware's content check (what a
 * hostile or damaged flash holds at boot). */
#ifndef FUZZ_BOARD_H
#define FUZZ_BOARD_H
#include "fake_hal.h"
#include "wdr_fw.h"
#include <stddef.h>
#include <stdint.h>

/* Fresh board with erased flash, firmware booted. */
void fz_board_fresh(wdr_fw *fw);

/* Power-cycle and boot again on the same flash. */
void fz_board_reboot(wdr_fw *fw);

/* Run the firmware for at most `steps` task calls, draining and decoding what it sends. */
void fz_board_run(wdr_fw *fw, long steps);

/* Bytes as they come over USB, then a bounded run. */
void fz_board_send_raw(wdr_fw *fw, const uint8_t *bytes, size_t n);

/* One request, framed with the next sequence number; returns the status answered, or -1. */
int fz_board_request(wdr_fw *fw, uint8_t op, const uint8_t *payload, uint32_t len);

/* BEGIN (the table's own length and CRC), chunks, COMMIT; the first status that is not OK. */
int fz_board_upload(wdr_fw *fw, int kind, const uint8_t *table, uint32_t len);

/* Write a table into the slot an upload would use, sealed as valid, without the firmware's
 * content check; a reboot then meets it. Returns the store's error, if any. */
int fz_board_store_raw(wdr_fw *fw, int kind, const uint8_t *table, uint32_t len);

#endif
