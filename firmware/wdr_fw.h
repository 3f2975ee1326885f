/* The controller firmware: boot, the frame state machine, tables and the wire protocol.
 * The caller owns one wdr_fw (static: it holds every buffer) and drives it:
 *
 *     static wdr_fw fw;
 *     hal_init();
 *     wdr_fw_init(&fw);
 *     for (;;)
 *         if (!wdr_fw_task(&fw))
 *             hal_wait_for_event();
 *
 * Re-running wdr_fw_init on the same flash is a reboot. */
#ifndef WDR_FW_H
#define WDR_FW_H
#include "hal.h"
#include "wdr_boot.h"
#include "wdr_cal.h"
#include "wdr_fw_config.h"
#include "wdr_lut.h"
#include "wdr_proto.h"
#include "wdr_store.h"
#include <stdbool.h>
#include <stdint.h>

enum wdr_fw_state { WDR_FW_IDLE = 0, WDR_FW_RESET = 1, WDR_FW_INTEGRATE = 2, WDR_FW_READOUT = 3 };

typedef struct wdr_fw_tx {
    uint32_t words[(WDR_PROTO_MAX_FRAME + 3u) / 4u]; /* one frame; word-aligned for in-place rows */
    uint32_t len;
} wdr_fw_tx;

typedef struct wdr_fw {
    hal_board_info board;
    wdr_store store;
    int boot_err;                 /* why the store could not start (0: it did) */

    /* Active tables. The LUT lives in RAM (the DAC plays from it); the calibration table stays
     * in flash and is read a row at a time into cal_row (its shared block, if any, into cal_shared). */
    uint32_t lut_ram[2][(WDR_FW_LUT_MAX_BYTES + 3u) / 4u]; /* active and staging */
    int lut_buf;                  /* index of the active LUT's buffer */
    int lut_slot, cal_slot;       /* active slots, -1: none */
    wdr_lut_view lut;
    wdr_cal_view cal;             /* active table's header, or the identity */
    wdr_lut_view staged_lut;      /* last table that passed wdr_fw_table_check */
    wdr_cal_view staged_cal;
    uint32_t cal_row[WDR_FW_CAL_ROW_MAX_BYTES / 4u];
    /* A BASIS table's shared block is needed by every row: held in RAM, active and staging, so
     * checking a new table never disturbs the one in use. */
    float cal_shared[2][WDR_FW_CAL_SHARED_MAX_FLOATS + WDR_CAL_COMPACT_EXTRA]; /* COMPACT: + scales, offsets */
    int cal_shared_buf;           /* index of the active table's shared block */

    /* Frame sequencing */
    uint8_t state;                /* enum wdr_fw_state */
    uint32_t frames_left;         /* of the current CAPTURE */
    bool streaming;
    bool raw_frames;              /* this capture skips the calibration table (WDR_CAPTURE_RAW) */
    uint16_t capture_seq;
    uint32_t frame_no;            /* frames completed since boot */
    uint16_t row;                 /* next row to read */
    uint64_t t_start, row_deadline;
    uint32_t integration_ns;      /* 0: the LUT's own */
    uint32_t frame_time_ns;
    wdr_lut_view play;            /* the LUT as played, with the integration time in force */
    uint16_t raw[WDR_FW_MAX_WIDTH];
    bool frame_end_due;

    /* Link */
    wdr_proto_decoder dec;
    uint8_t rx[WDR_FW_RX_CHUNK];
    uint32_t rx_pos, rx_len;
    wdr_fw_tx tx[WDR_FW_TX_SLOTS];
    uint8_t tx_head, tx_count;
    bool tx_in_flight;
    uint8_t last_response[WDR_FW_RESPONSE_MAX];
    uint32_t last_response_len;   /* 0: nothing to resend */
    uint16_t last_seq;
    uint8_t last_opcode;

    /* Auto exposure (fw_expo.c): the ramp's tick follows the scene's log-average */
    wdr_lut_exposure expo, staged_expo; /* the active LUT's exposure table, and the staged one's */
    bool expo_has_table, staged_has_expo;
    bool expo_auto;               /* SET_EXPOSURE 1 */
    int32_t expo_gain_q8;         /* ln(own tick / tick in force) * 256: the scene against the LUT's key */
    int32_t expo_last_q8;         /* last frame's measured ln(L_avg / key) * 256, at the tick then in force */
    int8_t expo_last_nudge;       /* the sign of the last frame's 1/256 gap, which a halved step leaves */
    uint64_t expo_tick_q16;       /* tick the next frame plays, in 1/65536 ps */
    uint8_t expo_held;            /* WDR_EXPO_HELD_*: the limit the last step ran into, or 0 */
    uint32_t expo_min_step_ticks; /* shortest DAC step of the active LUT, in its ticks */
    uint32_t expo_hist[WDR_FW_EXPO_HIST]; /* the frame's corrected codes, code >> expo_hist_shift */
    uint8_t expo_hist_shift;      /* so that the table's codes fit the histogram */
    uint16_t expo_lo_index;       /* histogram entries from here up: at or below the floor */
    uint16_t expo_hi_index;       /* entries below here: at or above the ceiling */
    int32_t expo_lo_q8, expo_hi_q8; /* ln(I / I_key) * 256 at those two limits */
    uint16_t expo_floor_bin;      /* the table's first bin at its lowest value (the floor's flat run) */

    /* Firmware images (fw_update.c): the image flash, the upload into the slot not running,
     * and what the bootloader passed to this boot */
    bool img_ok;                  /* the image flash answered with a usable layout */
    wdr_boot_flash img_flash;     /* hal_image_flash_* */
    wdr_boot_layout img_layout;
    wdr_boot_upload img_up;       /* slot -1: no upload */
    uint32_t img_crc;             /* CRC-32 of the chunks accepted so far */
    bool booted;                  /* boot_rec holds the bootloader's record */
    wdr_boot_record boot_rec;
    bool reboot_due;              /* REBOOT answered: reset once the answer has left */
    bool reverted;                /* FW_REVERT done: the other slot is the next boot, uploads wait */
} wdr_fw;

