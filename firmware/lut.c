#include "wdr_lut.h"
#include "crc32.h"
#include "wdr_err.h"
#include <string.h>

size_t wdr_lut_size(uint32_t entry_count)
{
    return WDR_LUT_HEADER_SIZE + (size_t)entry_count * WDR_LUT_ENTRY_SIZE;
}

static void header_pack(const wdr_lut_header *h, uint8_t *p)
{
    wdr_put_u32(p + 0, h->magic);
    wdr_put_u16(p + 4, h->version_major);
    wdr_put_u16(p + 6, h->version_minor);
    wdr_put_u16(p + 8, h->operator_id);
    p[10] = h->dac_bits;
    p[11] = h->timing;
    wdr_put_u32(p + 12, h->entry_count);
    wdr_put_u32(p + 16, h->tick_ps);
    wdr_put_u32(p + 20, h->t_integration_ticks);
    wdr_put_f32(p + 24, h->dac_lo_v);
    wdr_put_f32(p + 28, h->dac_hi_v);
    for (int i = 0; i < WDR_LUT_NPARAMS; i++)
        wdr_put_f32(p + 32 + 4 * i, h->params[i]);
    wdr_put_u32(p + 56, h->payload_crc);
    wdr_put_u32(p + 60, h->header_crc);
}

static void header_unpack(const uint8_t *p, wdr_lut_header *h)
{
    h->magic = wdr_get_u32(p + 0);
    h->version_major = wdr_get_u16(p + 4);
    h->version_minor = wdr_get_u16(p + 6);
    h->operator_id = wdr_get_u16(p + 8);
    h->dac_bits = p[10];
    h->timing = p[11];
    h->entry_count = wdr_get_u32(p + 12);
    h->tick_ps = wdr_get_u32(p + 16);
    h->t_integration_ticks = wdr_get_u32(p + 20);
    h->dac_lo_v = wdr_get_f32(p + 24);
    h->dac_hi_v = wdr_get_f32(p + 28);
    for (int i = 0; i < WDR_LUT_NPARAMS; i++)
        h->params[i] = wdr_get_f32(p + 32 + 4 * i);
    h->payload_crc = wdr_get_u32(p + 56);
    h->header_crc = wdr_get_u32(p + 60);
}

void wdr_lut_entry(const wdr_lut_view *lut, uint32_t i, uint32_t *t_ticks, uint16_t *code)
{
    const uint8_t *e = lut->entries + (size_t)i * WDR_LUT_ENTRY_SIZE;
    *t_ticks = wdr_get_u32(e);
    *code = wdr_get_u16(e + 4);
}

void wdr_lut_encode(wdr_lut_header *h, const uint32_t *t_ticks, const uint16_t *codes, uint8_t *out)
{
    uint8_t *e = out + WDR_LUT_HEADER_SIZE;
    for (uint32_t i = 0; i < h->entry_count; i++, e += WDR_LUT_ENTRY_SIZE) {
        wdr_put_u32(e, t_ticks[i]);
        wdr_put_u16(e + 4, codes[i]);
        wdr_put_u16(e + 6, 0);
    }
    h->magic = WDR_LUT_MAGIC;
    h->version_major = WDR_LUT_VERSION_MAJOR;
    h->version_minor = WDR_LUT_VERSION_MINOR;
    h->payload_crc = wdr_crc32(0, out + WDR_LUT_HEADER_SIZE, (size_t)h->entry_count * WDR_LUT_ENTRY_SIZE);
    header_pack(h, out);
    h->header_crc = wdr_crc32(0, out, WDR_LUT_HEADER_SIZE - 4);
    wdr_put_u32(out + 60, h->header_crc);
}

static int header_check(const wdr_lut_header *h)
{
    if (h->dac_bits < 4 || h->dac_bits > 16 || h->timing > WDR_TIMING_STAMPED)
        return WDR_E_INVAL;
    if (h->entry_count == 0 || h->entry_count > WDR_LUT_MAX_ENTRIES || h->tick_ps == 0)
        return WDR_E_INVAL;
    if (h->operator_id >= WDR_OP_COUNT || !(h->dac_hi_v > h->dac_lo_v))
        return WDR_E_INVAL;
    return WDR_OK;
}

/* Entries must start at t=0, rise strictly in time, stay in the DAC's range and end by
 * t_integration: the playback code relies on all of it. */
static int entries_check(const wdr_lut_view *lut)
{
    uint32_t max_code = (1u << lut->h.dac_bits) - 1u, prev_t = 0;
    for (uint32_t i = 0; i < lut->h.entry_count; i++) {
        uint32_t t;
        uint16_t code;
        wdr_lut_entry(lut, i, &t, &code);
        if (code > max_code || (i == 0 && t != 0) || (i > 0 && t <= prev_t))
            return WDR_E_INVAL;
        prev_t = t;
    }
    return prev_t < lut->h.t_integration_ticks ? WDR_OK : WDR_E_INVAL;
}

uint64_t wdr_ticks_ps(uint32_t ticks, uint32_t tick_ps, uint16_t tick_frac_q16)
{
    return (uint64_t)ticks * tick_ps + (((uint64_t)ticks * tick_frac_q16) >> 16);
}

uint64_t wdr_lut_ticks_ps(const wdr_lut_view *lut, uint32_t ticks)
{
    return wdr_ticks_ps(ticks, lut->h.tick_ps, lut->tick_frac_q16);
}

