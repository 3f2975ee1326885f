/* Wire protocol between host and board: the same bytes over USB bulk or the simulator's
 * socket. Framing, opcodes, status codes and payload layouts are written down in
 * firmware/SPEC.md ("Wire protocol"); this codec is shared by firmware and host (no heap).
 *
 * A frame is a 20-byte header and a payload of at most WDR_PROTO_MAX_PAYLOAD bytes:
 *   0 sync 'W' 'D' | 2 opcode | 3 flags | 4 seq u16 | 6 status u8 | 7 reserved 0
 *   8 length u32 | 12 payload CRC-32 | 16 header CRC-32 of bytes 0..15
 * All integers little-endian. */
#ifndef WDR_PROTO_H
#define WDR_PROTO_H
#include <stddef.h>
#include <stdint.h>

#define WDR_PROTO_VERSION_MAJOR 1
#define WDR_PROTO_VERSION_MINOR 4 /* 1.1: SET_EXPOSURE, exposure fields in STATUS; 1.2: INFO flags, new session;
                                   1.3: CAPTURE takes WDR_CAPTURE_RAW; 1.4: firmware update (FW_*, REBOOT),
                                   INFO's image version */

#define WDR_PROTO_SYNC0 0x57u /* 'W' */
#define WDR_PROTO_SYNC1 0x44u /* 'D' */
#define WDR_PROTO_HEADER_SIZE 20u
#define WDR_PROTO_CHUNK_DATA_MAX 4096u                  /* table bytes per *_CHUNK packet */
#define WDR_PROTO_MAX_PAYLOAD (WDR_PROTO_CHUNK_DATA_MAX + 32u)
#define WDR_PROTO_MAX_FRAME (WDR_PROTO_HEADER_SIZE + WDR_PROTO_MAX_PAYLOAD)
#define WDR_PROTO_ROW_HEADER 8u                         /* frame u32, row u16, width u16 */
#define WDR_PROTO_MAX_ROW_WIDTH ((WDR_PROTO_MAX_PAYLOAD - WDR_PROTO_ROW_HEADER) / 2u)

/* Limits of the INFO and STATUS fields a host sizes its buffers and waits with (SPEC.md, "Field
 * limits"): a board outside them is refused at connect, before it costs memory or time. */
#define WDR_PROTO_MAX_HEIGHT 8192u                 /* rows of a sensor (width: WDR_PROTO_MAX_ROW_WIDTH) */
#define WDR_PROTO_MAX_ROW_TIME_NS 10000000u        /* 10 ms a row */
#define WDR_PROTO_MAX_READOUT_NS 10000000000ull    /* height x row time: 10 s a frame's readout */
#define WDR_PROTO_MAX_INTEGRATION_NS 4000000000u   /* 4 s; SET_INTEGRATION refuses more (BAD_ARG) */

/* Opcodes. Requests go host -> board and get exactly one response with the same opcode,
 * the same seq and WDR_FLAG_RESPONSE. Never renumber. */
