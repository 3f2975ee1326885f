/* Table contents: the checks a stored LUT or calibration table must pass beyond its slot's
 * CRC (its own format, its kind, this board's geometry), activation, and the per-row
 * correction that READOUT runs on every frame. */
#include "correct.h"
#include "crc32.h"
#include "fw_internal.h"
#include <string.h>

#define CAL_MIN_DENOM 1e-3f /* the Moebius denominator r*y + 1 must stay this far from zero */

/* The active BASIS table's basis values at every raw code (wdr_correct_per_code), built at
 * activation so READOUT does one dot product per pixel instead of locating and interpolating
 * every pixel's code in the shared block. Outside wdr_fw because wdr_fw.h fixes its layout; a
 * program has one firmware (wdr_fw.h), so one table. A wider ADC than it holds interpolates. */
static union {
    float basis[WDR_FW_CAL_CODES * WDR_FW_MAX_CAL_COEFFS];
    /* COMPACT: base and two int16 pairs per code, 16 bytes; SHIFTED also the codes below 0 and,
     * for one USAT a pixel, on to twice the codes (no more RAM: basis is 8 floats a code) */
    uint32_t compact[WDR_FW_CAL_CODES * 8u];
} cal_code_points;

/* A stored table: read through the store (fw_store.c), which alone knows the slots' layout. */
typedef struct table_ref {
    wdr_store *store;
    int kind, slot;
} table_ref;

static int table_read(const table_ref *t, uint32_t off, void *buf, uint32_t n)
{
    return wdr_store_read(t->store, t->kind, t->slot, off, buf, n);
}

static uint16_t adc_max(const wdr_fw *fw)
{
    return (uint16_t)((1u << fw->board.adc_bits) - 1u);
}

/* ---- LUT: loaded whole into the staging RAM buffer ----------------------------------------- */

static int lut_check(wdr_fw *fw, const table_ref *t, uint32_t len)
{
    uint8_t *p = (uint8_t *)fw->lut_ram[fw->lut_buf ^ 1];
    if (len > WDR_FW_LUT_MAX_BYTES)
        return WDR_E_TOO_LARGE;
    int err = table_read(t, 0, p, len);
    if (err)
        return err;
    if (len >= 4 && wdr_get_u32(p) == WDR_CAL_MAGIC)
        return WDR_E_KIND;
    err = wdr_lut_parse(p, len, &fw->staged_lut);
    if (err)
        return err;
    /* LUT 1.1: the exposure block, if any, follows the entries and nothing else does (its bins
     * say its length: any other is BAD_TABLE) */
    size_t entries_end = wdr_lut_size(fw->staged_lut.h.entry_count);
    fw->staged_has_expo = len > entries_end;
    if (fw->staged_has_expo)
        err = len - entries_end < 8u ? WDR_E_INVAL
                                     : wdr_lut_exposure_parse(p + entries_end, len - entries_end, &fw->staged_expo);
    if (err)
        return err;
    return fw->staged_lut.h.dac_bits == fw->board.dac_bits ? WDR_OK : WDR_E_GEOMETRY;
}

/* ---- Calibration: too big for RAM, so checked row by row ----------------------------------- */

static int finite_bits(float x)
{
    uint32_t u;
    memcpy(&u, &x, sizeof u);
    return ((u >> 23) & 0xffu) != 0xffu;
}

/* A view of the one row block held in fw->cal_row, as row 0 of a one-row table (as
 * wdr_readout_row does). */
static void row_view(const wdr_fw *fw, const wdr_cal_view *full, wdr_cal_view *rv)
{
    *rv = *full;
    rv->h.height = 1;
    rv->payload = (const uint8_t *)fw->cal_row;
}

/* The kernel trusts its table: finite coefficients, denominators away from zero. */
static int cal_row_check(const wdr_cal_view *rv, uint32_t *bad)
{
    for (int k = 0; !wdr_cal_form_compact(rv->h.form) && k < rv->h.n_coeffs; k++) { /* int16: always finite */
        const float *c = wdr_cal_row_coeffs(rv, 0, k);
        for (int i = 0; i < rv->h.width; i++)
            if (!finite_bits(c[i]))
                return WDR_E_NUMERIC;
    }
    if (rv->h.form == WDR_FORM_MOEBIUS) {
        const float *r = wdr_cal_row_coeffs(rv, 0, 2);
        for (int i = 0; i < rv->h.width; i++)
            if (!(r[i] * (float)rv->h.raw_max + 1.0f >= CAL_MIN_DENOM))
                return WDR_E_NUMERIC;
    }
    const uint8_t *f = wdr_cal_row_flags(rv, 0);
    for (int i = 0; i < rv->h.width; i++)
        *bad += wdr_cal_pixel_flags(rv->h.form, f[i]) != 0;
    return WDR_OK;
}

