/* Calibration table: layout, parsing and validation (no heap; the table stays in the caller's buffer). */
#include "wdr_cal.h"
#include "crc32.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <string.h>

/* The kernel divides by r*y + 1: a table is refused unless that stays at least this far from zero. */
#define WDR_CAL_MIN_DENOM 1e-3f

uint32_t wdr_cal_row_stride(uint16_t width, uint16_t n_coeffs)
{
    uint32_t flags = ((uint32_t)width + 3u) & ~3u;
    return (uint32_t)n_coeffs * width * 4u + flags;
}

/* COMPACT: 2 bytes a coefficient, pixel-major; the flags as in every form. */
uint32_t wdr_cal_form_row_stride(uint16_t form, uint16_t width, uint16_t n_coeffs)
{
    if (!wdr_cal_form_compact(form))
        return wdr_cal_row_stride(width, n_coeffs);
    return (uint32_t)n_coeffs * width * 2u + (((uint32_t)width + 3u) & ~3u);
}

size_t wdr_cal_size(uint16_t width, uint16_t height, uint16_t n_coeffs)
{
    return WDR_CAL_HEADER_SIZE + (size_t)height * wdr_cal_row_stride(width, n_coeffs);
}

/* COMPACT: K points of 4 functions, then the 4 coefficient scales and the 4 offsets. */
uint32_t wdr_cal_shared_bytes(const wdr_cal_header *h)
{
    if (wdr_cal_form_compact(h->form))
        return (h->shared_points * WDR_CAL_COMPACT_COEFFS + WDR_CAL_COMPACT_EXTRA) * 4u;
    return h->form == WDR_FORM_BASIS ? h->shared_points * h->n_coeffs * 4u : 0u;
}

size_t wdr_cal_size_compact(uint16_t width, uint16_t height, uint32_t shared_points)
{
    return WDR_CAL_HEADER_SIZE + (size_t)height * wdr_cal_form_row_stride(WDR_FORM_COMPACT, width, 4u) +
           ((size_t)shared_points * WDR_CAL_COMPACT_COEFFS + WDR_CAL_COMPACT_EXTRA) * 4u;
}

size_t wdr_cal_size_basis(uint16_t width, uint16_t height, uint16_t n_coeffs, uint32_t shared_points)
{
    return wdr_cal_size(width, height, n_coeffs) + (size_t)shared_points * n_coeffs * 4u;
}

int wdr_cal_form_coeffs_ok(uint16_t form, uint16_t n_coeffs)
{
    switch (form) {
    case WDR_FORM_IDENTITY:
        return n_coeffs == 0;
    case WDR_FORM_MOEBIUS:
        return n_coeffs == 3;
    case WDR_FORM_POLY:
    case WDR_FORM_BASIS:
        return n_coeffs >= 2 && n_coeffs <= WDR_CAL_MAX_COEFFS;
    case WDR_FORM_COMPACT:
    case WDR_FORM_SHIFTED:
        return n_coeffs == WDR_CAL_COMPACT_COEFFS;
    default:
        return 0;
    }
}

/* x == x rejects NaN; the bounds reject Inf. */
static int finite_f(float x) { return x == x && x < 3.0e38f && x > -3.0e38f; }

int wdr_cal_shared_check(const float *shared, uint16_t n_coeffs, uint32_t shared_points)
{
    for (uint16_t k = 0; k < n_coeffs; k++) {
        int nonzero = 0;
        for (uint32_t j = 0; j < shared_points; j++) {
            float b = shared[j * n_coeffs + k];
            if (!finite_f(b))
                return WDR_E_NUMERIC;
            nonzero |= b != 0.0f;
        }
        if (!nonzero)
            return WDR_E_NUMERIC;
    }
    return WDR_OK;
}

