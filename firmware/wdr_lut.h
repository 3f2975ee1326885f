/* DAC ramp lookup table (LUT) format, shared by host and firmware.
 * The byte layout is written down in firmware/SPEC.md; all fields little-endian. */
#ifndef WDR_LUT_H
#define WDR_LUT_H
#include "wdr_bytes.h"
#include <stddef.h>
#include <stdint.h>

#define WDR_LUT_MAGIC 0x54554c57u /* "WLUT" */
#define WDR_LUT_VERSION_MAJOR 1
#define WDR_LUT_VERSION_MINOR 1 /* 1.1: an optional exposure block may follow the entries */
#define WDR_LUT_HEADER_SIZE 64u
#define WDR_LUT_ENTRY_SIZE 8u
#define WDR_LUT_MAX_ENTRIES 65536u
#define WDR_LUT_NPARAMS 6

enum wdr_lut_timing {
    WDR_TIMING_UNIFORM = 0, /* one entry per tick of a fixed DAC clock */
    WDR_TIMING_STAMPED = 1  /* one entry per DAC code, each with its own time stamp */
};

/* Operator ids stored in the LUT header. Never renumber: tables in flash use them. */
enum wdr_operator_id {
    WDR_OP_LINEAR = 0,
    WDR_OP_REINHARD = 1,
    WDR_OP_REINHARD_WHITE = 2,
    WDR_OP_SCHLICK = 3,
    WDR_OP_TUMBLIN_RUSHMEIER = 4,
    WDR_OP_DRAGO = 5,
    WDR_OP_EXPONENTIAL = 6,
    WDR_OP_LOGARITHMIC = 7,
    WDR_OP_USER_CURVE = 8,
    WDR_OP_COUNT
};

typedef struct wdr_lut_header {
    uint32_t magic;
    uint16_t version_major;
    uint16_t version_minor;
    uint16_t operator_id;
    uint8_t dac_bits;
    uint8_t timing;               /* enum wdr_lut_timing */
    uint32_t entry_count;
    uint32_t tick_ps;             /* one time tick, in picoseconds */
    uint32_t t_integration_ticks; /* end of integration: the ramp holds its last code until then */
    float dac_lo_v;               /* voltage of code 0 */
    float dac_hi_v;               /* voltage of code 2^bits - 1 */
    float params[WDR_LUT_NPARAMS];/* operator parameters, meaning per operator (SPEC.md) */
    uint32_t payload_crc;         /* CRC-32 of the entries */
    uint32_t header_crc;          /* CRC-32 of header bytes 0..59 */
} wdr_lut_header;

/* A parsed LUT that points into the caller's buffer (no copy). */
typedef struct wdr_lut_view {
    wdr_lut_header h;
    const uint8_t *entries;
    /* In memory only (0 from wdr_lut_parse): 1/65536 ps beyond h.tick_ps. Auto exposure plays a
     * scaled tick, and bright scenes want 16-20 ps from a 1000 ps LUT: in whole picoseconds one
     * step was 5-6 %, and the key settled up to 9 % off (Schlick, Exponential; fw_expo.c). */
    uint16_t tick_frac_q16;
} wdr_lut_view;

/* `ticks` ticks of (tick_ps + tick_frac_q16 / 65536) ps each, in ps (rounded down). */
uint64_t wdr_ticks_ps(uint32_t ticks, uint32_t tick_ps, uint16_t tick_frac_q16);

/* `ticks` of the view's tick, in ps: what every HAL times the ramp and the integration by. */
uint64_t wdr_lut_ticks_ps(const wdr_lut_view *lut, uint32_t ticks);

/* Bytes taken by a LUT with n entries. */
size_t wdr_lut_size(uint32_t entry_count);

/* Check and parse a LUT held in buf.
 * @retval WDR_OK
 * @retval WDR_E_TRUNCATED  len shorter than the header or than the entries it promises
 * @retval WDR_E_CORRUPT    bad magic, header CRC or payload CRC
 * @retval WDR_E_VERSION    major version not 1
 * @retval WDR_E_INVAL      a field out of range (bits, count, timing, times not rising) */
int wdr_lut_parse(const void *buf, size_t len, wdr_lut_view *out);

/* Entry i of a parsed LUT: its start time in ticks and its DAC code. */
void wdr_lut_entry(const wdr_lut_view *lut, uint32_t i, uint32_t *t_ticks, uint16_t *code);

/* Serialise header h (CRC fields are computed here) followed by entries into out,
 * which must hold wdr_lut_size(h->entry_count) bytes. t_ticks and codes have entry_count items. */
void wdr_lut_encode(wdr_lut_header *h, const uint32_t *t_ticks, const uint16_t *codes, uint8_t *out);

/* ---- Exposure block (LUT 1.1, optional, right after the entries) ----------------------------
 * What a corrected output code says about the light: for bin b (codes b << code_shift up to the
 * next bin), ln(I / I_key) * 256 of the current whose nominal-pixel code is b << code_shift
 * (codes between two bins interpolate linearly; the last bin and above are flat),
 * with the ramp at its own tick; I_key is the log-average current the ramp was built for; codes
 * past the sensor's floor or ceiling read its ends. The firmware histograms a frame's codes and
 * takes the log-average of the scene against the key from it (codes at an end are censored: "at
 * most" / "at least" that current) and retimes the next frame's ramp: a scene m times brighter
 * wants the tick divided by m. The first blocks had 64 bins; the host now writes 1024 (4 codes
 * each at 12 bits: 64 put the bottom decade of Reinhard in one bin). */
