/* The boot chain's flash logic, shared by the bootloader (boot_main_arm.c, the simulated
 * board), the firmware's update commands (fw_update.c) and the tests: the image flash's
 * layout, each slot's append-only state log, the security-counter floor, the boot decision,
 * and uploads into a slot. No HAL calls: the caller passes its flash as wdr_boot_flash, so the
 * same code runs over the NOR emulator, a PSRAM region or hal_image_flash_*.
 * Byte layouts and rules: SPEC.md, "Image flash and boot". The caller owns every struct. */
#ifndef WDR_BOOT_H
#define WDR_BOOT_H
#include "hal.h"
#include "wdr_image.h"
#include <stdbool.h>
#include <stdint.h>

/* ---- The image flash ---------------------------------------------------------------------- */

typedef struct wdr_boot_flash {
    hal_flash_geometry geo; /* block_size a power of two; prog_size <= WDR_BOOT_RECORD_SIZE */
    void *ctx;
    /* each returns WDR_OK or a negative wdr_err (WDR_E_IO, WDR_E_POWER, WDR_E_INVAL) */
    int (*read)(void *ctx, uint32_t addr, void *buf, uint32_t len);
    int (*erase)(void *ctx, uint32_t block);
    int (*prog)(void *ctx, uint32_t addr, const void *buf, uint32_t len);
} wdr_boot_flash;

#define WDR_BOOT_RECORD_SIZE 16u  /* one state or floor record; a multiple of prog_size */
#define WDR_BOOT_RECORD_MAGIC 0x54534257u /* "WBST" */
#define WDR_BOOT_FLOOR_BLOCKS 2u
#define WDR_BOOT_MAX_ATTEMPTS 3u  /* test boots of an unconfirmed image before it is rejected */

/* Where things are, from the geometry: blocks 0-1 the floor log, then two equal slots, each
 * its image blocks followed by one state block. */
typedef struct wdr_boot_layout {
    uint32_t block_size, prog_size;
    uint32_t floor_addr[WDR_BOOT_FLOOR_BLOCKS];
    uint32_t slot_addr[2];       /* first byte of the slot's image */
    uint32_t state_addr[2];      /* the slot's state block */
    uint32_t image_capacity;     /* largest whole image (header + app + trailer) a slot holds */
} wdr_boot_layout;

/* @retval WDR_OK  @retval WDR_E_UNSUPPORTED fewer than 6 blocks, or prog_size does not divide
 * WDR_BOOT_RECORD_SIZE */
int wdr_boot_layout_init(wdr_boot_layout *l, const hal_flash_geometry *g);

/* ---- State records (append-only, one program operation each) ------------------------------ */

enum wdr_boot_record_type {
    WDR_REC_BEGIN = 1,     /* an upload started here (value: declared image bytes) */
    WDR_REC_PENDING = 2,   /* the upload verified; boot it once as a test (value: security counter) */
    WDR_REC_ATTEMPT = 3,   /* the bootloader started a test boot (value: attempt number, from 1) */
    WDR_REC_CONFIRMED = 4, /* the running image passed its self-test / was confirmed */
    WDR_REC_REJECTED = 5,  /* never boot this slot again (value: enum wdr_boot_reject) */
    WDR_REC_FLOOR = 6      /* floor log only: security counter floor (value) */
};

enum wdr_boot_reject {
    WDR_REJECT_UNCONFIRMED = 1, /* WDR_BOOT_MAX_ATTEMPTS test boots without a confirmation */
    WDR_REJECT_REVERTED = 2,    /* `wdrctl fw revert` */
    WDR_REJECT_INVALID = 3      /* its verification failed at boot */
};

/* What a slot is, from its log and its image. */
enum wdr_slot_state {
    WDR_SLOT_EMPTY = 0,      /* no image header (erased, or an upload that never began) */
    WDR_SLOT_INCOMPLETE = 1, /* an upload began and did not verify: never booted */
    WDR_SLOT_PENDING = 2,    /* verified upload waiting for its first test boot */
    WDR_SLOT_TESTING = 3,    /* test-booted, not confirmed yet (attempts counts the boots) */
    WDR_SLOT_CONFIRMED = 4,  /* confirmed, or a factory image (valid image and an empty log) */
    WDR_SLOT_REJECTED = 5,   /* reverted or given up: never booted again */
    WDR_SLOT_INVALID = 6     /* a log says bootable, but the image fails verification */
};

/* What must hold for an image to run on this board. */
typedef struct wdr_boot_policy {
    const char *board;                        /* board name the header must carry */
    const uint8_t *pubkey;                    /* WDR_P256_PUBKEY_SIZE bytes, the embedded key */
    uint32_t load_lo, load_hi;                /* application must lie in [load_lo, load_hi) */
    bool check_signature;                     /* false only in the measured "hash only" build */
} wdr_boot_policy;

