/* wdrctl calibrate: fixed-pattern-noise calibration of the simulator itself (default) or of a
 * board (--device): a simulated board sets its illuminant, a real one asks a person to set each
 * light level. The frame source for a board is host/cal/acquire/cal_board_source.c. */
#include "cal_board_source.h"
#include "cal_common.h"
#include "cal_exposure.h"
#include "file_io.h"
#include "operators.h"
#include "transport_client.h"
#include "wdr_lut.h"
#include "wdr_err.h"
#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- a board as the frame source ---- */

typedef struct device_src {
    wdrctl_conn conn;
    wdr_cal_board board;
} device_src;

/* A person sets the light on a real board: one prompt per level, on the terminal. */
static int prompt_level(double amps)
{
    fprintf(stderr, "Set a uniform light giving %.4g A per pixel (0: cover the sensor), then press Enter: ", amps);
    int ch;
    while ((ch = getchar()) != '\n' && ch != EOF)
        ;
    return ch == EOF ? WDR_E_IO : WDR_OK;
}

/* The LUT file the board will image with, stored with the calibration margin this chip needs
 * (sized from the board's own frames: cal_size_margin). */
static int upload_lut_with_margin(device_src *d, const char *path, const wdr_board *b, const wdr_cal_source *src,
                                  const wdr_cal_design *design, wdr_cal_margin *m)
{
    uint8_t *buf;
    size_t len;
    if (wdr_read_file(path, &buf, &len) != WDR_OK)
        return wdrctl_fail(EX_NOINPUT, "%s: cannot read LUT", path);
    wdr_cal_board_lut l = {&d->board, buf, len, b};
    fprintf(stderr, "wdrctl: %s: sizing its calibration margin on the board's frames\n", path);
    int rc = cal_size_margin(src, design, wdr_cal_board_set_margin, &l, m);
    free(buf);
    if (rc == EX_OK)
        fprintf(stderr, "wdrctl: %s stored with a %.1f mV calibration margin (+%.3g s of integration)\n", path,
                m->margin_v * 1e3, m->added_s);
    return rc;
}

/* The chip's mean corrected code at each calibration level (malloc'd; NULL: the nominal's are used). */
static double *level_codes(const cal_run *r)
{
    const wdr_cal_levels *lv = &r->levels;
    double *codes = malloc(sizeof *codes * (size_t)lv->n);
    for (int k = 0; codes && k < lv->n; k++)
        if (wdr_cal_mean_corrected_code(r->table, r->table_len, lv->frames + (size_t)k * lv->width * lv->height,
                                        &codes[k]) != WDR_OK) {
            free(codes);
            return NULL;
        }
    return codes;
}

/* The LUT stored again, its exposure block anchored at the calibration's levels (cal_exposure.h):
 * the table came from the board's designed pixel, the corrected codes are this chip's median
 * pixel's (sim-qvga seed 5: 0.02-0.12 ln apart below 1e-13 A, auto exposure 2.3 % low on the HDR
 * wedge). A LUT without an exposure block is left as stored. */
static int anchor_exposure(device_src *d, const char *path, const wdr_board *b, const cal_run *r)
{
    uint8_t *buf, *ext = NULL;
    size_t len, ext_len;
    double added, done;
    char err[512];
    wdr_cal_exposure_anchors a;
    if (wdr_read_file(path, &buf, &len) != WDR_OK)
        return wdrctl_fail(EX_NOINPUT, "%s: cannot read LUT", path);
    int rc = wdr_cal_lut_for_board(buf, len, b, r->margin.margin_v, &ext, &ext_len, &added, &done, err, sizeof err);
    free(buf);
    if (rc)
        return wdrctl_fail(EX_DATAERR, "calibrate: %s: %s", path, err);
    double *codes = level_codes(r);
    rc = wdr_cal_exposure_anchor(ext, ext_len, b, &r->res.nominal, r->cfg.out_scale, r->levels.amps, r->levels.n,
                                 codes, &a);
    free(codes);
    if (rc == WDR_OK && a.n > 0 && (rc = wdr_cal_board_upload_lut(&d->board, ext, ext_len)) != WDR_OK) {
        free(ext);
        return wdrctl_conn_fail(&d->conn, rc);
    }
    free(ext);
    if (rc)
        return wdrctl_fail(EX_DATAERR, "calibrate: %s: the exposure block: %s (the LUT stays as stored)", path,
                           wdr_strerror(rc));
    if (a.n > 0)
        fprintf(stderr,
                "wdrctl: %s: exposure table anchored at %d calibration levels (the chip's median codes; largest move "
                "%.3f ln, at %.3g A)\n",
                path, a.n, a.worst_ln, a.worst_at_a);
    if (a.dark_line)
        fprintf(stderr, "wdrctl: %s: its line past the floor fitted to the levels there (no light %+.2f codes from the "
                "design's)\n", path, a.dark_moved_codes);
    return EX_OK;
}