int wdr_cal_shared_ok(const wdr_cal_header *h, const float *shared)
{
    int err = wdr_cal_shared_check(shared, h->n_coeffs, h->shared_points);
    if (err || !wdr_cal_form_compact(h->form))
        return err;
    const float *scale = shared + (size_t)h->shared_points * WDR_CAL_COMPACT_COEFFS;
    for (uint32_t k = 0; k < WDR_CAL_COMPACT_COEFFS; k++)
        if (!finite_f(scale[k]) || !(scale[k] > 0.0f) || !finite_f(scale[WDR_CAL_COMPACT_COEFFS + k]))
            return WDR_E_NUMERIC;
    return WDR_OK;
}

int wdr_cal_identity(wdr_cal_view *v, uint32_t sensor_id, uint16_t width, uint16_t height, float out_scale,
                     uint16_t raw_max, uint16_t out_max)
{
    if (!v || width == 0 || height == 0 || width > WDR_CAL_MAX_WIDTH || !finite_f(out_scale) || !(out_scale > 0.0f))
        return WDR_E_INVAL;
    memset(v, 0, sizeof *v);
    v->h.magic = WDR_CAL_MAGIC;
    v->h.version_major = WDR_CAL_VERSION_MAJOR;
    v->h.version_minor = WDR_CAL_VERSION_MINOR;
    v->h.sensor_id = sensor_id;
    v->h.width = width;
    v->h.height = height;
    v->h.form = WDR_FORM_IDENTITY;
    v->h.in_scale = 1.0f;
    v->h.out_scale = out_scale;
    v->h.raw_max = raw_max;
    v->h.out_max = out_max;
    return WDR_OK;
}

static void header_pack(const wdr_cal_header *h, uint8_t *p)
{
    wdr_put_u32(p + 0, h->magic);
    wdr_put_u16(p + 4, h->version_major);
    wdr_put_u16(p + 6, h->version_minor);
    wdr_put_u32(p + 8, h->sensor_id);
    wdr_put_u16(p + 12, h->width);
    wdr_put_u16(p + 14, h->height);
    wdr_put_u16(p + 16, h->form);
    wdr_put_u16(p + 18, h->n_coeffs);
    wdr_put_u16(p + 20, h->model);
    wdr_put_u16(p + 22, h->operator_id);
    wdr_put_f32(p + 24, h->in_scale);
    wdr_put_f32(p + 28, h->in_offset);
    wdr_put_f32(p + 32, h->out_scale);
    wdr_put_u16(p + 36, h->out_max);
    wdr_put_u16(p + 38, h->raw_max);
    wdr_put_u32(p + 40, h->bad_pixels);
    wdr_put_u32(p + 44, h->shared_points);
    wdr_put_u32(p + 48, h->reserved);
    wdr_put_u32(p + 52, h->payload_len);
    wdr_put_u32(p + 56, h->payload_crc);
    wdr_put_u32(p + 60, h->header_crc);
}

static void header_unpack(const uint8_t *p, wdr_cal_header *h)
{
    h->magic = wdr_get_u32(p + 0);
    h->version_major = wdr_get_u16(p + 4);
    h->version_minor = wdr_get_u16(p + 6);
    h->sensor_id = wdr_get_u32(p + 8);
    h->width = wdr_get_u16(p + 12);
    h->height = wdr_get_u16(p + 14);
    h->form = wdr_get_u16(p + 16);
    h->n_coeffs = wdr_get_u16(p + 18);
    h->model = wdr_get_u16(p + 20);
    h->operator_id = wdr_get_u16(p + 22);
    h->in_scale = wdr_get_f32(p + 24);
    h->in_offset = wdr_get_f32(p + 28);
    h->out_scale = wdr_get_f32(p + 32);
    h->out_max = wdr_get_u16(p + 36);
    h->raw_max = wdr_get_u16(p + 38);
    h->bad_pixels = wdr_get_u32(p + 40);
    h->shared_points = wdr_get_u32(p + 44);
    h->reserved = wdr_get_u32(p + 48);
    h->payload_len = wdr_get_u32(p + 52);
    h->payload_crc = wdr_get_u32(p + 56);
    h->header_crc = wdr_get_u32(p + 60);
}