enum wdr_cmd {
    WDR_CMD_INFO = 0x01,            /* version check and board identity */
    WDR_CMD_STATUS = 0x02,          /* state, active tables, counters */
    WDR_CMD_LUT_BEGIN = 0x10,       /* start a LUT upload into the inactive slot */
    WDR_CMD_LUT_CHUNK = 0x11,
    WDR_CMD_LUT_COMMIT = 0x12,      /* check, mark committed, activate; answers the stored CRC */
    WDR_CMD_LUT_SELECT = 0x13,      /* play the LUT of slot A, B or the newest */
    WDR_CMD_CAL_BEGIN = 0x20,
    WDR_CMD_CAL_CHUNK = 0x21,
    WDR_CMD_CAL_COMMIT = 0x22,
    WDR_CMD_SET_INTEGRATION = 0x30, /* integration time in ns; 0: the LUT's own */
    WDR_CMD_CAPTURE = 0x31,         /* N frames, streamed as ROW and FRAME_END packets */
    WDR_CMD_STREAM = 0x32,          /* 1: capture frames until 0 */
    WDR_CMD_ABORT = 0x33,           /* stop a capture or stream, drop an upload */
    WDR_CMD_SET_EXPOSURE = 0x34,    /* u8 0: the LUT's own tick, 1: auto exposure */
    WDR_CMD_FW_BEGIN = 0x50,        /* 1.4: start an image upload into the slot not running */
    WDR_CMD_FW_CHUNK = 0x51,
    WDR_CMD_FW_COMMIT = 0x52,       /* verify (hash, key, signature, board, counter), mark pending */
    WDR_CMD_FW_STATUS = 0x53,       /* both slots, the running one, the last reset's cause */
    WDR_CMD_FW_CONFIRM = 0x54,      /* the running test image stays */
    WDR_CMD_FW_REVERT = 0x55,       /* give up the running image; the next boot runs the other */
    WDR_CMD_REBOOT = 0x56,          /* answer, then reset */
    WDR_CMD_SIM_SET_ILLUMINANT = 0x70, /* simulation only: uniform photocurrent */
    WDR_CMD_ROW = 0x40,             /* board -> host, unsolicited: one corrected row */
    WDR_CMD_FRAME_END = 0x41        /* board -> host, unsolicited: a frame is complete */
};

enum wdr_proto_flags {
    WDR_FLAG_RESPONSE = 0x01, /* answer to the request with the same seq */
    WDR_FLAG_EVENT = 0x02     /* unsolicited (ROW, FRAME_END); seq is the CAPTURE/STREAM seq */
};

/* Status byte of a response. 0 is success; everything else says why nothing changed. */
enum wdr_status {
    WDR_ST_OK = 0,
    WDR_ST_BUSY = 1,          /* capture or stream running */
    WDR_ST_BAD_CRC = 2,       /* payload CRC, or uploaded table's CRC, does not match */
    WDR_ST_BAD_SEQUENCE = 3,  /* chunk offset not the next one, or no upload begun */
    WDR_ST_TOO_LARGE = 4,     /* payload or table larger than the limit or the slot */
    WDR_ST_BAD_GEOMETRY = 5,  /* table made for another sensor id, size or DAC */
    WDR_ST_NO_TABLE = 6,      /* no valid LUT (or chosen slot empty) */
    WDR_ST_UNSUPPORTED = 7,   /* unknown opcode, or board cannot do it */
    WDR_ST_BAD_KIND = 8,      /* table of another kind (a LUT sent as calibration, ...) */
    WDR_ST_BAD_LENGTH = 9,    /* payload length wrong for the opcode */
    WDR_ST_BAD_VERSION = 10,  /* protocol or table major version differs */
    WDR_ST_TRUNCATED = 11,    /* commit before all declared bytes arrived */
    WDR_ST_BAD_TABLE = 12,    /* table content fails its format's checks */
    WDR_ST_BAD_ARG = 13,      /* a field out of range */
    WDR_ST_FLASH = 14,        /* flash refused an operation */
    /* 1.4: firmware images */
    WDR_ST_BAD_SIGNATURE = 15, /* the image's signature does not verify */
    WDR_ST_BAD_KEY = 16,      /* signed by a key the board does not trust */
    WDR_ST_DOWNGRADE = 17,    /* security counter below the board's floor */
    WDR_ST_BAD_HASH = 18,     /* SHA-256 of the image differs from its trailer */
    WDR_ST_BAD_BOARD = 19,    /* image for another board */
    WDR_ST_BAD_STATE = 20,    /* not now: upload while a test image runs, confirm with nothing to confirm, ... */
    WDR_ST_BAD_IMAGE = 21     /* image structure (header, trailer, sizes) out of range */
};

/* STATUS exposure_flags (1.1): the limit that holds auto exposure's key short of the scene. */
enum wdr_expo_held { WDR_EXPO_HELD_DAC_RATE = 2, WDR_EXPO_HELD_INTEGRATION = 4 };