#define WDR_LUT_EXPO_MAGIC 0x58454c57u /* "WLEX" */
#define WDR_LUT_EXPO_BINS 64u          /* the fewest bins (the first 1.1 blocks) */
#define WDR_LUT_EXPO_MAX_BINS 1024u    /* the most: a power of two from 64 to this */
#define WDR_LUT_EXPO_DROOP 1u /* flags bit 0: a droop array follows ln_q8 */
#define WDR_LUT_EXPO_DARK 2u  /* flags bit 1: the dark current follows the arrays (i16 ln q8, u16 0) */
/* flags bit 2: past the floor the nominal pixel's code stays on the line through the floor's bin
 * and the floor's flat run down to no light (the table was cut where codes stop resolving, not
 * where pixels stop crossing): the firmware reads the dark tail from the mean of its codes */
#define WDR_LUT_EXPO_LINEAR_DARK 4u
#define WDR_LUT_EXPO_FLAGS (WDR_LUT_EXPO_DROOP | WDR_LUT_EXPO_DARK | WDR_LUT_EXPO_LINEAR_DARK)
/* Codes a pixel at a limit may read past it (noise): the firmware censors them too. The floor's
 * code is WDR_LUT_EXPO_FLOOR_CODE(first bin of the floor's flat run, code_shift) less half a code. */
#define WDR_LUT_EXPO_NOISE_CODES 4
#define WDR_LUT_EXPO_FLOOR_CODE(first_min, shift)                                                                      \
    ((first_min) > 0 ? (int32_t)(((uint32_t)(first_min)-1u) << (shift)) - WDR_LUT_EXPO_NOISE_CODES : 0)
#define WDR_LUT_EXPO_BLOCK_SIZE_FOR(bins, flags)                                                                      \
    (8u + 2u * (uint32_t)(bins) * (1u + ((flags)&1u)) + 4u * (((flags) >> 1) & 1u) + 4u)
#define WDR_LUT_EXPO_BLOCK_SIZE(bins) WDR_LUT_EXPO_BLOCK_SIZE_FOR(bins, 0u)
#define WDR_LUT_EXPO_SIZE WDR_LUT_EXPO_BLOCK_SIZE(WDR_LUT_EXPO_BINS) /* a 64-bin block */
#define WDR_LUT_EXPO_MAX_LN_Q8 8192 /* |ln_q8| at most 32 ln (e^32 = 8e13, past any sensor's range) */

typedef struct wdr_lut_exposure {
    uint8_t code_shift;                   /* bin = code >> code_shift, below bins */
    uint16_t bins;                        /* 64, 128, ..., WDR_LUT_EXPO_MAX_BINS */
    uint8_t flags;                        /* WDR_LUT_EXPO_DROOP */
    int16_t ln_q8[WDR_LUT_EXPO_MAX_BINS]; /* ln(I / I_key) in 1/256 */
    /* With WDR_LUT_EXPO_DROOP: codes (1/256) the hold droop lowers bin b's code by per unit of
     * (tick / own tick - 1): a tick m times the own holds every crossed pixel m times longer */
    int16_t droop_q8[WDR_LUT_EXPO_MAX_BINS];
    /* With WDR_LUT_EXPO_DARK: ln(I_dark / I_key) * 256, the mean dark current. The calibration
     * at the own tick takes it out, but a tick m times longer adds (m - 1) I_dark more to each
     * pixel's reading (the scene's current does not scale with the tick; its charge does). */
    int16_t dark_ln_q8;
} wdr_lut_exposure;

/* Check and read the exposure block at buf (the bytes after a LUT's entries, exactly len of them).
 * @retval WDR_OK  @retval WDR_E_TRUNCATED len < 8  @retval WDR_E_CORRUPT magic or CRC
 * @retval WDR_E_INVAL bins not a power of two in 64..WDR_LUT_EXPO_MAX_BINS, flags outside
 *                     WDR_LUT_EXPO_FLAGS, the dark field's reserved half not 0, len other than WDR_LUT_EXPO_BLOCK_SIZE_FOR(bins, flags),
 *                     code_shift above 10, or an ln_q8 outside +-WDR_LUT_EXPO_MAX_LN_Q8 */
int wdr_lut_exposure_parse(const void *buf, size_t len, wdr_lut_exposure *out);

/* The table's flat ends, as the firmware reads them and the host writes them: *floor_bin the first
 * bin at the table's lowest value (the floor lies in the bin before it), *ceiling_bin the last at
 * its highest (the ceiling lies in the bin after it); the sloped part is between them. */
void wdr_lut_exposure_flat_ends(const wdr_lut_exposure *ex, uint32_t *floor_bin, uint32_t *ceiling_bin);

/* Write the block (WDR_LUT_EXPO_BLOCK_SIZE_FOR(in->bins, in->flags) bytes, CRC computed here). */
void wdr_lut_exposure_encode(const wdr_lut_exposure *in, uint8_t *out);

#endif