const float *wdr_cal_row_coeffs(const wdr_cal_view *v, int row, int k)
{
    return (const float *)(const void *)(v->payload + (size_t)row * v->row_stride + (size_t)k * v->h.width * 4u);
}

const uint32_t *wdr_cal_row_compact(const wdr_cal_view *v, int row)
{
    return (const uint32_t *)(const void *)(v->payload + (size_t)row * v->row_stride);
}

const uint8_t *wdr_cal_row_flags(const wdr_cal_view *v, int row)
{
    size_t coeff_bytes = wdr_cal_form_compact(v->h.form) ? 2u : 4u;
    return v->payload + (size_t)row * v->row_stride + (size_t)v->h.n_coeffs * v->h.width * coeff_bytes;
}

const float *wdr_cal_compact_scales(const wdr_cal_view *v)
{
    return v->shared + (size_t)v->h.shared_points * WDR_CAL_COMPACT_COEFFS;
}

static void encode_rows(const wdr_cal_header *h, const float *coeffs, const uint8_t *flags, uint8_t *rows)
{
    uint32_t stride = wdr_cal_row_stride(h->width, h->n_coeffs);
    uint8_t *payload = rows;
    memset(payload, 0, (size_t)stride * h->height);
    for (uint32_t r = 0; r < h->height; r++) {
        uint8_t *row = payload + (size_t)r * stride;
        for (uint32_t k = 0; k < h->n_coeffs; k++)
            for (uint32_t c = 0; c < h->width; c++)
                wdr_put_f32(row + 4u * (k * h->width + c), coeffs[((size_t)k * h->height + r) * h->width + c]);
        memcpy(row + (size_t)h->n_coeffs * h->width * 4u, flags + (size_t)r * h->width, h->width);
    }
}

/* Header fields that follow from the rest; the payload is in place after the header. */
static void seal(wdr_cal_header *h, uint8_t *out)
{
    h->magic = WDR_CAL_MAGIC;
    h->version_major = WDR_CAL_VERSION_MAJOR;
    /* older readers keep reading the forms they know */
    h->version_minor = h->form == WDR_FORM_SHIFTED   ? 3
                       : h->form == WDR_FORM_COMPACT ? 2
                       : h->form == WDR_FORM_BASIS   ? 1
                                                     : 0;
    h->reserved = 0;
    h->payload_len = wdr_cal_shared_bytes(h) + wdr_cal_form_row_stride(h->form, h->width, h->n_coeffs) * h->height;
    h->payload_crc = wdr_crc32(0, out + WDR_CAL_HEADER_SIZE, h->payload_len);
    header_pack(h, out);
    h->header_crc = wdr_crc32(0, out, WDR_CAL_HEADER_SIZE - 4);
    wdr_put_u32(out + 60, h->header_crc);
}

void wdr_cal_encode(wdr_cal_header *h, const float *coeffs, const uint8_t *flags, uint8_t *out)
{
    h->shared_points = 0;
    encode_rows(h, coeffs, flags, out + WDR_CAL_HEADER_SIZE);
    seal(h, out);
}

void wdr_cal_encode_basis(wdr_cal_header *h, const float *shared, const float *coeffs, const uint8_t *flags,
                          uint8_t *out)
{
    uint32_t n = h->shared_points * h->n_coeffs;
    for (uint32_t j = 0; j < n; j++)
        wdr_put_f32(out + WDR_CAL_HEADER_SIZE + 4u * j, shared[j]);
    encode_rows(h, coeffs, flags, out + WDR_CAL_HEADER_SIZE + 4u * n);
    seal(h, out);
}

/* Offset and scale of coefficient k: the middle of its range over the table, and the half-range
 * that maps to WDR_CAL_COMPACT_Q_MAX (what every pixel shares goes into the offset, so the int16
 * keep only the spread between pixels). */