/* The operator a board calibration serves: with --lut, the LUT's own (its header), which
 * --operator, when given, must name; else --operator (default reinhard). The design, the display
 * figures and the table's operator field follow it (the table said Reinhard for every board). */
static int device_operator(cal_opts *o, int *op_id)
{
    if (o->lut) {
        uint8_t *buf;
        size_t len;
        wdr_lut_view v;
        if (wdr_read_file(o->lut, &buf, &len) != WDR_OK)
            return wdrctl_fail(EX_NOINPUT, "%s: cannot read LUT", o->lut);
        int rc = wdr_lut_parse(buf, len, &v);
        const wdr_operator_info *in = rc ? NULL : wdr_operator_info_by_id(v.h.operator_id);
        free(buf);
        if (rc)
            return wdrctl_fail(EX_DATAERR, "%s: not a LUT: %s", o->lut, wdr_strerror(rc));
        if (!in)
            return wdrctl_fail(EX_DATAERR, "%s: field operator_id: %u is no known operator", o->lut,
                               v.h.operator_id);
        if (o->op_asked && strcmp(in->name, o->op_name))
            return wdrctl_fail(EX_USAGE, "calibrate: --operator %s, but %s was built for %s", o->op_name, o->lut,
                               in->name);
        o->op_name = in->name;
    }
    const wdr_operator_info *op = wdr_operator_info_by_name(o->op_name);
    if (!op)
        return wdrctl_fail(EX_USAGE, "calibrate: unknown operator '%s' (see 'wdrctl operators')", o->op_name);
    *op_id = op->id;
    return EX_OK;
}

/* A board without a LUT refuses every capture ("refused by the board" from the first frame):
 * its STATUS says so before anything is lit or measured. */
static int require_lut(device_src *d, const char *address)
{
    int has_lut, rc = wdr_cal_board_has_lut(&d->board, &has_lut);
    if (rc)
        return wdrctl_conn_fail(&d->conn, rc);
    if (!has_lut)
        return wdrctl_fail(EX_CONFIG,
                           "calibrate: no LUT on the board: upload one or give --lut (%s reports no active "
                           "LUT slot in its STATUS, and captures nothing without one)",
                           address);
    return EX_OK;
}

/* One connection for the whole run (LUT, probe, levels, verification, upload, scene put back):
 * a board that serves one host (wdr-simboard --once) serves all of it. --wait as for every
 * board command. */
static int open_device(const cal_opts *o, device_src *d, wdr_cal_source *src)
{
    memset(d, 0, sizeof *d);
    int rc = wdrctl_connect_wait(o->device, wdrctl_global.timeout_ms, wdrctl_global.retries, wdrctl_global.wait_ms,
                                 &d->conn);
    if (rc != EX_OK)
        return rc;
    const wdr_info *in = &d->conn.c->info;
    if (wdr_cal_board_open(&d->board, d->conn.c, prompt_level, src) != WDR_OK)
        return wdrctl_fail(EX_OSERR, "out of memory for a %ux%u frame", in->width, in->height);
    if (!d->board.simulated && !o->currents && !o->levels_file)
        return wdrctl_fail(EX_USAGE,
                           "calibrate: %s sets no light itself: give the levels you will set with "
                           "--currents A,B,.. or --levels-file FILE (you are asked for each)",
                           o->device);
    return EX_OK; /* frames come raw (wdr_client_capture_raw): no table is changed to measure */
}

/* The board file that describes the board at --device: --board, else the one the board names in
 * INFO. Its physics sizes the droop in the LUT's exposure block and the read delay of the designed
 * response, so a file for another geometry is refused (sim-vga's file on sim-qvga put 4x the read
 * delay and another chip's hold leak into the table). */
static int load_device_board(const cal_opts *o, const wdr_info *in, wdr_board *b)
{
    const char *name = o->board ? o->board : in->name[0] ? in->name : NULL;
    if (!name)
        return wdrctl_fail(EX_USAGE, "calibrate: the board at %s gives no name: give --board NAME|FILE", o->device);
    int rc = cal_load_board(name, b);
    if (rc != EX_OK)
        return o->board ? rc
                        : wdrctl_fail(rc, "calibrate: the board at %s calls itself '%s': give --board for its board file",
                                      o->device, in->name);
    const char *field = b->width != in->width     ? "geometry.width"
                        : b->height != in->height ? "geometry.height"
                        : b->adc_bits != in->adc_bits ? "adc.bits"
                        : b->dac_bits != in->dac_bits ? "dac.bits"
                                                      : NULL;
    if (field)
        return wdrctl_fail(EX_CONFIG,
                           "calibrate: board file '%s' (%dx%d, %d-bit ADC, %d-bit DAC) does not describe the board at "
                           "%s ('%s', %ux%u, %u-bit ADC, %u-bit DAC): field %s differs; give --board for that board",
                           name, b->width, b->height, b->adc_bits, b->dac_bits, o->device, in->name, in->width,
                           in->height, in->adc_bits, in->dac_bits, field);
    return EX_OK;
}