/* The format's own header checks: wdr_cal_parse on the header alone stops at TRUNCATED
 * exactly when everything it can see (magic, CRC, version, fields) is right. */
static int cal_header(wdr_fw *fw, const table_ref *t, uint32_t len, wdr_cal_view *v)
{
    uint8_t *p = (uint8_t *)fw->cal_row;
    if (len < WDR_CAL_HEADER_SIZE)
        return WDR_E_TRUNCATED;
    int err = table_read(t, 0, p, WDR_CAL_HEADER_SIZE);
    if (err)
        return err;
    if (wdr_get_u32(p) == WDR_LUT_MAGIC)
        return WDR_E_KIND;
    err = wdr_cal_parse(p, WDR_CAL_HEADER_SIZE, v);
    if (err != WDR_E_TRUNCATED)
        return err ? err : WDR_E_INVAL;
    if (len < WDR_CAL_HEADER_SIZE + (uint64_t)v->h.payload_len)
        return WDR_E_TRUNCATED;
    if (len > WDR_CAL_HEADER_SIZE + (uint64_t)v->h.payload_len)
        return WDR_E_INVAL;
    v->row_stride = wdr_cal_form_row_stride(v->h.form, v->h.width, v->h.n_coeffs);
    v->payload = NULL;
    v->shared = NULL;
    return WDR_OK;
}

static int cal_geometry(const wdr_fw *fw, const wdr_cal_view *v)
{
    int err = wdr_cal_check_geometry(v, fw->board.sensor_id, fw->board.width, fw->board.height);
    if (err)
        return err;
    if (v->h.raw_max != adc_max(fw))
        return WDR_E_GEOMETRY;
    if (wdr_cal_shared_bytes(&v->h) > sizeof fw->cal_shared[0])
        return WDR_E_TOO_LARGE;
    return v->row_stride <= sizeof fw->cal_row ? WDR_OK : WDR_E_TOO_LARGE;
}

/* BASIS: the shared block into the staging buffer, checked once; the kernel then trusts it for
 * every row. *crc continues over it (the payload CRC covers the shared block, then the rows). */
static int cal_shared_load(wdr_fw *fw, const table_ref *t, uint32_t off, wdr_cal_view *v, uint32_t *crc, int *content)
{
    uint32_t bytes = wdr_cal_shared_bytes(&v->h);
    if (!bytes)
        return WDR_OK;
    float *buf = fw->cal_shared[fw->cal_shared_buf ^ 1];
    int err = table_read(t, off, buf, bytes);
    if (err)
        return err;
    *crc = wdr_crc32(*crc, buf, bytes);
    *content = wdr_cal_shared_ok(&v->h, buf);
    v->shared = buf;
    return WDR_OK;
}

/* Read the shared block and every row once: CRC of the payload, value checks, flag count. A CRC
 * mismatch wins over what the corrupted rows look like. */
static int cal_rows_check(wdr_fw *fw, const table_ref *t, uint32_t off, wdr_cal_view *v)
{
    uint32_t crc = 0, bad = 0;
    int content = WDR_OK;
    int err = cal_shared_load(fw, t, off, v, &crc, &content);
    if (err)
        return err;
    off += wdr_cal_shared_bytes(&v->h);
    wdr_cal_view rv;
    row_view(fw, v, &rv);
    for (uint32_t r = 0; r < v->h.height; r++) {
        int err = table_read(t, off + r * v->row_stride, fw->cal_row, v->row_stride);
        if (err)
            return err;
        crc = wdr_crc32(crc, fw->cal_row, v->row_stride);
        if (!content)
            content = cal_row_check(&rv, &bad);
    }
    if (crc != v->h.payload_crc)
        return WDR_E_CORRUPT;
    if (content)
        return content;
    return bad == v->h.bad_pixels ? WDR_OK : WDR_E_INVAL;
}

