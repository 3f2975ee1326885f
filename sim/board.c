#include "board.h"
#include "data_path.h"
#include "file_io.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <cJSON.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

void wdr_board_defaults(wdr_board *b)
{
    memset(b, 0, sizeof *b);
    snprintf(b->name, sizeof b->name, "default");
    snprintf(b->backend, sizeof b->backend, "sim");
    b->sensor_id = 0x3501;
    b->width = 640;
    b->height = 480;
    b->vdd_v = 3.3;
    b->reset_gate_v = 4.0;
    b->vt0_v = 0.45;
    b->gamma_sqrt_v = 0.4;
    b->phi2f_v = 0.7;
    b->kp_a_per_v2 = 170e-6;
    b->sf_bias_a = 1e-6;
    b->m1 = (wdr_mos){1.0, 0.7};
    b->m2 = (wdr_mos){2.0, 0.7};
    b->m3 = (wdr_mos){2.0, 0.7};
    b->c_pd_f = 10e-15;
    b->c_pd_ref_v = 2.0;
    b->pb_v = 0.8;
    b->mj = 0.4;
    b->dark_current_a = 3e-16;
    b->c_hold_f = 5e-15;
    b->hold_leak_a = 1e-15;
    b->avt_mv_um = 9.5;
    b->abeta_pct_um = 0.7;
    b->c_pd_sigma_pct = 1.0;
    b->dark_sigma_ln = 0.3;
    b->temperature_k = 300.0;
    b->read_noise_v = 0.3e-3;
    b->i_min_a = 1e-14;
    b->i_max_a = 1e-8;
    b->i_center_a = 1e-11;
    b->lum_per_amp = 1e11;
    b->swing_v = 1.5;
    b->dark_offset_v = 0.0;
    b->dac_bits = 12;
    b->dac_lo_v = 0.0;
    b->dac_hi_v = 3.3;
    b->dac_timing = WDR_TIMING_STAMPED;
    b->dac_timer_hz = 1e9;
    b->dac_uniform_entries = 4096;
    b->adc_bits = 12;
    b->adc_lo_v = 0.0;
    b->adc_hi_v = 2.0;
    b->adc_offset_v = 0.0;
    b->adc_gain = 1.0;
    b->row_time_s = 20e-6;
}

enum field_type { F_DOUBLE, F_INT, F_U16, F_U32, F_STRING, F_TIMING };

typedef struct field {
    const char *section; /* NULL for top level */
    const char *key;
    size_t offset;
    enum field_type type;
    double min, max;
    size_t size; /* for strings */
} field;

#define FD(sec, key, member, lo, hi) {sec, key, offsetof(wdr_board, member), F_DOUBLE, lo, hi, 0}
#define FI(sec, key, member, type, lo, hi) {sec, key, offsetof(wdr_board, member), type, lo, hi, 0}
#define FS(sec, key, member) {sec, key, offsetof(wdr_board, member), F_STRING, 0, 0, sizeof(((wdr_board *)0)->member)}