/* On success and on failure alike: the scene goes back in front of a simulated board (a failure
 * to do so fails a calibration that had succeeded; after a failure it is only reported). */
static int close_device(device_src *d, int rc)
{
    int restored = d->conn.c ? wdr_cal_board_close(&d->board) : WDR_OK;
    if (restored && rc == EX_OK)
        rc = wdrctl_conn_fail(&d->conn, restored);
    else if (restored)
        fprintf(stderr, "wdrctl: the board stays on uniform light: %s (run 'wdrctl sim illuminant scene')\n",
                d->conn.c->err);
    wdrctl_disconnect(&d->conn);
    return rc;
}

/* ---- verification: the figures of host/cal/metrics/cal_metrics.h on fresh frames ---- */

#define VERIFY_CURRENTS 7     /* log-spaced over the calibrated range, about one per decade */
#define VERIFY_MAX_FRAMES 4   /* frames averaged per verification frame (at most the calibration's) */
#define NOMINAL_PER_DECADE 64 /* nominal response points for the display mapping (tonemap --nominal) */

typedef struct verify_ctx {
    int can_light;          /* the source sets its own uniform light (simulator, simulated board) */
    int quantised;          /* converters on */
    int temporal;           /* temporal noise expected (a board: yes; the simulator: as set up) */
    const char *holds_with; /* the conditions, printed beside the figures */
    const wdr_cal_design *design;
    wdr_display_map display;
} verify_ctx;

typedef struct verify_result {
    int n, frames;
    wdr_eval_point pt[VERIFY_CURRENTS];
} verify_result;

static int verify_display(const cal_opts *o, const wdr_board *b, verify_ctx *v)
{
    char err[512];
    if (wdr_display_map_init(&v->display, b, o->op_name, err, sizeof err))
        return wdrctl_fail(EX_USAGE, "calibrate: operator '%s': %s", o->op_name, err);
    return EX_OK;
}

static int verify(const cal_opts *o, const wdr_cal_source *src, const cal_run *r, const verify_ctx *v,
                  verify_result *out)
{
    char err[512];
    wdr_cal_view tab;
    out->n = 0;
    if (!o->json || !v->can_light || wdr_cal_parse(r->table, r->table_len, &tab))
        return EX_OK;
    out->frames = r->frames < VERIFY_MAX_FRAMES ? r->frames : VERIFY_MAX_FRAMES;
    wdr_eval_opts eo = {.frames = out->frames,
                        .temporal = v->temporal,
                        .quantised = v->quantised,
                        .display = &v->display,
                        .design = v->design};
    for (int k = 0; k < VERIFY_CURRENTS; k++) {
        double x = r->lo * pow(r->hi / r->lo, (k + 0.5) / VERIFY_CURRENTS);
        eo.first_frame_no = 5000000 + 16 * k;
        int rc = wdr_eval_point_measure(&r->res, &tab, src, x, &eo, &out->pt[k]);
        if (rc) {
            snprintf(err, sizeof err, "%s", wdr_strerror(rc));
            return wdrctl_fail(EX_IOERR, "calibrate: verification frames at %.3g A failed: %s", x, err);
        }
        out->n++;
    }
    return EX_OK;
}

/* Pixel frames the display error of a decade left out: its currents' pixels less those it used. */
static long display_left_out(const verify_result *vr, const wdr_display_error *dec, long np)
{
    long points = 0;
    for (int k = 0; k < vr->n; k++)
        points += vr->pt[k].x >= dec->x_lo * (1 - 1e-9) && vr->pt[k].x < dec->x_hi * (1 - 1e-9);
    return points * np - dec->used;
}

/* What each verification figure left out, per current: flagged pixels and unresolved ones. */
static void add_left_out_json(cJSON *j, const verify_result *vr)
{
    double a[3][VERIFY_CURRENTS];
    for (int k = 0; k < vr->n; k++) {
        const wdr_eval_point *p = &vr->pt[k];
        a[0][k] = (double)(p->before.excluded + p->before.unresolved);
        a[1][k] = (double)(p->table.excluded + p->table.unresolved);
        a[2][k] = (double)p->total.left_out;
    }
    cJSON_AddItemToObject(j, "pixels_left_out_before", cJSON_CreateDoubleArray(a[0], vr->n));
    cJSON_AddItemToObject(j, "pixels_left_out_after_table", cJSON_CreateDoubleArray(a[1], vr->n));
    cJSON_AddItemToObject(j, "pixels_left_out_one_frame", cJSON_CreateDoubleArray(a[2], vr->n));
}