typedef struct wdr_boot_slot {
    uint8_t state;           /* enum wdr_slot_state */
    uint8_t attempts;        /* ATTEMPT records */
    uint8_t reject_reason;   /* enum wdr_boot_reject, when REJECTED */
    int verify_err;          /* WDR_OK, or why the image fails (wdr_image_verify's codes);
                                WDR_E_STATE: not verified (EMPTY, INCOMPLETE, REJECTED) */
    bool has_header;         /* hdr parsed */
    wdr_image_header hdr;
    uint8_t sha256[WDR_SHA256_SIZE]; /* from the trailer, when it parsed */
    uint32_t log_next;       /* offset in the state block of the first unused record */
} wdr_boot_slot;

/* Read one slot: its log and a full verification of its image against pol and the floor.
 * A slot whose log says it never boots (INCOMPLETE, REJECTED) is not verified, only its header
 * and trailer parsed (hdr, sha256 for fw status), so a boot costs one verification per
 * bootable slot. @retval WDR_OK (whatever the state)  @retval WDR_E_IO  @retval WDR_E_POWER */
int wdr_boot_slot_read(const wdr_boot_flash *f, const wdr_boot_layout *l, int slot,
                       const wdr_boot_policy *pol, uint32_t floor, wdr_boot_slot *out);

/* Append one record to a slot's state log. @retval WDR_OK  @retval WDR_E_TOO_LARGE log full
 * @retval WDR_E_IO  @retval WDR_E_POWER */
int wdr_boot_log_append(const wdr_boot_flash *f, const wdr_boot_layout *l, int slot, uint8_t type, uint32_t value);

/* ---- Security counter floor ---------------------------------------------------------------- */

/* The floor: the largest FLOOR record in either floor block (0 when none).
 * @retval WDR_OK  @retval WDR_E_IO  @retval WDR_E_POWER */
int wdr_boot_floor_read(const wdr_boot_flash *f, const wdr_boot_layout *l, uint32_t *floor);

/* Raise the floor to value (nothing when it is already there); compacts into the other block
 * when one is full, writing the maximum there before erasing anything.
 * @retval WDR_OK  @retval WDR_E_IO  @retval WDR_E_POWER */
int wdr_boot_floor_raise(const wdr_boot_flash *f, const wdr_boot_layout *l, uint32_t value);

/* ---- Verification ------------------------------------------------------------------------- */

/* Check the image at addr (at most capacity bytes) in this order: header structure, board,
 * load range, trailer structure, SHA-256 of header and application, key hash, signature,
 * security counter >= floor. hdr and trl get what parsed.
 * @retval WDR_OK  @retval WDR_E_CORRUPT no image (bad magic)  @retval WDR_E_VERSION
 * @retval WDR_E_INVAL a field out of range  @retval WDR_E_TOO_LARGE does not fit the slot
 * @retval WDR_E_BOARD another board  @retval WDR_E_HASH digest differs
 * @retval WDR_E_KEY signed by another key  @retval WDR_E_SIGNATURE  @retval WDR_E_DOWNGRADE
 * @retval WDR_E_IO  @retval WDR_E_POWER */
int wdr_image_verify(const wdr_boot_flash *f, uint32_t addr, uint32_t capacity, const wdr_boot_policy *pol,
                     uint32_t floor, wdr_image_header *hdr, wdr_image_trailer *trl);

/* ---- The boot decision ---------------------------------------------------------------------- */

typedef struct wdr_boot_decision {
    int slot;                /* slot to run, or -1: nothing bootable */
    bool testing;            /* it is a test boot (an ATTEMPT was recorded) */
    wdr_boot_slot slots[2];  /* what was found (after the records this decision wrote) */
    uint32_t floor;
} wdr_boot_decision;

/* The bootloader's whole decision, at every reset: a PENDING or TESTING slot with fewer than
 * WDR_BOOT_MAX_ATTEMPTS attempts gets an ATTEMPT record and runs; one that has used them up
 * gets REJECTED (unconfirmed); otherwise the valid CONFIRMED slot of the newest version runs
 * (slot A on a tie). A slot whose log says bootable but whose image fails gets REJECTED
 * (invalid). Every record is written before the decision is returned, so a cut at any point
 * repeats a decision that is at least as safe. A record the flash refuses (log full, a program
 * failing with WDR_E_IO) makes it more careful, never fails it: that slot is not test-booted or
 * is passed over, and a floor raise that fails is left to the next boot.
 * @retval WDR_OK (see out->slot)  @retval WDR_E_IO a read failed  @retval WDR_E_POWER */
int wdr_boot_decide(const wdr_boot_flash *f, const wdr_boot_layout *l, const wdr_boot_policy *pol,
                    wdr_boot_decision *out);

/* ---- Uploads (the firmware, into the slot that is not running) ------------------------------ */

typedef struct wdr_boot_upload {
    int slot;                /* -1: none in progress */
    uint32_t len, crc;       /* declared whole-image bytes and CRC-32 */
    uint32_t received, programmed, erased_to; /* offsets within the slot's image */
    uint8_t tail[WDR_BOOT_RECORD_SIZE];
    uint32_t tail_fill;
} wdr_boot_upload;