static const field board_fields[] = {
    FS(NULL, "name", name),
    FS(NULL, "backend", backend),
    FI(NULL, "sensor_id", sensor_id, F_U32, 0, 4294967295.0),
    FI("geometry", "width", width, F_U16, 1, 8192),
    FI("geometry", "height", height, F_U16, 1, 8192),
    FD("supply", "vdd_V", vdd_v, 0.5, 20),
    FD("supply", "reset_gate_V", reset_gate_v, 0.5, 20),
    FD("transistors", "vt0_V", vt0_v, -2, 5),
    FD("transistors", "gamma_sqrtV", gamma_sqrt_v, 0, 3),
    FD("transistors", "phi2f_V", phi2f_v, 0.1, 2),
    FD("transistors", "kp_A_per_V2", kp_a_per_v2, 1e-9, 1),
    FD("transistors", "sf_bias_A", sf_bias_a, 1e-12, 1e-2),
    FD("transistors", "m1_w_um", m1.w_um, 0.05, 1000),
    FD("transistors", "m1_l_um", m1.l_um, 0.05, 1000),
    FD("transistors", "m2_w_um", m2.w_um, 0.05, 1000),
    FD("transistors", "m2_l_um", m2.l_um, 0.05, 1000),
    FD("transistors", "m3_w_um", m3.w_um, 0.05, 1000),
    FD("transistors", "m3_l_um", m3.l_um, 0.05, 1000),
    FD("photodiode", "c_pd_F", c_pd_f, 1e-17, 1e-11),
    FD("photodiode", "c_pd_ref_V", c_pd_ref_v, 0, 20),
    FD("photodiode", "junction_pb_V", pb_v, 0.1, 5),
    FD("photodiode", "junction_m", mj, 0, 0.9),
    FD("photodiode", "dark_current_A", dark_current_a, 0, 1e-9),
    FD("hold", "c_hold_F", c_hold_f, 1e-17, 1e-11),
    FD("hold", "leakage_A", hold_leak_a, 0, 1e-9),
    FD("mismatch", "avt_mV_um", avt_mv_um, 0, 100),
    FD("mismatch", "abeta_pct_um", abeta_pct_um, 0, 50),
    FD("mismatch", "c_pd_pct", c_pd_sigma_pct, 0, 50),
    FD("mismatch", "dark_sigma_ln", dark_sigma_ln, 0, 5),
    FD("noise", "temperature_K", temperature_k, 1, 500),
    FD("noise", "read_noise_V", read_noise_v, 0, 1),
    FD("photocurrent", "i_min_A", i_min_a, 1e-18, 1e-3),
    FD("photocurrent", "i_max_A", i_max_a, 1e-18, 1e-3),
    FD("photocurrent", "i_center_A", i_center_a, 1e-18, 1e-3),
    FD("photocurrent", "lum_per_A", lum_per_amp, 1e-30, 1e30),
    FD("output", "swing_V", swing_v, 1e-3, 20),
    FD("output", "dark_offset_V", dark_offset_v, -5, 5),
    FI("dac", "bits", dac_bits, F_INT, 4, 16),
    FD("dac", "v_lo_V", dac_lo_v, -20, 20),
    FD("dac", "v_hi_V", dac_hi_v, -20, 20),
    FI("dac", "timing", dac_timing, F_TIMING, 0, 1),
    FD("dac", "timer_Hz", dac_timer_hz, 1e3, 1e12),
    FI("dac", "uniform_entries", dac_uniform_entries, F_U32, 2, WDR_LUT_MAX_ENTRIES),
    FI("adc", "bits", adc_bits, F_INT, 4, 16),
    FD("adc", "v_lo_V", adc_lo_v, -20, 20),
    FD("adc", "v_hi_V", adc_hi_v, -20, 20),
    FD("adc", "offset_V", adc_offset_v, -5, 5),
    FD("adc", "gain", adc_gain, 0.01, 100),
    FD("readout", "row_time_s", row_time_s, 0, 0.01), /* the protocol's limit (SPEC.md, field limits) */
    FD("controller", "table_bus_MBps", table_bus_mbps, 0, 1e6),
};
#define N_FIELDS (sizeof board_fields / sizeof board_fields[0])

static const field *find_field(const char *section, const char *key)
{
    for (size_t i = 0; i < N_FIELDS; i++) {
        const field *f = &board_fields[i];
        int same_section = (!section && !f->section) || (section && f->section && !strcmp(section, f->section));
        if (same_section && !strcmp(key, f->key))
            return f;
    }
    return NULL;
}

static int is_section(const char *name)
{
    for (size_t i = 0; i < N_FIELDS; i++)
        if (board_fields[i].section && !strcmp(board_fields[i].section, name))
            return 1;
    return 0;
}

static int set_number(wdr_board *b, const field *f, double v)
{
    char *base = (char *)b + f->offset;
    switch (f->type) {
    case F_DOUBLE: *(double *)base = v; break;
    case F_INT: *(int *)base = (int)v; break;
    case F_U16: *(uint16_t *)base = (uint16_t)v; break;
    case F_U32: *(uint32_t *)base = (uint32_t)v; break;
    default: return WDR_E_INVAL;
    }
    return WDR_OK;
}

static int bad(char *err, int errlen, const char *path, const char *section, const char *key,
               const char *why)
{
    snprintf(err, (size_t)errlen, "%s: field '%s%s%s': %s", path, section ? section : "", section ? "." : "",
             key, why);
    return WDR_E_INVAL;
}