enum wdr_table_kind { WDR_KIND_LUT = 1, WDR_KIND_CAL = 2, WDR_KIND_FW = 3 /* STATUS upload_kind only */ };

typedef struct wdr_proto_header {
    uint8_t opcode;      /* enum wdr_cmd */
    uint8_t flags;
    uint16_t seq;
    uint8_t status;      /* enum wdr_status; 0 in requests */
    uint32_t length;     /* payload bytes */
    uint32_t payload_crc;
} wdr_proto_header;

/* A decoded packet; payload points into the decoder and lives until the next feed. */
typedef struct wdr_packet {
    wdr_proto_header h;
    const uint8_t *payload;
} wdr_packet;

/* Streaming decoder: feed any byte slices, get whole packets. Caller owns it. */
typedef struct wdr_proto_decoder {
    uint8_t buf[WDR_PROTO_MAX_FRAME];
    uint32_t fill;          /* bytes held in buf */
    uint32_t pending;       /* bytes of the packet handed out last, released on the next feed */
    uint32_t skipped;       /* bytes dropped while hunting for a valid header */
    uint32_t bad_payloads;  /* frames with a good header and a bad payload CRC */
} wdr_proto_decoder;

/* What one wdr_proto_feed call produced. */
enum wdr_feed_result {
    WDR_FEED_MORE = 0,      /* all bytes taken, no packet yet */
    WDR_FEED_PACKET = 1,    /* *out holds a valid packet */
    WDR_FEED_BAD_CRC = 2,   /* *out.h is valid, the payload CRC is not: answer BAD_CRC */
    WDR_FEED_TOO_LARGE = 3  /* *out.h is valid, length > WDR_PROTO_MAX_PAYLOAD: answer TOO_LARGE */
};

void wdr_proto_decoder_init(wdr_proto_decoder *d);

/* Take bytes from data[0..len) until one result is ready; *used gets how many were taken
 * (call again with the rest). Garbage before or inside a frame is skipped: the decoder
 * resynchronises on the next sync pair whose header CRC holds.
 * @return enum wdr_feed_result */
int wdr_proto_feed(wdr_proto_decoder *d, const uint8_t *data, size_t len, size_t *used, wdr_packet *out);

/* Write a frame (header with both CRCs, then the payload) into out; payload may be NULL when
 * len is 0. @return bytes written, or 0 if cap is too small or len > WDR_PROTO_MAX_PAYLOAD. */
size_t wdr_proto_encode(uint8_t *out, size_t cap, const wdr_proto_header *h, const void *payload, uint32_t len);

/* Fill out's header for a payload already placed at out + WDR_PROTO_HEADER_SIZE (no copy).
 * @return frame bytes, or 0 if len > WDR_PROTO_MAX_PAYLOAD. */
size_t wdr_proto_seal(uint8_t *out, const wdr_proto_header *h, uint32_t len);

/* Short English name of a status, for messages. */
const char *wdr_status_name(int status);

/* Status that answers a firmware error code (enum wdr_err). */
int wdr_status_from_err(int err);

/* ---- Payload layouts (offsets in SPEC.md) ------------------------------------------------ */

/* CAPTURE's optional flags byte (protocol 1.1). RAW: frames as the ADC gave them, with no
 * calibration table applied and no table changed (calibration measures through it). */
#define WDR_CAPTURE_RAW 0x01u
#define WDR_BEGIN_SIZE 8u        /* total_len u32, crc32 u32 of the whole table */
#define WDR_CHUNK_OFFSET_SIZE 4u /* offset u32, then 1..WDR_PROTO_CHUNK_DATA_MAX table bytes */
#define WDR_COMMIT_REPLY_SIZE 12u
#define WDR_INFO_SIZE 76u        /* 1.4: image patch and build appended */
#define WDR_INFO_SIZE_1_3 68u
#define WDR_STATUS_SIZE 68u
#define WDR_STATUS_SIZE_1_0 52u /* what a 1.0 board sends: the exposure fields read as 0 */
#define WDR_FRAME_END_SIZE 20u
#define WDR_SLOT_NEWEST 0xffu    /* LUT_SELECT: the newest valid slot */
#define WDR_SLOT_NONE 0xffu      /* STATUS: no valid table of that kind */
#define WDR_INFO_CAP_ILLUMINANT 0x1u
/* INFO request: u16 major, u16 minor, then (1.2) u32 flags */
#define WDR_INFO_REQUEST_SIZE 8u
#define WDR_INFO_FLAG_NEW_SESSION 0x1u /* stop any capture or stream, drop an upload in progress */