/* Start an upload into slot: erase its first image block (the old header goes first), then
 * its state block, then append BEGIN. @retval WDR_OK  @retval WDR_E_INVAL len 0 or slot
 * @retval WDR_E_TOO_LARGE len > image_capacity  @retval WDR_E_IO  @retval WDR_E_POWER */
int wdr_boot_upload_begin(const wdr_boot_flash *f, const wdr_boot_layout *l, wdr_boot_upload *u, int slot,
                          uint32_t len, uint32_t crc);

/* Program the next n bytes at offset (erasing each block just before its first byte).
 * @retval WDR_OK  @retval WDR_E_SEQUENCE none in progress or offset != received
 * @retval WDR_E_TOO_LARGE past len (both leave the upload open at u->received)
 * @retval WDR_E_IO  @retval WDR_E_POWER (the upload ends: begin again) */
int wdr_boot_upload_chunk(const wdr_boot_flash *f, const wdr_boot_layout *l, wdr_boot_upload *u, uint32_t offset,
                          const uint8_t *data, uint32_t n);

/* Program the tail, check length and CRC, verify the image (wdr_image_verify against pol and
 * the floor), then append PENDING. On any failure the slot stays INCOMPLETE and the upload ends.
 * @retval WDR_OK  @retval WDR_E_SEQUENCE  @retval WDR_E_TRUNCATED  @retval WDR_E_CORRUPT CRC
 * @retval wdr_image_verify's codes  @retval WDR_E_IO  @retval WDR_E_POWER */
int wdr_boot_upload_finish(const wdr_boot_flash *f, const wdr_boot_layout *l, wdr_boot_upload *u,
                           const wdr_boot_policy *pol, wdr_image_header *hdr);

void wdr_boot_upload_abort(wdr_boot_upload *u);

/* The running slot passed its self-test: append CONFIRMED, then raise the floor to its
 * security counter. @retval WDR_OK (also when already confirmed)  @retval WDR_E_STATE not
 * testing or pending  @retval WDR_E_IO  @retval WDR_E_POWER */
int wdr_boot_confirm(const wdr_boot_flash *f, const wdr_boot_layout *l, const wdr_boot_policy *pol, int slot);

/* Give up the running slot (REJECTED, reverted) so the next boot runs the other one; refused
 * when the other slot holds no valid confirmed image (the board would boot nothing).
 * @retval WDR_OK  @retval WDR_E_STATE nothing to revert to  @retval WDR_E_IO  @retval WDR_E_POWER */
int wdr_boot_revert(const wdr_boot_flash *f, const wdr_boot_layout *l, const wdr_boot_policy *pol, int running);

/* ---- What the bootloader tells the application (RAM kept across resets) --------------------- */

enum wdr_reset_cause {
    WDR_RESET_POWER_ON = 0,  /* no record survived: power-on or a cold start */
    WDR_RESET_SOFTWARE = 1,  /* REBOOT, or hal_reset by the firmware */
    WDR_RESET_WATCHDOG = 2,  /* the watchdog expired: a hang */
    WDR_RESET_FAULT = 3,     /* a HardFault (fault_pc, fault_status say where and why) */
    WDR_RESET_UNKNOWN = 4
};

#define WDR_BOOT_RECORD_MAGIC_RAM 0x43524257u /* "WBRC" */

typedef struct wdr_boot_record {
    uint32_t magic;          /* WDR_BOOT_RECORD_MAGIC_RAM */
    uint8_t slot;            /* slot running (0 A, 1 B) */
    uint8_t testing;         /* 1: a test boot, confirm it or it reverts */
    uint8_t reset_cause;     /* enum wdr_reset_cause of the reset that led here */
    uint8_t attempts;        /* test boots so far, this one included */
    uint32_t fault_pc;       /* WDR_RESET_FAULT: stacked PC of the fault (WATCHDOG: where it hung) */
    uint32_t fault_status;   /* WDR_RESET_FAULT: CFSR (or 0 where none) */
    uint32_t boots;          /* resets since power-on */
    uint32_t floor;          /* security counter floor at boot */
    uint64_t boot_ns;        /* bootloader time (reset to jump), ns, where known */
    wdr_image_header hdr;    /* the running image's header */
    uint32_t crc;            /* CRC-32 of everything before it */
} wdr_boot_record;

/* Seal / check a record's CRC and magic. The writer memsets the record to 0 before filling it
 * (the CRC covers its padding bytes too). */
void wdr_boot_record_seal(wdr_boot_record *r);
bool wdr_boot_record_ok(const wdr_boot_record *r);

/* ---- The key this build trusts (-DWDR_SIGNING_KEY, firmware/boot/wdr_boot_key.cmake) -------- */

/* The embedded public key, WDR_P256_PUBKEY_SIZE bytes (0x04 || X || Y): pol->pubkey. */
const uint8_t *wdr_boot_key(void);
/* true when it is the tree's development key: NOT FOR PRODUCTION (fw status says so). */
bool wdr_boot_key_is_dev(void);

/* Short English names, for messages and fw status. */
const char *wdr_slot_state_name(int state);
const char *wdr_reset_cause_name(int cause);

#endif
