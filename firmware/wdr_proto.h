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
#define WDR_PROTO_VERSION_MINOR 3 /* 1.1: SET_EXPOSURE, exposure fields in STATUS; 1.2: INFO flags, new session;
                                   1.3: CAPTURE takes WDR_CAPTURE_RAW */

#define WDR_PROTO_SYNC0 0x57u /* 'W' */
#define WDR_PROTO_SYNC1 0x44u /* 'D' */
#define WDR_PROTO_HEADER_SIZE 20u
#define WDR_PROTO_CHUNK_DATA_MAX 4096u                  /* table bytes per *_CHUNK packet */
#define WDR_PROTO_MAX_PAYLOAD (WDR_PROTO_CHUNK_DATA_MAX + 32u)
#define WDR_PROTO_MAX_FRAME (WDR_PROTO_HEADER_SIZE + WDR_PROTO_MAX_PAYLOAD)
#define WDR_PROTO_ROW_HEADER 8u                         /* frame u32, row u16, width u16 */
#define WDR_PROTO_MAX_ROW_WIDTH ((WDR_PROTO_MAX_PAYLOAD - WDR_PROTO_ROW_HEADER) / 2u)

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
    WDR_ST_FLASH = 14         /* flash refused an operation */
};

enum wdr_table_kind { WDR_KIND_LUT = 1, WDR_KIND_CAL = 2 };

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
#define WDR_INFO_SIZE 68u
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
    uint8_t exposure_flags;     /* bit 0: the active LUT has an exposure table */
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
/* @retval WDR_OK  @retval WDR_E_TRUNCATED len < WDR_INFO_SIZE */
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

#endif