typedef struct wdr_info {
    uint16_t proto_major, proto_minor;
    uint16_t fw_major, fw_minor;
    uint32_t sensor_id;
    uint16_t width, height;
    uint8_t adc_bits, dac_bits;
    uint16_t caps;              /* WDR_INFO_CAP_* */
    uint32_t max_payload;
    uint32_t lut_capacity;      /* largest LUT a slot holds, bytes */
    uint32_t cal_capacity;      /* largest calibration table a slot holds, bytes */
    uint32_t row_time_ns;
    char name[32];              /* NUL-terminated */
    /* 1.4: fw_major.fw_minor.fw_patch+fw_build is the running image's version (0 build and
     * the built-in constants when the board did not boot a signed image) */
    uint16_t fw_patch;
    uint8_t fw_slot;            /* slot running, WDR_SLOT_NONE: not booted from a slot */
    uint8_t fw_flags;           /* bit 0: test boot (unconfirmed) */
    uint32_t fw_build;
} wdr_info;

typedef struct wdr_status_report {
    uint8_t state;              /* firmware state machine: 0 idle, 1 reset, 2 integrate, 3 readout */
    uint8_t lut_slot, cal_slot; /* active slot 0 (A) or 1 (B), or WDR_SLOT_NONE */
    uint8_t upload_kind;        /* enum wdr_table_kind of the upload in progress, or 0 */
    uint32_t lut_seq, cal_seq;  /* sequence numbers of the active tables */
    uint32_t lut_crc, cal_crc;  /* CRC-32 of the active tables' bytes */
    uint32_t upload_received;   /* bytes of the upload in progress */
    uint32_t frames;            /* frames completed since boot */
    uint32_t integration_ns;    /* integration time in force */
    uint32_t frame_time_ns;     /* reset + integration + readout of the last frame */
    uint64_t time_ns;           /* board clock */
    uint32_t rx_skipped;        /* garbage bytes dropped by the decoder */
    uint32_t rx_bad_crc;        /* frames dropped for a bad payload CRC */
    /* 1.1: exposure */
    uint8_t exposure_auto;      /* 1: auto exposure on */
    uint8_t exposure_flags;     /* bit 0: the active LUT has an exposure table; bit 1 (WDR_EXPO_HELD_DAC_RATE):
                                 * the key is held short of a brighter scene by the DAC's rate; bit 2
                                 * (WDR_EXPO_HELD_INTEGRATION): short of a darker one by the longest integration */
    int32_t key_gain_q8;        /* ln(scene log-average / LUT's key) * 256 in force: the tick is the LUT's / e^(gain/256) */
    uint32_t tick_ps;           /* DAC tick in force */
    int32_t last_error_q8;      /* last frame's measured ln(L_avg / key) * 256, before the correction */
} wdr_status_report;

typedef struct wdr_commit_reply {
    uint32_t crc;   /* CRC-32 of the table as read back from flash */
    uint32_t seq;   /* its slot sequence number */
    uint8_t slot;   /* 0 (A) or 1 (B) */
} wdr_commit_reply;

typedef struct wdr_frame_end {
    uint32_t frame;
    uint16_t rows;
    uint16_t flags;             /* bit 0: a calibration table corrected the rows */
    uint32_t integration_ns;
    uint64_t t_start_ns;        /* board time at the release of reset */
} wdr_frame_end;