static cJSON *verification_json(const verify_ctx *v, const cal_run *r, const verify_result *vr)
{
    long np = (long)r->res.width * r->res.height;
    cJSON *j = cJSON_CreateObject();
    double a[7][VERIFY_CURRENTS];
    wdr_display_error per[VERIFY_CURRENTS], dec[8];
    for (int k = 0; k < vr->n; k++) {
        const wdr_eval_point *p = &vr->pt[k];
        a[0][k] = p->x, a[1][k] = p->before.sd_pct, a[2][k] = p->before.beyond_frac, a[3][k] = p->table.sd_pct;
        a[4][k] = p->floor_pct, a[5][k] = p->total.total_1_pct, a[6][k] = p->total.temporal_pct;
        per[k] = p->display;
    }
    static const char *names[] = {"photocurrents_A",          "contrast_before_pct",    "before_beyond_curve_frac",
                                  "contrast_after_table_pct", "quantisation_floor_pct", "total_one_frame_pct",
                                  "temporal_one_frame_pct"};
    cJSON_AddStringToObject(j, "holds_with", v->holds_with);
    cJSON_AddNumberToObject(j, "frames_averaged", vr->frames);
    for (int q = 0; q < 7; q++)
        cJSON_AddItemToObject(j, names[q], cJSON_CreateDoubleArray(a[q], vr->n));
    add_left_out_json(j, vr);
    int nd = wdr_display_by_decade(per, vr->n, dec, 8);
    cJSON *d = cJSON_AddArrayToObject(j, "display_error_per_decade");
    for (int k = 0; k < nd; k++) {
        cJSON *e = cJSON_CreateObject();
        cJSON_AddNumberToObject(e, "from_A", dec[k].x_lo);
        cJSON_AddNumberToObject(e, "to_A", dec[k].x_hi);
        cJSON_AddNumberToObject(e, "mean_levels", dec[k].mean_levels);
        cJSON_AddNumberToObject(e, "mean_abs_levels", dec[k].mean_abs_levels);
        cJSON_AddNumberToObject(e, "frac_off_by_more_than_1_level", dec[k].frac_over_1);
        cJSON_AddNumberToObject(e, "pixels_left_out", (double)display_left_out(vr, &dec[k], np));
        cJSON_AddItemToArray(d, e);
    }
    cJSON_AddStringToObject(j, "note",
                            "figures of host/cal/metrics/cal_metrics.h (as wdrctl fpn report): contrast error "
                            "100 sd of ln(x_hat/x) on fresh frames, averaged over frames_averaged; total "
                            "and temporal from single frames. Every figure leaves out the pixels_flagged "
                            "pixels (above), and the contrast errors also those with no x_hat within a decade of "
                            "the range: pixels_left_out_* count both, per current (per decade: summed "
                            "over its currents)");
    return j;
}

/* The nominal response the corrected codes lie on: `wdrctl tonemap --nominal` maps them to display. */
static cJSON *nominal_json(const cal_run *r)
{
    double lx[1024], code[1024];
    int n = wdr_nominal_response_table(&r->res.nominal, NOMINAL_PER_DECADE, lx, code, 1024);
    cJSON *j = cJSON_CreateObject();
    for (int k = 0; k < n; k++)
        lx[k] = exp(lx[k]);
    cJSON_AddItemToObject(j, "amps_A", cJSON_CreateDoubleArray(lx, n));
    cJSON_AddItemToObject(j, "codes", cJSON_CreateDoubleArray(code, n));
    cJSON_AddStringToObject(j, "note",
                            "corrected output codes (before out_scale) as functions of the photocurrent: "
                            "the array's median response, droop and dark current included");
    return j;
}

/* ---- the command ---- */

static int write_file(const char *path, const uint8_t *buf, size_t len)
{
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(buf, 1, len, f) != len) {
        if (f)
            fclose(f);
        return wdrctl_fail(EX_CANTCREAT, "%s: cannot write calibration table", path);
    }
    return fclose(f) ? wdrctl_fail(EX_IOERR, "%s: write failed", path) : EX_OK;
}

/* ---- flagged pixels: the count by reason, and --max-flagged ---- */