static int cal_check(wdr_fw *fw, const table_ref *t, uint32_t len)
{
    wdr_cal_view *v = &fw->staged_cal;
    int err = cal_header(fw, t, len, v);
    if (!err)
        err = cal_geometry(fw, v);
    if (!err)
        err = cal_rows_check(fw, t, WDR_CAL_HEADER_SIZE, v);
    return err;
}

/* ---- Activation ------------------------------------------------------------------------------ */

int wdr_fw_table_check(wdr_fw *fw, int kind, int slot, uint32_t len)
{
    table_ref t = {&fw->store, kind, slot};
    return kind == WDR_KIND_LUT ? lut_check(fw, &t, len) : cal_check(fw, &t, len);
}

/* Make the table that passed the last wdr_fw_table_check of this kind active. */
void wdr_fw_table_activate(wdr_fw *fw, int kind, int slot)
{
    if (kind == WDR_KIND_LUT) {
        fw->lut = fw->staged_lut;
        fw->lut_buf ^= 1;
        fw->lut_slot = slot;
        fw->integration_ns = 0; /* an override was checked against the old ramp */
        fw->expo = fw->staged_expo;
        fw->expo_has_table = fw->staged_has_expo;
        wdr_fw_expo_reset(fw);
    } else {
        fw->cal = fw->staged_cal;
        fw->cal_slot = slot;
        if (fw->cal.shared) {
            fw->cal_shared_buf ^= 1; /* the staging buffer the check filled is now the active one */
            /* TOO_LARGE (more codes than WDR_FW_CAL_CODES) leaves the view interpolating */
            if (wdr_cal_form_compact(fw->cal.h.form))
                (void)wdr_correct_per_code_compact(&fw->cal, cal_code_points.compact,
                                                   sizeof cal_code_points.compact / sizeof(uint32_t));
            else
                (void)wdr_correct_per_code(&fw->cal, cal_code_points.basis,
                                           sizeof cal_code_points.basis / sizeof(float));
        }
    }
}

static void identity_cal(wdr_fw *fw)
{
    fw->cal_slot = -1;
    if (wdr_cal_identity(&fw->cal, fw->board.sensor_id, fw->board.width, fw->board.height, 1.0f, adc_max(fw),
                         adc_max(fw)))
        memset(&fw->cal, 0, sizeof fw->cal); /* width 0: wdr_fw_init refused this board already */
}

/* Newest slot whose content passes; a slot that fails is not a table and is skipped. */
static void boot_kind(wdr_fw *fw, int kind)
{
    for (int tries = 0; tries < 2; tries++) {
        int slot = wdr_store_newest(&fw->store, kind, -1);
        if (slot < 0)
            return;
        if (!wdr_fw_table_check(fw, kind, slot, wdr_store_length(&fw->store, kind, slot))) {
            wdr_fw_table_activate(fw, kind, slot);
            return;
        }
        wdr_store_forget(&fw->store, kind, slot);
    }
}

void wdr_fw_tables_boot(wdr_fw *fw)
{
    fw->lut_slot = -1;
    identity_cal(fw);
    if (fw->boot_err)
        return;
    boot_kind(fw, WDR_KIND_LUT);
    boot_kind(fw, WDR_KIND_CAL);
}

/* ---- The on-the-fly path ----------------------------------------------------------------------- */

/* Bring row `row` of the active calibration table from flash into fw->cal_row; nothing to do
 * for the identity. READOUT runs wdr_readout_row on it for every row of every frame. The rows
 * end the stored table (its length was checked to be exact), so they are counted back from
 * there: fw->cal's shared_points may describe the per-code points, not the stored block. */
int wdr_fw_load_cal_row(wdr_fw *fw, uint16_t row)
{
    if (fw->cal_slot < 0)
        return WDR_OK;
    const wdr_cal_view *v = &fw->cal;
    table_ref t = {&fw->store, WDR_KIND_CAL, fw->cal_slot};
    uint32_t end = wdr_store_length(&fw->store, WDR_KIND_CAL, fw->cal_slot);
    return table_read(&t, end - (uint32_t)(v->h.height - row) * v->row_stride, fw->cal_row, v->row_stride);
}