void wdr_info_pack(const wdr_info *in, uint8_t *out);
/* @retval WDR_OK  @retval WDR_E_TRUNCATED len < WDR_INFO_SIZE_1_3 (a 1.3 board: image fields 0,
 * fw_slot WDR_SLOT_NONE) */
int wdr_info_unpack(const uint8_t *p, size_t len, wdr_info *out);
void wdr_status_pack(const wdr_status_report *in, uint8_t *out);
/* @retval WDR_OK  @retval WDR_E_TRUNCATED len < WDR_STATUS_SIZE_1_0 (a 1.0 report: exposure fields 0) */
int wdr_status_unpack(const uint8_t *p, size_t len, wdr_status_report *out);
void wdr_commit_pack(const wdr_commit_reply *in, uint8_t *out);
/* @retval WDR_OK  @retval WDR_E_TRUNCATED */
int wdr_commit_unpack(const uint8_t *p, size_t len, wdr_commit_reply *out);
void wdr_frame_end_pack(const wdr_frame_end *in, uint8_t *out);
/* @retval WDR_OK  @retval WDR_E_TRUNCATED */
int wdr_frame_end_unpack(const uint8_t *p, size_t len, wdr_frame_end *out);

/* ---- Firmware update (1.4) ------------------------------------------------------------------
 * FW_BEGIN: as LUT_BEGIN (u32 whole-image length, u32 CRC-32). FW_CHUNK: as LUT_CHUNK.
 * FW_COMMIT: no payload; answers u8 slot, 3 reserved, then the 64-byte image header on OK.
 * FW_STATUS: no payload; answers wdr_fw_status_report. CONFIRM, REVERT, REBOOT: no payload. */
#define WDR_FW_COMMIT_REPLY_SIZE 68u
#define WDR_FW_SLOT_REPORT_SIZE 56u
#define WDR_FW_STATUS_SIZE (24u + 2u * WDR_FW_SLOT_REPORT_SIZE)
#define WDR_FW_STATUS_F_DEV_KEY 0x1u   /* the board trusts the development key: not for production */
#define WDR_FW_STATUS_F_TESTING 0x2u   /* the running image is a test boot */
#define WDR_FW_STATUS_F_NO_BOOT 0x4u   /* not booted by the bootloader (no image flash, or a debug load) */

typedef struct wdr_fw_slot_report {
    uint8_t state;              /* enum wdr_slot_state (firmware/boot/wdr_boot.h) */
    uint8_t attempts;           /* test boots so far */
    uint8_t reject_reason;      /* enum wdr_boot_reject when rejected */
    int8_t verify_err;          /* enum wdr_err of its verification, 0: verified */
    uint8_t ver_major, ver_minor;
    uint16_t ver_patch;
    uint32_t ver_build;
    uint32_t security_counter;
    uint32_t image_size;        /* application bytes */
    uint8_t sha256[32];         /* from its trailer (zero when none parsed) */
} wdr_fw_slot_report;

typedef struct wdr_fw_status_report {
    uint8_t running;            /* slot running, or WDR_SLOT_NONE */
    uint8_t reset_cause;        /* enum wdr_reset_cause of the last reset */
    uint8_t flags;              /* WDR_FW_STATUS_F_* */
    uint8_t max_attempts;       /* test boots before a revert */
    uint32_t fault_pc;          /* last reset a fault: where */
    uint32_t fault_status;      /* last reset a fault: CFSR */
    uint32_t floor;             /* security counter floor */
    uint32_t boots;             /* resets since power-on */
    uint8_t key_hash[4];        /* first bytes of the trusted key's SHA-256 */
    wdr_fw_slot_report slot[2];
} wdr_fw_status_report;

void wdr_fw_status_pack(const wdr_fw_status_report *in, uint8_t *out);
/* @retval WDR_OK  @retval WDR_E_TRUNCATED len < WDR_FW_STATUS_SIZE */
int wdr_fw_status_unpack(const uint8_t *p, size_t len, wdr_fw_status_report *out);

#endif
