/* Calibration (fixed-pattern-noise correction) table, shared by host and firmware.
 * The byte layout is written down in firmware/SPEC.md, section "Calibration table format";
 * all fields little-endian, coefficients IEEE-754 float32.
 *
 * A table maps each pixel's raw ADC code y to a corrected value: the nominal pixel's response
 * to the photocurrent that this pixel's calibration model recovers from y. The firmware
 * evaluates it on the fly (firmware/correct.h) with one small per-pixel formula. */
#ifndef WDR_CAL_H
#define WDR_CAL_H
#include <stddef.h>
#include <stdint.h>

#define WDR_CAL_MAGIC 0x4c414357u /* "WCAL" */
#define WDR_CAL_VERSION_MAJOR 1
#define WDR_CAL_VERSION_MINOR 3 /* 1: the BASIS form and its shared block; 2: the COMPACT form;
                                  3: the SHIFTED form */
#define WDR_CAL_HEADER_SIZE 64u
#define WDR_CAL_MAX_COEFFS 8u
#define WDR_CAL_MAX_WIDTH 4096u
/* BASIS: at most this many float32 in the shared block (16 KiB), so a firmware can hold it in RAM */
#define WDR_CAL_MAX_SHARED_FLOATS 4096u
/* COMPACT: coefficients per pixel (two SMLAD pairs), and the largest stored coefficient */
#define WDR_CAL_COMPACT_COEFFS 4u
#define WDR_CAL_COMPACT_Q_MAX 32767
/* COMPACT: floats after the shared points: 4 coefficient scales, then 4 offsets */
#define WDR_CAL_COMPACT_EXTRA 8u
/* SHIFTED: the pixel byte of a zero shift, the bit that marks a flagged pixel, and the codes the
 * per-code points reach below 0 */
#define WDR_CAL_SHIFT_ZERO 64u
#define WDR_CAL_SHIFT_FLAGGED 0x80u
#define WDR_CAL_SHIFT_PAD 64u
#define WDR_CAL_SHIFT_SAT_BITS 13u /* a 12-bit ADC's shifted codes, padded to 2^13 points */

/* Per-pixel formula. Never renumber: tables in flash use these ids. */
enum wdr_cal_form {
    WDR_FORM_IDENTITY = 0, /* no coefficients: v = y */
    WDR_FORM_MOEBIUS = 1,  /* 3 coefficients p, q, r: v = (p y + q) / (r y + 1) */
    WDR_FORM_POLY = 2,     /* n coefficients c0..c(n-1), u = y * in_scale + in_offset:
                              v = c0 + c1 u + ... + c(n-1) u^(n-1)  (Horner, no divide) */
    WDR_FORM_BASIS = 3,    /* n coefficients c0..c(n-1) over n shared basis functions B_k tabulated at
                              K points (minor version 1): t = y * in_scale + in_offset clamped to
                              [0, K-1], v = sum_k c_k B_k(t), B_k interpolated linearly. The sharp
                              bends every pixel's map shares live in the shared table */
    WDR_FORM_COMPACT = 4,  /* BASIS with 4 functions and per-pixel int16 coefficients q_k (minor
                              version 2): c_k = offset_k + q_k * scale_k, 4 f32 scales and 4 f32
                              offsets after the shared points; 9 bytes per pixel, a fixed-point
                              kernel on the controller */
    WDR_FORM_SHIFTED = 5,  /* COMPACT whose flag byte also carries a per-pixel code shift (minor
                              version 3): a good pixel's byte b < 128 reads its code as
                              u = min(y + b, raw_max + 64) - 64, a flagged pixel's byte is
                              128 | flags; 9 bytes per pixel */
    WDR_FORM_COUNT
};

/* Which calibration model produced a table: informational, for reports. */
enum wdr_cal_model_id {
    WDR_MODEL_NONE = 0,
    WDR_MODEL_SIMPLE3 = 1,  /* paper eq. 16-20: y = a - b(x+d)/(1+c(x+d)) */
    WDR_MODEL_COMPLEX4 = 2, /* paper eq. 21-26: y = a - b x(1+e x)/(1+c x) */
    WDR_MODEL_LSQ = 3,      /* least squares over N currents on a physical basis (any operator) */
    WDR_MODEL_POLYMAP = 4,  /* least-squares polynomial map from pixel codes to nominal codes */
    WDR_MODEL_SPLINE = 5,   /* per-pixel monotone cubic through its own N responses, in ln x */
    WDR_MODEL_COUNT
};

/* Per-pixel flag bits: any set bit makes the kernel replace the pixel from its row neighbours. */
enum wdr_cal_pixel_flag {
    WDR_PIX_DEAD = 1u << 0,      /* responds far less than the array to light */
    WDR_PIX_STUCK = 1u << 1,     /* same output at every level */
    WDR_PIX_HOT = 1u << 2,       /* dark output far towards bright: large dark current */
    WDR_PIX_SATURATED = 1u << 3, /* at an ADC rail inside the calibrated range */
    WDR_PIX_UNFIT = 1u << 4      /* the model could not be fitted or inverted (reason in the host report) */
};