/* "dead 3, stuck 0, hot 2, saturated 0, unfit 4 (reversed slope 4)": one kind per pixel (cal_bad.c). */
static const char *flag_reasons(const wdr_cal_result *res, char *buf, size_t cap)
{
    char part[96];
    const char *sep = " (";
    buf[0] = 0;
    for (int b = 0; b < WDR_CAL_FLAG_KINDS; b++) {
        snprintf(part, sizeof part, "%s%s %ld", b ? ", " : "", wdr_cal_flag_name(b), res->n_flag[b]);
        strncat(buf, part, cap - strlen(buf) - 1);
    }
    for (int st = 1; st < WDR_FIT_COUNT; st++)
        if (res->n_status[st]) {
            snprintf(part, sizeof part, "%s%s %ld", sep, wdr_fit_status_name(st), res->n_status[st]);
            strncat(buf, part, cap - strlen(buf) - 1);
            sep = ", ";
        }
    if (sep[0] == ',')
        strncat(buf, ")", cap - strlen(buf) - 1);
    return buf;
}

static long chip_pixels(const cal_run *r)
{
    return (long)r->res.width * r->res.height;
}

static double flagged_ppm(const cal_run *r)
{
    return 1e6 * (double)r->res.n_bad / (double)chip_pixels(r);
}

static int within_flag_limit(const cal_opts *o, const cal_run *r)
{
    return (double)r->res.n_bad <= cal_flag_limit_pixels(&o->max_flagged, chip_pixels(r));
}

/* Flat responses with no margin sized by this run: the board's LUT came from `lut upload`, whose
 * fixed calibration margin leaves a mismatched chip's latest crossers uncrossed at the dim end
 * (sim-qvga, seed 1: 145-148 of 19,200 with 8 or 64 frames per level; 2 frames hide them in noise). */
static const char *margin_hint(const cal_run *r)
{
    return r->res.n_status[WDR_FIT_FLAT] && !r->margin.rounds
               ? "; the board's LUT carries no calibration margin sized for this chip: give --lut FILE, and "
                 "calibrate sizes it on the chip's frames before it calibrates"
               : "";
}

/* More flagged than --max-flagged: EX_DATAERR (the chip's frames do not calibrate), with the
 * count by reason; nothing is written or uploaded, so the board keeps the tables it has. */
static int fail_flagged(const cal_opts *o, const cal_run *r)
{
    char why[512];
    return wdrctl_fail(EX_DATAERR,
                       "calibrate: %ld of %ld pixels flagged (%.4g ppm), more than --max-flagged %s allows (%.4g "
                       "pixels): by kind %s; no table written%s%s",
                       r->res.n_bad, chip_pixels(r), flagged_ppm(r), o->max_flagged.text,
                       cal_flag_limit_pixels(&o->max_flagged, chip_pixels(r)), flag_reasons(&r->res, why, sizeof why),
                       o->upload ? " or uploaded: the board keeps its tables" : "", margin_hint(r));
}

static void print_text_summary(const cal_opts *o, const cal_run *r)
{
    const wdr_cal_result *res = &r->res;
    char why[512], pct[64];
    printf("model %s, table form %s (%d coefficients), %ld of %ld pixels flagged (%.4g ppm; --max-flagged %s allows "
           "%.4g)\n",
           cal_model_name(res->model), cal_form_name(r->cfg.form),
           r->cfg.form == WDR_FORM_MOEBIUS ? 3 : r->cfg.n_coeffs, res->n_bad, chip_pixels(r), flagged_ppm(r),
           o->max_flagged.text, cal_flag_limit_pixels(&o->max_flagged, chip_pixels(r)));
    if (res->n_bad)
        printf("flagged by kind: %s\n", flag_reasons(res, why, sizeof why));
    printf("currents:");
    for (int k = 0; k < r->choice.n; k++)
        printf(" %.4g", r->choice.amps[k]);
    printf(" A (0: dark reference)\nworst contrast error at selection: %s",
           cal_pct_text(r->choice.worst_pct, "levels given, not selected", pct, sizeof pct));
    if (isfinite(r->choice.worst_pct)) /* judged on a sample: what it left out is counted there */
        printf(" (judged on %ld pixels sampled from the probe; %ld of them flagged and left out)", r->choice.judged,
               r->choice.left_out);
    printf("\nframes per level: %d%s\n", r->frames, r->why.frames ? " (auto)" : "");
}