static void compact_range(const float *coeffs, size_t plane, uint32_t k, float *offset, float *scale)
{
    float lo = coeffs[k * plane], hi = lo;
    for (size_t i = 1; i < plane; i++) {
        float c = coeffs[k * plane + i];
        lo = c < lo ? c : lo;
        hi = c > hi ? c : hi;
    }
    *offset = 0.5f * (lo + hi);
    float half = hi - *offset > *offset - lo ? hi - *offset : *offset - lo;
    *scale = half > 0.0f ? half / (float)WDR_CAL_COMPACT_Q_MAX : 1.0f;
}

static uint16_t compact_q(float c, float offset, float scale)
{
    float q = (c - offset) / scale;
    q = q > (float)WDR_CAL_COMPACT_Q_MAX ? (float)WDR_CAL_COMPACT_Q_MAX : q;
    q = q < -(float)WDR_CAL_COMPACT_Q_MAX ? -(float)WDR_CAL_COMPACT_Q_MAX : q;
    return (uint16_t)(int16_t)(q < 0.0f ? q - 0.5f : q + 0.5f);
}

void wdr_cal_encode_compact(wdr_cal_header *h, const float *shared, const float *coeffs, const uint8_t *flags,
                            uint8_t *out)
{
    const uint32_t n = WDR_CAL_COMPACT_COEFFS, w = h->width;
    const size_t plane = (size_t)w * h->height;
    h->form = h->form == WDR_FORM_SHIFTED ? WDR_FORM_SHIFTED : WDR_FORM_COMPACT;
    h->n_coeffs = (uint16_t)n;
    uint8_t *p = out + WDR_CAL_HEADER_SIZE;
    for (uint32_t j = 0; j < h->shared_points * n; j++, p += 4)
        wdr_put_f32(p, shared[j]);
    float scale[WDR_CAL_COMPACT_COEFFS], offset[WDR_CAL_COMPACT_COEFFS];
    for (uint32_t k = 0; k < n; k++)
        compact_range(coeffs, plane, k, &offset[k], &scale[k]);
    for (uint32_t k = 0; k < n; k++, p += 4)
        wdr_put_f32(p, scale[k]);
    for (uint32_t k = 0; k < n; k++, p += 4)
        wdr_put_f32(p, offset[k]);
    const uint32_t stride = wdr_cal_form_row_stride(WDR_FORM_COMPACT, h->width, (uint16_t)n);
    memset(p, 0, (size_t)stride * h->height);
    for (uint32_t r = 0; r < h->height; r++, p += stride) {
        for (uint32_t c = 0; c < w; c++)
            for (uint32_t k = 0; k < n; k++)
                wdr_put_u16(p + 2u * (c * n + k), compact_q(coeffs[k * plane + (size_t)r * w + c], offset[k], scale[k]));
        memcpy(p + (size_t)n * w * 2u, flags + (size_t)r * w, w);
    }
    seal(h, out);
}

static int header_check(const wdr_cal_header *h)
{
    if (h->width == 0 || h->height == 0 || h->width > WDR_CAL_MAX_WIDTH)
        return WDR_E_INVAL;
    if (h->form == WDR_FORM_IDENTITY || !wdr_cal_form_coeffs_ok(h->form, h->n_coeffs))
        return WDR_E_INVAL;
    if (h->model >= WDR_MODEL_COUNT || h->reserved || h->out_max == 0 || h->raw_max == 0)
        return WDR_E_INVAL;
    /* Products in 64 bits: shared_points comes from outside, and 0x40000001 * 4 wraps to 4 in u32. */
    if (h->form == WDR_FORM_BASIS ? h->shared_points < 2 || (uint64_t)h->shared_points * h->n_coeffs > WDR_CAL_MAX_SHARED_FLOATS
        : wdr_cal_form_compact(h->form)
            ? h->shared_points < 2 ||
                  (uint64_t)h->shared_points * WDR_CAL_COMPACT_COEFFS > WDR_CAL_MAX_SHARED_FLOATS
            : h->shared_points != 0)
        return WDR_E_INVAL;
    if (!finite_f(h->in_scale) || h->in_scale == 0.0f || !finite_f(h->in_offset))
        return WDR_E_INVAL;
    if (!finite_f(h->out_scale) || !(h->out_scale > 0.0f))
        return WDR_E_INVAL;
    /* height * row_stride reaches 8.8e9 for a 4096 x 65535 basis-8 table: compare in 64 bits. */
    if (h->payload_len !=
        wdr_cal_shared_bytes(h) + (uint64_t)h->height * wdr_cal_form_row_stride(h->form, h->width, h->n_coeffs))
        return WDR_E_INVAL;
    return WDR_OK;
}