typedef struct wdr_cal_header {
    uint32_t magic;
    uint16_t version_major;
    uint16_t version_minor;
    uint32_t sensor_id;
    uint16_t width, height;
    uint16_t form;         /* enum wdr_cal_form */
    uint16_t n_coeffs;     /* per pixel: 0 (IDENTITY), 3 (MOEBIUS), 2..8 (POLY, BASIS), 4 (COMPACT) */
    uint16_t model;        /* enum wdr_cal_model_id */
    uint16_t operator_id;  /* enum wdr_operator_id of the ramp it was calibrated with */
    float in_scale;        /* POLY: u = y * in_scale + in_offset keeps u in about [-1, 1];
                              BASIS: t = y * in_scale + in_offset is the shared table's position */
    float in_offset;
    float out_scale;       /* output code = round(v * out_scale), clamped to [0, out_max] */
    uint16_t out_max;      /* largest output code */
    uint16_t raw_max;      /* largest raw ADC code (2^bits - 1) */
    uint32_t bad_pixels;   /* number of pixels with a flag set */
    uint32_t shared_points;/* BASIS, COMPACT: K, points per basis function (2..WDR_CAL_MAX_SHARED_FLOATS / n;
                              the COMPACT block holds 4 scales more);
                              zero for the other forms (minor version 0: reserved, zero) */
    uint32_t reserved;     /* zero */
    uint32_t payload_len;  /* bytes after the header: shared block + height * row_stride */
    uint32_t payload_crc;  /* CRC-32 of the payload */
    uint32_t header_crc;   /* CRC-32 of header bytes 0..59 */
} wdr_cal_header;

/* A parsed table pointing into the caller's buffer (no copy), or the identity (no buffer).
 * Row r occupies row_stride bytes at payload + r * row_stride: n_coeffs planes of width float32
 * (plane k holds coefficient k of every pixel of the row), then width flag bytes, padded to 4.
 * BASIS tables carry a shared block before the first row: K points of n float32 each, point-major
 * (shared[j * n + k] = B_k at point j), so one pixel's lookups share a cache line.
 * COMPACT rows are pixel-major instead: 4 int16 per pixel (q0 q1 q2 q3, 8 bytes, two words a
 * pixel for the kernel's SMLAD pairs), then the flags; its shared block ends with 4 f32 scales
 * and 4 f32 offsets. */
typedef struct wdr_cal_view {
    wdr_cal_header h;
    const uint8_t *payload; /* first row; NULL for the identity */
    uint32_t row_stride;
    const float *shared;    /* BASIS, COMPACT: the shared block (a firmware may point it at a RAM copy); else NULL */
    /* COMPACT after wdr_correct_per_code_compact: per raw code 4 words, the offsets' base and two
     * int16 pairs (the kernel's fixed-point points, 2^-code_shift output codes), else NULL
     * (computed per pixel) */
    const uint32_t *code_q;
    uint32_t code_shift;
    /* SHIFTED: 13 when the per-code points run on to 2^13 codes (copies of the last), so that one
     * USAT clamps a pixel's shifted code; else 0 (a compare) */
    uint32_t code_sat;
} wdr_cal_view;

/* Bytes of one row block and of a whole table (header included); wdr_cal_row_stride is the
 * float forms', wdr_cal_form_row_stride any form's (COMPACT: 8 bytes a pixel, then the flags). */
uint32_t wdr_cal_row_stride(uint16_t width, uint16_t n_coeffs);
uint32_t wdr_cal_form_row_stride(uint16_t form, uint16_t width, uint16_t n_coeffs);
size_t wdr_cal_size(uint16_t width, uint16_t height, uint16_t n_coeffs);
/* Bytes of a BASIS or COMPACT table's shared block (0 for the other forms), and of a whole BASIS
 * or COMPACT table. */
uint32_t wdr_cal_shared_bytes(const wdr_cal_header *h);
size_t wdr_cal_size_basis(uint16_t width, uint16_t height, uint16_t n_coeffs, uint32_t shared_points);
size_t wdr_cal_size_compact(uint16_t width, uint16_t height, uint32_t shared_points);

/* Coefficients needed by a form (n for POLY is the caller's choice, 2..8). */
int wdr_cal_form_coeffs_ok(uint16_t form, uint16_t n_coeffs);

/* Check a BASIS shared block: every value finite and no basis function zero at every point
 * (the per-pixel fit would be rank-deficient and its coefficients arbitrary).
 * @retval WDR_OK, WDR_E_NUMERIC */
int wdr_cal_shared_check(const float *shared, uint16_t n_coeffs, uint32_t shared_points);
/* The same for a header's form: BASIS as above; COMPACT also needs its 4 scales finite and > 0.
 * @retval WDR_OK, WDR_E_NUMERIC */