static int apply_item(wdr_board *b, const char *section, const cJSON *item, const char *path, char *err,
                      int errlen)
{
    const field *f = find_field(section, item->string);
    char why[160];
    if (!f)
        return bad(err, errlen, path, section, item->string, "unknown field");
    if (f->type == F_STRING) {
        if (!cJSON_IsString(item) || strlen(item->valuestring) >= f->size)
            return bad(err, errlen, path, section, item->string, "must be a short string");
        snprintf((char *)b + f->offset, f->size, "%s", item->valuestring);
        return WDR_OK;
    }
    if (f->type == F_TIMING) {
        const char *s = cJSON_IsString(item) ? item->valuestring : "";
        if (strcmp(s, "uniform") && strcmp(s, "stamped"))
            return bad(err, errlen, path, section, item->string, "must be \"uniform\" or \"stamped\"");
        b->dac_timing = strcmp(s, "uniform") ? WDR_TIMING_STAMPED : WDR_TIMING_UNIFORM;
        return WDR_OK;
    }
    if (!cJSON_IsNumber(item))
        return bad(err, errlen, path, section, item->string, "must be a number");
    double v = item->valuedouble;
    if (!isfinite(v) || v < f->min || v > f->max || (f->type != F_DOUBLE && v != floor(v))) {
        snprintf(why, sizeof why, "value %g out of range [%g, %g]", v, f->min, f->max);
        return bad(err, errlen, path, section, item->string, why);
    }
    return set_number(b, f, v);
}

static int apply_json(wdr_board *b, const cJSON *root, const char *path, char *err, int errlen)
{
    for (const cJSON *it = root->child; it; it = it->next) {
        int rc;
        if (cJSON_IsObject(it)) {
            if (!is_section(it->string))
                return bad(err, errlen, path, NULL, it->string, "unknown section");
            for (const cJSON *sub = it->child; sub; sub = sub->next)
                if ((rc = apply_item(b, it->string, sub, path, err, errlen)))
                    return rc;
        } else if (!strcmp(it->string, "format") || !strcmp(it->string, "version") ||
                   !strcmp(it->string, "comment")) {
            continue;
        } else if ((rc = apply_item(b, NULL, it, path, err, errlen))) {
            return rc;
        }
    }
    return WDR_OK;
}

int wdr_board_validate(const wdr_board *b, const char *path, char *err, int errlen)
{
    char why[160];
    if (!(b->i_min_a < b->i_center_a && b->i_center_a < b->i_max_a)) {
        snprintf(why, sizeof why, "need i_min_A < i_center_A < i_max_A, got %g, %g, %g", b->i_min_a,
                 b->i_center_a, b->i_max_a);
        return bad(err, errlen, path, "photocurrent", "i_center_A", why);
    }
    if (!(b->dac_hi_v > b->dac_lo_v)) {
        snprintf(why, sizeof why, "v_hi_V %g must exceed v_lo_V %g", b->dac_hi_v, b->dac_lo_v);
        return bad(err, errlen, path, "dac", "v_hi_V", why);
    }
    if (!(b->adc_hi_v > b->adc_lo_v)) {
        snprintf(why, sizeof why, "v_hi_V %g must exceed v_lo_V %g", b->adc_hi_v, b->adc_lo_v);
        return bad(err, errlen, path, "adc", "v_hi_V", why);
    }
    if (strcmp(b->backend, "sim") && strcmp(b->backend, "linux"))
        return bad(err, errlen, path, NULL, "backend", "must be \"sim\" or \"linux\"");
    return WDR_OK;
}

int wdr_board_load(const char *path, wdr_board *b, char *err, int errlen)
{
    char *text = wdr_read_text(path);
    if (!text) {
        snprintf(err, (size_t)errlen, "%s: cannot read board file", path);
        return WDR_E_IO;
    }
    cJSON *root = cJSON_Parse(text);
    int rc = WDR_OK;
    if (!root || !cJSON_IsObject(root)) {
        snprintf(err, (size_t)errlen, "%s: not a JSON object (near '%.20s')", path,
                 cJSON_GetErrorPtr() ? cJSON_GetErrorPtr() : "");
        rc = WDR_E_INVAL;
    } else {
        rc = apply_json(b, root, path, err, errlen);
    }
    cJSON_Delete(root);
    free(text);
    return rc ? rc : wdr_board_validate(b, path, err, errlen);
}

void wdr_board_path(const char *name, char *out, int outlen) { wdr_data_path(WDR_DATA_BOARDS, name, out, outlen); }

int wdr_board_load_named(const char *name, wdr_board *b, char *err, int errlen)
{
    char path[4200];
    wdr_board_path(name, path, sizeof path);
    if (wdr_data_is_name(name) && access(path, F_OK) != 0) {
        wdr_data_unknown(WDR_DATA_BOARDS, name, err, errlen);
        return WDR_E_IO;
    }
    return wdr_board_load(path, b, err, errlen);
}