static void print_summary(const cal_opts *o, const cal_run *r, const verify_ctx *v, const verify_result *vr)
{
    const wdr_cal_result *res = &r->res;
    if (!o->json) {
        print_text_summary(o, r);
        if (r->margin.rounds)
            printf("calibration margin: %.1f mV, +%.1f us of integration (sized from the chip's frames)\n",
                   r->margin.margin_v * 1e3, r->margin.added_s * 1e6);
        return;
    }
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "model", cal_model_name(res->model));
    cJSON_AddStringToObject(j, "form", cal_form_name(r->cfg.form));
    cJSON_AddNumberToObject(j, "coefficients", r->cfg.form == WDR_FORM_MOEBIUS ? 3 : r->cfg.n_coeffs);
    cJSON_AddItemToObject(j, "currents_A", cJSON_CreateDoubleArray(r->choice.amps, r->choice.n));
    cJSON_AddNumberToObject(j, "range_lo_A", r->lo);
    cJSON_AddNumberToObject(j, "range_hi_A", r->hi);
    if (isfinite(r->choice.worst_pct)) {
        cJSON_AddNumberToObject(j, "selection_worst_pct", r->choice.worst_pct);
        cJSON_AddNumberToObject(j, "selection_worst_at_A", r->choice.worst_at);
        cJSON_AddNumberToObject(j, "selection_pixels_judged", (double)r->choice.judged);
        cJSON_AddNumberToObject(j, "selection_pixels_left_out", (double)r->choice.left_out);
    }
    cJSON_AddNumberToObject(j, "pixels", (double)chip_pixels(r));
    cJSON_AddNumberToObject(j, "pixels_flagged", (double)res->n_bad);
    cJSON_AddNumberToObject(j, "pixels_flagged_ppm", flagged_ppm(r));
    cJSON *lim = cJSON_AddObjectToObject(j, "max_flagged");
    cJSON_AddStringToObject(lim, "given", o->max_flagged.text);
    cJSON_AddNumberToObject(lim, "pixels", cal_flag_limit_pixels(&o->max_flagged, chip_pixels(r)));
    cJSON_AddBoolToObject(lim, "within", within_flag_limit(o, r));
    cJSON_AddNumberToObject(j, "frames_per_level", r->frames);
    if (r->why.frames) { /* --frames auto: the level that decided and its figures */
        cJSON *a = cJSON_AddObjectToObject(j, "frames_auto");
        cJSON_AddNumberToObject(a, "target_pct", r->why.target_pct);
        cJSON_AddNumberToObject(a, "decided_at_A", r->why.at_amps);
        cJSON_AddNumberToObject(a, "noise_codes_per_frame", r->why.sigma_codes);
        cJSON_AddNumberToObject(a, "slope_codes_per_ln_A", r->why.slope);
        cJSON_AddNumberToObject(a, "wanted_codes", r->why.want_codes);
        cJSON_AddNumberToObject(a, "frames_needed", r->why.needed);
        cJSON_AddBoolToObject(a, "capped", r->why.capped);
    }
    if (r->margin.rounds) { /* the ramp's calibration margin, sized from the chip's frames */
        cJSON *m = cJSON_AddObjectToObject(j, "calibration_margin");
        cJSON_AddNumberToObject(m, "margin_mV", r->margin.margin_v * 1e3);
        cJSON_AddNumberToObject(m, "added_integration_us", r->margin.added_s * 1e6);
        cJSON_AddNumberToObject(m, "latest_above_median_mV", r->margin.latest_v * 1e3);
        cJSON_AddNumberToObject(m, "crossing_level_sd_mV", r->margin.spread_v * 1e3);
        cJSON_AddNumberToObject(m, "guard_mV", r->margin.guard_v * 1e3);
        cJSON_AddNumberToObject(m, "at_A", r->margin.dim_a);
        cJSON_AddNumberToObject(m, "probe_rounds", r->margin.rounds);
    }
    cJSON *f = cJSON_AddObjectToObject(j, "flags"); /* one kind per pixel: these add up to pixels_flagged */
    for (int b = 0; b < WDR_CAL_FLAG_KINDS; b++)
        cJSON_AddNumberToObject(f, wdr_cal_flag_name(b), (double)res->n_flag[b]);
    cJSON *why = cJSON_AddObjectToObject(j, "unfit_reasons");
    for (int st = 1; st < WDR_FIT_COUNT; st++)
        if (res->n_status[st])
            cJSON_AddNumberToObject(why, wdr_fit_status_name(st), (double)res->n_status[st]);
    cJSON_AddNumberToObject(j, "table_bytes", (double)r->table_len);
    if (r->form_auto.tried)
        cJSON_AddItemToObject(j, "form_auto", cal_form_choice_json(&r->form_auto));
    if (vr->n)
        cJSON_AddItemToObject(j, "verification", verification_json(v, r, vr));
    cJSON_AddItemToObject(j, "nominal_response", nominal_json(r));
    char *text = cJSON_Print(j);
    printf("%s\n", text);
    free(text);
    cJSON_Delete(j);
}

static int upload_table(device_src *d, const char *address, const cal_run *r)
{
    int rc = wdr_cal_board_store_table(&d->board, r->table, r->table_len);
    if (rc && d->conn.c->commit_unknown)
        return wdrctl_commit_outcome(&d->conn, address, WDR_KIND_CAL, r->table, r->table_len);
    if (rc)
        return wdrctl_conn_fail(&d->conn, rc);
    fprintf(stderr, "wdrctl: calibration table uploaded and active\n");
    return EX_OK;
}