/* Denominator r*y + 1 is linear in y and 1 at y = 0, so its value at raw_max bounds it. */
static int moebius_row_ok(const wdr_cal_view *v, int row)
{
    const float *r = wdr_cal_row_coeffs(v, row, 2);
    for (int c = 0; c < v->h.width; c++)
        if (!(r[c] * (float)v->h.raw_max + 1.0f >= WDR_CAL_MIN_DENOM))
            return 0;
    return 1;
}

static int coefficients_check(const wdr_cal_view *v)
{
    uint32_t bad = 0;
    for (int row = 0; row < v->h.height; row++) {
        for (int k = 0; !wdr_cal_form_compact(v->h.form) && k < v->h.n_coeffs; k++) { /* int16: always finite */
            const float *c = wdr_cal_row_coeffs(v, row, k);
            for (int i = 0; i < v->h.width; i++)
                if (!finite_f(c[i]))
                    return WDR_E_NUMERIC;
        }
        if (v->h.form == WDR_FORM_MOEBIUS && !moebius_row_ok(v, row))
            return WDR_E_NUMERIC;
        const uint8_t *f = wdr_cal_row_flags(v, row);
        for (int i = 0; i < v->h.width; i++)
            bad += wdr_cal_pixel_flags(v->h.form, f[i]) != 0;
    }
    return bad == v->h.bad_pixels ? WDR_OK : WDR_E_INVAL;
}

int wdr_cal_parse(const void *buf, size_t len, wdr_cal_view *out)
{
    const uint8_t *p = buf;
    if (!p || !out || ((uintptr_t)p & 3u))
        return WDR_E_INVAL;
    out->payload = NULL;
    out->shared = NULL;
    out->code_q = NULL;
    if (len < WDR_CAL_HEADER_SIZE)
        return WDR_E_TRUNCATED;
    header_unpack(p, &out->h);
    if (out->h.magic != WDR_CAL_MAGIC || out->h.header_crc != wdr_crc32(0, p, WDR_CAL_HEADER_SIZE - 4))
        return WDR_E_CORRUPT;
    if (out->h.version_major != WDR_CAL_VERSION_MAJOR)
        return WDR_E_VERSION;
    int err = header_check(&out->h);
    if (err)
        return err;
    if (len - WDR_CAL_HEADER_SIZE < out->h.payload_len)
        return WDR_E_TRUNCATED;
    uint32_t shared_bytes = wdr_cal_shared_bytes(&out->h);
    out->shared = shared_bytes ? (const float *)(const void *)(p + WDR_CAL_HEADER_SIZE) : NULL;
    out->payload = p + WDR_CAL_HEADER_SIZE + shared_bytes;
    out->row_stride = wdr_cal_form_row_stride(out->h.form, out->h.width, out->h.n_coeffs);
    out->code_q = NULL;
    out->code_shift = 0;
    out->code_sat = 0;
    if (wdr_crc32(0, p + WDR_CAL_HEADER_SIZE, out->h.payload_len) != out->h.payload_crc)
        return WDR_E_CORRUPT;
    if (out->shared && wdr_cal_shared_ok(&out->h, out->shared))
        return WDR_E_NUMERIC;
    return coefficients_check(out);
}

int wdr_cal_check_geometry(const wdr_cal_view *v, uint32_t sensor_id, uint16_t width, uint16_t height)
{
    if (v->h.sensor_id != sensor_id || v->h.width != width || v->h.height != height)
        return WDR_E_GEOMETRY;
    return WDR_OK;
}