/* Start from whatever flash holds: read the board, check every stored table, activate the
 * newest valid LUT and calibration table. Missing or broken tables are not errors. On any
 * error below the firmware still runs and answers INFO and STATUS, with no tables.
 * @retval WDR_OK
 * @retval WDR_E_IO           board identity or flash unavailable
 * @retval WDR_E_POWER        flash lost power while being read (simulated fault)
 * @retval WDR_E_UNSUPPORTED  sensor wider than WDR_FW_MAX_WIDTH or odd bit depths, or a flash
 *                            too small for four slots or with prog_size > 128 */
int wdr_fw_init(wdr_fw *fw);

/* Do the work that is ready: events, one incoming packet, one step of the frame.
 * @return 1 if something happened (call again), 0 if idle (the caller may hal_wait_for_event). */
int wdr_fw_task(wdr_fw *fw);

/* Fill a status report (what STATUS answers). */
void wdr_fw_status(const wdr_fw *fw, wdr_status_report *out);

/* Handle one decoded request as if it had arrived on the link (tests drive the firmware
 * packet by packet with it; the link calls it for every packet). */
void wdr_fw_handle(wdr_fw *fw, const wdr_packet *pkt);

/* Auto exposure (fw_expo.c). mode 0: the LUT's own tick; 1: auto.
 * @retval WDR_OK  @retval WDR_E_INVAL mode  @retval WDR_E_NO_TABLE  @retval WDR_E_UNSUPPORTED no exposure table */
int wdr_fw_set_exposure(wdr_fw *fw, uint8_t mode);
void wdr_fw_expo_reset(wdr_fw *fw);
void wdr_fw_expo_frame_start(wdr_fw *fw);
void wdr_fw_expo_row(wdr_fw *fw, const uint16_t *codes, uint16_t width);
void wdr_fw_expo_frame_end(wdr_fw *fw, bool complete);
/* The gain step for a frame whose key lies `gap` (ln * 256) from the gain in force; `last_nudge`
 * carries the sign of the previous frame's gap of one from frame to frame. */
int32_t wdr_fw_expo_step(int32_t gap, int8_t *last_nudge);

#endif