int wdr_cal_shared_ok(const wdr_cal_header *h, const float *shared);

/* The identity correction for a sensor without a table: output = raw * out_scale.
 * @retval WDR_OK
 * @retval WDR_E_INVAL  zero size, width above WDR_CAL_MAX_WIDTH, out_scale not finite and > 0 */
int wdr_cal_identity(wdr_cal_view *v, uint32_t sensor_id, uint16_t width, uint16_t height, float out_scale,
                     uint16_t raw_max, uint16_t out_max);

/* Check and parse a table held in buf; buf must be 4-byte aligned (float loads on Cortex-M7).
 * Every coefficient is checked to be finite and every MOEBIUS denominator positive over
 * [0, raw_max], a BASIS shared block by wdr_cal_shared_check, so the kernel can trust the table.
 * @retval WDR_OK
 * @retval WDR_E_TRUNCATED  len shorter than the header or than the payload it promises
 * @retval WDR_E_CORRUPT    bad magic, header CRC or payload CRC
 * @retval WDR_E_VERSION    major version not 1
 * @retval WDR_E_INVAL      a field out of range, misaligned buffer, reserved field not zero
 * @retval WDR_E_NUMERIC    a coefficient or shared value is NaN/Inf, a denominator can reach zero,
 *                          or a basis function is zero everywhere */
int wdr_cal_parse(const void *buf, size_t len, wdr_cal_view *out);

/* Check that a parsed table belongs to this sensor.
 * @retval WDR_OK, WDR_E_GEOMETRY */
int wdr_cal_check_geometry(const wdr_cal_view *v, uint32_t sensor_id, uint16_t width, uint16_t height);

/* Row accessors into a parsed table (not for the identity). wdr_cal_row_coeffs is the float
 * forms' plane k; wdr_cal_row_compact a COMPACT row's 2 words per pixel; wdr_cal_compact_scales
 * the 4 scales of a COMPACT shared block. */
const float *wdr_cal_row_coeffs(const wdr_cal_view *v, int row, int k);
const uint32_t *wdr_cal_row_compact(const wdr_cal_view *v, int row);
const uint8_t *wdr_cal_row_flags(const wdr_cal_view *v, int row);
const float *wdr_cal_compact_scales(const wdr_cal_view *v);

/* COMPACT and SHIFTED share the layout (int16 coefficients, shared block with scales, offsets). */
static inline int wdr_cal_form_compact(uint16_t form)
{
    return form == WDR_FORM_COMPACT || form == WDR_FORM_SHIFTED;
}

/* The bits of a pixel byte that say "flagged": a SHIFTED byte below 128 is a shift, not a flag. */
static inline uint8_t wdr_cal_flag_mask(uint16_t form)
{
    return form == WDR_FORM_SHIFTED ? (uint8_t)WDR_CAL_SHIFT_FLAGGED : (uint8_t)0xFFu;
}

/* A pixel's flags from its byte in the row (wdr_cal_row_flags), whatever the form. */
static inline uint8_t wdr_cal_pixel_flags(uint16_t form, uint8_t b)
{
    if (form != WDR_FORM_SHIFTED)
        return b;
    return (b & WDR_CAL_SHIFT_FLAGGED) ? (uint8_t)(b & 0x7Fu) : (uint8_t)0u;
}

/* Serialise: header h (magic, version, payload_len and CRCs are filled here) and, for each row,
 * coefficients coeffs[(k * height + row) * width + col] and flags[row * width + col], into out,
 * which must hold wdr_cal_size(...) bytes. Host side; the firmware only parses. */
void wdr_cal_encode(wdr_cal_header *h, const float *coeffs, const uint8_t *flags, uint8_t *out);
/* The same for a BASIS table (h->form, h->n_coeffs, h->shared_points set): shared holds
 * shared_points * n_coeffs values, point-major; out holds wdr_cal_size_basis(...) bytes. */
void wdr_cal_encode_basis(wdr_cal_header *h, const float *shared, const float *coeffs, const uint8_t *flags,
                          uint8_t *out);
/* The same for a COMPACT table (h->shared_points set; form and n_coeffs are filled here): shared
 * as for BASIS with 4 functions, coeffs as for wdr_cal_encode; each coefficient k is quantised to
 * int16 q = round((c - offset_k) / scale_k), offset_k the middle of c_k's range over the table and
 * scale_k its half-range / 32767 (1 if all equal). h->form SHIFTED is kept (else COMPACT is
 * set), and flags[] then holds its pixel bytes (shift + 64, or 128 | flags);
 * out holds wdr_cal_size_compact(...) bytes. */
void wdr_cal_encode_compact(wdr_cal_header *h, const float *shared, const float *coeffs, const uint8_t *flags,
                            uint8_t *out);

#endif
