/* Flash table store: two slots (A/B) per table kind, written so that a power cut at any
 * erase or program leaves the previous table or the new one valid, never a mix.
 * Byte layout and rules: SPEC.md, "Flash slot format". Caller owns the struct. */
#ifndef WDR_STORE_H
#define WDR_STORE_H
#include "hal.h"
#include <stdint.h>

#define WDR_SLOT_MAGIC 0x544c5357u        /* "WSLT" */
#define WDR_SLOT_MARKER_MAGIC 0x544d4357u /* "WCMT" */
#define WDR_SLOT_VERSION_MAJOR 1
#define WDR_SLOT_VERSION_MINOR 0
#define WDR_SLOT_HEADER_SIZE 64u
#define WDR_SLOT_MARKER_OFFSET 128u
#define WDR_SLOT_DATA_OFFSET 256u
#define WDR_SLOT_MAX_PROG 128u            /* header and marker must not share a program unit */
#define WDR_STORE_KINDS 2                 /* index kind - 1: 0 LUT, 1 CAL */

/* What a table must match to be valid on this board. */
typedef struct wdr_store_id {
    uint32_t sensor_id;
    uint16_t width, height;
    uint8_t dac_bits, adc_bits;
} wdr_store_id;

typedef struct wdr_slot {
    uint32_t addr;      /* first byte of the slot */
    uint32_t capacity;  /* largest table it holds */
    uint8_t valid;      /* header, marker and CRC checked (content is checked by the caller) */
    uint32_t seq, length, crc;
} wdr_slot;

typedef struct wdr_store {
    hal_flash_geometry geo;
    wdr_store_id id;
    wdr_slot slot[WDR_STORE_KINDS][2];
    /* upload in progress (kind 0: none) */
    uint8_t up_kind, up_slot;
    uint32_t up_len, up_crc, up_received, up_programmed, up_seq;
    uint32_t up_erased;              /* address up to which the slot's blocks are erased */
    uint8_t tail[WDR_SLOT_MAX_PROG]; /* bytes held back until a whole program unit is there */
    uint32_t tail_fill;
    uint8_t scratch[WDR_SLOT_DATA_OFFSET];
} wdr_store;

/* Partition the flash and check every slot's header, marker and data CRC.
 * lut_max: largest LUT to store.
 * @retval WDR_OK  @retval WDR_E_IO  @retval WDR_E_POWER
 * @retval WDR_E_UNSUPPORTED  geometry cannot hold four slots, or prog_size > WDR_SLOT_MAX_PROG */
int wdr_store_init(wdr_store *st, const wdr_store_id *id, uint32_t lut_max);

/* Check one slot again from flash (sets its valid flag). @retval WDR_OK (valid or not), WDR_E_IO, WDR_E_POWER */
int wdr_store_scan_slot(wdr_store *st, int kind, int slot);

/* The slot to pick at boot: the newest valid one not excluded (exclude -1: none). -1 if none. */
int wdr_store_newest(const wdr_store *st, int kind, int exclude);

/* Start an upload of len bytes whose CRC-32 is crc into the slot that is not active, and
 * erase its first block (the rest are erased as chunks reach them). @retval WDR_OK  @retval WDR_E_INVAL len 0
 * @retval WDR_E_TOO_LARGE len > capacity  @retval WDR_E_IO  @retval WDR_E_POWER */
int wdr_store_begin(wdr_store *st, int kind, int active_slot, uint32_t len, uint32_t crc);

/* Program the next n bytes at offset. @retval WDR_OK  @retval WDR_E_SEQUENCE no upload or
 * offset != bytes received  @retval WDR_E_KIND upload of another kind
 * @retval WDR_E_TOO_LARGE past the declared length  @retval WDR_E_IO  @retval WDR_E_POWER */
int wdr_store_chunk(wdr_store *st, int kind, uint32_t offset, const uint8_t *data, uint32_t n);

/* Program the held-back tail and check the stored bytes against the declared length and CRC.
 * On success the data sits, unmarked, in slot up_slot for the caller's content check.
 * @retval WDR_OK  @retval WDR_E_SEQUENCE no upload  @retval WDR_E_KIND
 * @retval WDR_E_TRUNCATED fewer bytes than declared  @retval WDR_E_CORRUPT CRC differs
 * @retval WDR_E_IO  @retval WDR_E_POWER */
int wdr_store_finish(wdr_store *st, int kind);

/* Program header then commit marker of the finished upload, read them back, end the upload.
 * @retval WDR_OK  @retval WDR_E_SEQUENCE  @retval WDR_E_CORRUPT read-back failed
 * @retval WDR_E_IO  @retval WDR_E_POWER */
int wdr_store_seal(wdr_store *st);

/* Forget the upload in progress (its slot stays invalid). */
void wdr_store_abort(wdr_store *st);

/* Read n bytes at offset off of the table data of a slot (what follows its header), within the
 * slot's capacity: the table code names a slot, never its flash address.
 * @retval WDR_OK  @retval WDR_E_INVAL outside the slot  @retval WDR_E_IO  @retval WDR_E_POWER */
int wdr_store_read(const wdr_store *st, int kind, int slot, uint32_t off, void *buf, uint32_t n);

/* Length of the table a valid slot holds (0: none). */
uint32_t wdr_store_length(const wdr_store *st, int kind, int slot);

/* A slot whose content failed the caller's checks: no longer a candidate for newest. */
void wdr_store_forget(wdr_store *st, int kind, int slot);

/* CRC-32 of len bytes of table data in a slot, read back from flash.
 * @retval WDR_OK  @retval WDR_E_IO  @retval WDR_E_POWER */
int wdr_store_data_crc(wdr_store *st, const wdr_slot *s, uint32_t len, uint32_t *crc);

#endif