static int calibrate_with(const cal_opts *o, const wdr_cal_source *src, cal_run *r, uint32_t sensor_id, int op_id,
                          int model, const verify_ctx *v)
{
    verify_result vr = {0};
    r->cfg.design = v->design; /* end slopes from the designed response */
    int least = cal_min_select(model, r->cfg.n_coeffs);
    if (o->select_n && o->select_n < least)
        return wdrctl_fail(EX_USAGE, "calibrate: --select %d: model %s needs at least %d levels (--select %d..%d)",
                           o->select_n, cal_model_name(model), least, least, GRID_LEVELS);
    int rc = cal_plan_currents(o, src, r, o->select_n ? o->select_n : cal_default_currents(model));
    cal_form_frames_how how = {v->can_light, v->temporal};
    r->table_later = o->form == CAL_FORM_AUTO && model == WDR_MODEL_SPLINE;
    if (rc == EX_OK)
        rc = cal_acquire_and_fit(o, src, r, sensor_id, op_id);
    if (rc == EX_OK && !within_flag_limit(o, r)) { /* the figures, then the failure: no table leaves */
        print_summary(o, r, v, &vr);
        return fail_flagged(o, r);
    }
    if (rc == EX_OK && r->table_later)
        rc = cal_choose_form(src, &how, sensor_id, op_id, r);
    if (rc == EX_OK && o->out)
        rc = write_file(o->out, r->table, r->table_len);
    if (rc == EX_OK)
        rc = verify(o, src, r, v, &vr);
    if (rc == EX_OK)
        print_summary(o, r, v, &vr);
    return rc;
}

static const cli_option calibrate_rows[] = {
    {"output", 'o', CLI_STRING, CAL_O(out), "CAL.bin", "where the calibration table goes"},
    {"model", 0, CLI_STRING, CAL_O(models), "NAME", "spline, simple3, complex4, lsq or polymap (default spline)",
     .values = "spline simple3 complex4 lsq polymap"},
    {"models", 0, CLI_STRING, CAL_O(models), "NAME", "the same as --model", .flags = CLI_HIDDEN},
    {"currents", 0, CLI_STRING, CAL_O(currents), "A,B,..", "the light levels, in A per pixel, rising"},
    {"levels-file", 0, CLI_STRING, CAL_O(levels_file), "FILE", "the light levels, one per line (# comments)"},
    {"select", 0, CLI_INT, CAL_O(select_n), "N",
     "choose N levels from a probe (the model's least: simple3 3, complex4 and spline 4, polymap 6, lsq 7)",
     .min = CAL_SELECT_MIN, .max = GRID_LEVELS},
    CAL_ROW_FRAMES,
    CAL_ROW_BOARD,
    CAL_ROW_OPERATOR,
    CAL_ROW_ADC,
    CAL_ROW_DAC,
    CAL_ROW_NOISE,
    {"lut", 0, CLI_STRING, CAL_O(lut), "LUT.bin", "with --device: image with this LUT (stored with a margin; its exposure table anchored at the calibration's levels)"},
    {"upload", 0, CLI_FLAG, CAL_O(upload), NULL, "with --device: store the table on the board and apply it"},
    {"max-flagged", 0, CLI_STRING, CAL_O(max_flagged_text), "N|Nppm",
     "fail (exit 65, no table written or uploaded) when more pixels are flagged: N pixels, or N parts per million "
     "of the chip (default " CAL_MAX_FLAGGED_DEFAULT ")"},
    CAL_ROW_OUT_SCALE,
    {"form", 0, CLI_CHOICE, CAL_O(form), NULL,
     "table form; auto (default): the smallest whose error, measured on this chip's frames, is within max(1 %, "
     "1.2x the fit's own) at every judged current; none: the nearest to it",
     .choices = cal_forms, .what = "table form"},
    CAL_ROW_SAMPLE,
    CAL_ROW_SEED,
    CAL_ROW_JSON,
    {0}};

const cli_command wdrctl_cmd_calibrate = {
    "calibrate",
    NULL,
    0,
    0,
    "fixed-pattern-noise calibration of the simulated chip, or of a board (--device)",
    "Give -o CAL.bin and/or --upload. A simulated board sets its own light; a real one asks for each level of "
    "--currents or --levels-file. One connection serves the whole run; the global --wait looks for a board that is "
    "starting. A board with no LUT is refused up front (exit 78): upload one or give --lut. When the fit flags more "
    "pixels than --max-flagged, calibrate prints the count by kind and exits 65 (EX_DATAERR: the chip's frames do "
    "not calibrate) without writing or uploading a table. Every printed figure says how many pixels it left out.",
    calibrate_rows,
    cmd_calibrate,
    CLI_CMD_BOARD};