int wdr_lut_parse(const void *buf, size_t len, wdr_lut_view *out)
{
    const uint8_t *p = buf;
    out->tick_frac_q16 = 0;
    if (len < WDR_LUT_HEADER_SIZE)
        return WDR_E_TRUNCATED;
    header_unpack(p, &out->h);
    if (out->h.magic != WDR_LUT_MAGIC || out->h.header_crc != wdr_crc32(0, p, WDR_LUT_HEADER_SIZE - 4))
        return WDR_E_CORRUPT;
    if (out->h.version_major != WDR_LUT_VERSION_MAJOR)
        return WDR_E_VERSION;
    int err = header_check(&out->h);
    if (err)
        return err;
    if (len < wdr_lut_size(out->h.entry_count))
        return WDR_E_TRUNCATED;
    out->entries = p + WDR_LUT_HEADER_SIZE;
    if (wdr_crc32(0, out->entries, (size_t)out->h.entry_count * WDR_LUT_ENTRY_SIZE) != out->h.payload_crc)
        return WDR_E_CORRUPT;
    return entries_check(out);
}

/* ---- Exposure block (SPEC.md, LUT 1.1) ---- */

static int expo_bins_valid(uint32_t bins)
{
    return bins >= WDR_LUT_EXPO_BINS && bins <= WDR_LUT_EXPO_MAX_BINS && (bins & (bins - 1u)) == 0;
}

int wdr_lut_exposure_parse(const void *buf, size_t len, wdr_lut_exposure *out)
{
    const uint8_t *p = buf;
    if (len < 8u)
        return WDR_E_TRUNCATED;
    uint32_t bins = wdr_get_u16(p + 4);
    if (wdr_get_u32(p) != WDR_LUT_EXPO_MAGIC)
        return WDR_E_CORRUPT;
    if (!expo_bins_valid(bins) || (p[7] & ~WDR_LUT_EXPO_FLAGS) || len != WDR_LUT_EXPO_BLOCK_SIZE_FOR(bins, p[7]) ||
        p[6] > 10u)
        return WDR_E_INVAL;
    const uint8_t *dark = p + 8 + 2 * bins * (1u + (p[7] & WDR_LUT_EXPO_DROOP));
    if (wdr_get_u32(p + len - 4u) != wdr_crc32(0, p, len - 4u))
        return WDR_E_CORRUPT;
    out->code_shift = p[6];
    out->bins = (uint16_t)bins;
    out->flags = p[7];
    for (uint32_t b = 0; b < bins; b++) {
        out->ln_q8[b] = (int16_t)wdr_get_u16(p + 8 + 2 * b);
        out->droop_q8[b] = (out->flags & WDR_LUT_EXPO_DROOP) ? (int16_t)wdr_get_u16(p + 8 + 2 * (bins + b)) : 0;
        if (out->ln_q8[b] < -WDR_LUT_EXPO_MAX_LN_Q8 || out->ln_q8[b] > WDR_LUT_EXPO_MAX_LN_Q8)
            return WDR_E_INVAL; /* the gain steps by half of it: bounded steps, bounded arithmetic */
    }
    out->dark_ln_q8 = (out->flags & WDR_LUT_EXPO_DARK) ? (int16_t)wdr_get_u16(dark) : 0;
    if ((out->flags & WDR_LUT_EXPO_DARK) &&
        (wdr_get_u16(dark + 2) || out->dark_ln_q8 < -WDR_LUT_EXPO_MAX_LN_Q8 || out->dark_ln_q8 > WDR_LUT_EXPO_MAX_LN_Q8))
        return WDR_E_INVAL;
    return WDR_OK;
}

void wdr_lut_exposure_flat_ends(const wdr_lut_exposure *ex, uint32_t *floor_bin, uint32_t *ceiling_bin)
{
    uint32_t first_min = 0, last_max = 0;
    for (uint32_t b = 1; b < ex->bins; b++) {
        if (ex->ln_q8[b] < ex->ln_q8[first_min])
            first_min = b;
        if (ex->ln_q8[b] >= ex->ln_q8[0])
            last_max = b;
    }
    *floor_bin = first_min, *ceiling_bin = last_max;
}

void wdr_lut_exposure_encode(const wdr_lut_exposure *in, uint8_t *out)
{
    uint8_t flags = in->flags & WDR_LUT_EXPO_FLAGS;
    uint32_t size = WDR_LUT_EXPO_BLOCK_SIZE_FOR(in->bins, flags);
    wdr_put_u32(out, WDR_LUT_EXPO_MAGIC);
    wdr_put_u16(out + 4, in->bins);
    out[6] = in->code_shift;
    out[7] = flags;
    for (uint32_t b = 0; b < in->bins; b++) {
        wdr_put_u16(out + 8 + 2 * b, (uint16_t)in->ln_q8[b]);
        if (flags & WDR_LUT_EXPO_DROOP)
            wdr_put_u16(out + 8 + 2 * (in->bins + b), (uint16_t)in->droop_q8[b]);
    }
    if (flags & WDR_LUT_EXPO_DARK) {
        uint8_t *dark = out + 8 + 2u * in->bins * (1u + (flags & WDR_LUT_EXPO_DROOP));
        wdr_put_u16(dark, (uint16_t)in->dark_ln_q8);
        wdr_put_u16(dark + 2, 0);
    }
    wdr_put_u32(out + size - 4u, wdr_crc32(0, out, size - 4u));
}