/* The simulated chip's conditions, as the verification figures hold with them. */
static const char *sim_conditions(const cal_opts *o)
{
    static const char *names[2][2] = {
        {"simulated chip: converters (partly) off, temporal noise off",
         "simulated chip: converters (partly) off, temporal noise on"},
        {"simulated chip: ADC and DAC on, temporal noise off", "simulated chip: ADC and DAC on, temporal noise on"}};
    return names[o->adc && o->dac][o->noise != 0];
}

int cmd_calibrate(int argc, char **argv)
{
    cal_opts o;
    wdr_board b;
    int model = WDR_MODEL_SPLINE, rc = cal_parse_options(argc, argv, &wdrctl_cmd_calibrate, &o);
    if (rc != EX_OK || (o.models && (rc = cal_model_from_name(o.models, &model)) != EX_OK))
        return rc;
    if (!o.out && !o.upload)
        return wdrctl_fail(EX_USAGE, "calibrate: give -o CAL.bin and/or --upload");
    if ((o.upload || o.lut) && !o.device)
        return wdrctl_fail(EX_USAGE, "calibrate: --upload and --lut need --device");
    if (o.noise_asked && o.device)
        return wdrctl_fail(EX_USAGE,
                           "calibrate: option --noise sets the simulated chip's noise; the board at %s "
                           "has its own (give --board to calibrate the simulator)",
                           o.device);
    cal_run r = {0};
    wdr_cal_config_defaults(&r.cfg, model);
    if (o.form == WDR_FORM_MOEBIUS && model != WDR_MODEL_SIMPLE3)
        return wdrctl_fail(EX_USAGE, "calibrate: --form moebius is exact only for --model simple3");
    if (o.form != CAL_FORM_AUTO)
        r.cfg.form = o.form;
    if (wdr_cal_form_compact((uint16_t)o.form))
        r.cfg.n_coeffs = WDR_CAL_COMPACT_COEFFS;
    if (o.device) {
        device_src d;
        memset(&d, 0, sizeof d); /* closed below even when no connection was opened */
        wdr_cal_source src;
        verify_ctx v = {.quantised = 1, .temporal = 1, .holds_with = "the board as it runs (its converters and noise)"};
        wdr_cal_design design;
        int op_id = WDR_OP_REINHARD;
        if ((rc = device_operator(&o, &op_id)) == EX_OK && (rc = open_device(&o, &d, &src)) == EX_OK && (rc = load_device_board(&o, &d.conn.c->info, &b)) == EX_OK &&
            (rc = cal_design_for(&b, o.op_name, 0, &design)) == EX_OK && (rc = verify_display(&o, &b, &v)) == EX_OK &&
            (!o.lut || (rc = upload_lut_with_margin(&d, o.lut, &b, &src, &design, &r.margin)) == EX_OK) &&
            (rc = require_lut(&d, o.device)) == EX_OK) {
            cal_set_output(&o, &r.cfg, d.conn.c->info.adc_bits);
            cal_set_step(&b, &r.cfg); /* the DAC and ADC ranges of the board's file */
            v.can_light = d.board.simulated, v.design = &design;
            rc = calibrate_with(&o, &src, &r, d.conn.c->info.sensor_id, op_id, model, &v);
            if (rc == EX_OK && o.lut)
                rc = anchor_exposure(&d, o.lut, &b, &r);
            if (rc == EX_OK && o.upload)
                rc = upload_table(&d, o.device, &r);
        }
        rc = close_device(&d, rc);
        cal_free_run(&r);
        return rc;
    }
    sim_chip c;
    const wdr_operator_info *op = wdr_operator_info_by_name(o.op_name);
    if (!op)
        return wdrctl_fail(EX_USAGE, "calibrate: unknown operator '%s' (see 'wdrctl operators')", o.op_name);
    if ((rc = cal_load_board(o.board, &b)) != EX_OK || (rc = cal_open_sim(&o, &b, &c)) != EX_OK)
        return rc;
    cal_set_output(&o, &r.cfg, (unsigned)b.adc_bits);
    if (o.dac)
        cal_set_step(&b, &r.cfg);
    r.cfg.tie_codes = o.adc ? r.cfg.tie_codes : 1e-3; /* unquantised codes: only a clipped pixel ties */
    wdr_cal_source src = {b.width, b.height, wdr_cal_sim_capture, &c.ss};
    verify_ctx v = {
        .can_light = 1, .quantised = o.adc, .temporal = o.noise, .design = &c.design, .holds_with = sim_conditions(&o)};
    rc = verify_display(&o, &b, &v);
    r.margin = c.margin;
    if (rc == EX_OK)
        rc = calibrate_with(&o, &src, &r, b.sensor_id, op->id, model, &v);
    cal_free_run(&r);
    cal_close_sim(&c);
    return rc;
}
