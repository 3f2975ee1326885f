/* wdrctl calibrate: fixed-pattern-noise calibration of the simulator itself (default) or of a
 * board (--device): a simulated board sets its illuminant, a real one asks a person to set each
 * light level. The frame source for a board is host/cal/cal_board_source.c. */
#include "cal_board_source.h"
#include "cal_common.h"
#include "file_io.h"
#include "operators.h"
#include "transport_client.h"
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

/* The LUT file the board will image with, stored with the calibration margin. */
static int upload_lut_with_margin(device_src *d, const char *path)
{
    uint8_t *buf;
    size_t len;
    char err[512];
    double added_s, done_v;
    if (wdr_read_file(path, &buf, &len) != WDR_OK)
        return wdrctl_fail(EX_NOINPUT, "%s: cannot read LUT", path);
    int rc = wdr_cal_board_store_lut(&d->board, buf, len, &added_s, &done_v, err, sizeof err);
    free(buf);
    if (rc == WDR_E_INVAL || rc == WDR_E_NOMEM)
        return wdrctl_fail(EX_DATAERR, "%s: %s", path, rc == WDR_E_NOMEM ? "out of memory" : err);
    if (rc)
        return wdrctl_conn_fail(&d->conn, rc);
    fprintf(stderr, "wdrctl: %s stored with a %.0f mV calibration margin (+%.3g s of integration)\n", path,
            done_v * 1e3, added_s);
    return EX_OK;
}

static int open_device(const cal_opts *o, device_src *d, wdr_cal_source *src)
{
    memset(d, 0, sizeof *d);
    int rc = wdrctl_connect(o->device, WDR_CLIENT_TIMEOUT_MS, WDR_CLIENT_RETRIES, &d->conn);
    if (rc != EX_OK)
        return rc;
    const wdr_info *in = &d->conn.c->info;
    if (wdr_cal_board_open(&d->board, d->conn.c, prompt_level, src) != WDR_OK)
        return wdrctl_fail(EX_OSERR, "out of memory for a %ux%u frame", in->width, in->height);
    if (!d->board.simulated && !o->currents && !o->levels_file)
        return wdrctl_fail(EX_USAGE, "calibrate: %s sets no light itself: give the levels you will set with "
                           "--currents A,B,.. or --levels-file FILE (you are asked for each)", o->device);
    if (o->lut && (rc = upload_lut_with_margin(d, o->lut)) != EX_OK)
        return rc;
    int r = wdr_cal_board_store_passthrough(&d->board);
    if (r)
        return wdrctl_conn_fail(&d->conn, r);
    return EX_OK;
}

static void close_device(device_src *d)
{
    wdr_cal_board_close(&d->board);
    wdrctl_disconnect(&d->conn);
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

static void print_summary(const cal_opts *o, const cal_run *r)
{
    const wdr_cal_result *res = &r->res;
    if (!o->json) {
        printf("model %s, table form %s (%d coefficients), %ld of %ld pixels flagged\ncurrents:", cal_model_name(res->model),
               cal_form_name(r->cfg.form), r->cfg.form == WDR_FORM_MOEBIUS ? 3 : r->cfg.n_coeffs,
               res->n_bad, (long)res->width * res->height);
        for (int k = 0; k < r->choice.n; k++)
            printf(" %.4g", r->choice.amps[k]);
        printf(" A (0: dark reference)\nworst contrast error at selection: %.4g %%\n", r->choice.worst_pct);
        printf("frames per level: %d%s\n", r->frames, r->why.frames ? " (auto)" : "");
        return;
    }
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "model", cal_model_name(res->model));
    cJSON_AddStringToObject(j, "form", cal_form_name(r->cfg.form));
    cJSON_AddNumberToObject(j, "coefficients", r->cfg.form == WDR_FORM_MOEBIUS ? 3 : r->cfg.n_coeffs);
    cJSON_AddItemToObject(j, "currents_A", cJSON_CreateDoubleArray(r->choice.amps, r->choice.n));
    cJSON_AddNumberToObject(j, "range_lo_A", r->lo);
    cJSON_AddNumberToObject(j, "range_hi_A", r->hi);
    if (isfinite(r->choice.worst_pct))
        cJSON_AddNumberToObject(j, "selection_worst_pct", r->choice.worst_pct);
    cJSON_AddNumberToObject(j, "pixels_flagged", (double)res->n_bad);
    cJSON_AddNumberToObject(j, "frames_per_level", r->frames);
    if (r->why.frames) { /* --frames auto: the level that decided and its figures */
        cJSON *a = cJSON_AddObjectToObject(j, "frames_auto");
        cJSON_AddNumberToObject(a, "target_pct", r->why.target_pct);
        cJSON_AddNumberToObject(a, "decided_at_A", r->why.at_amps);
        cJSON_AddNumberToObject(a, "noise_codes_per_frame", r->why.sigma_codes);
        cJSON_AddNumberToObject(a, "slope_codes_per_ln_A", r->why.slope);
        cJSON_AddNumberToObject(a, "wanted_codes", r->why.want_codes);
        cJSON_AddBoolToObject(a, "capped", r->why.capped);
    }
    static const char *flag_names[] = {"dead", "stuck", "hot", "saturated", "unfit"};
    cJSON *f = cJSON_AddObjectToObject(j, "flags");
    for (int b = 0; b < 5; b++)
        cJSON_AddNumberToObject(f, flag_names[b], (double)res->n_flag[b]);
    cJSON *why = cJSON_AddObjectToObject(j, "unfit_reasons");
    for (int st = 1; st < WDR_FIT_COUNT; st++)
        if (res->n_status[st])
            cJSON_AddNumberToObject(why, wdr_fit_status_name(st), (double)res->n_status[st]);
    cJSON_AddNumberToObject(j, "table_bytes", (double)r->table_len);
    char *text = cJSON_Print(j);
    printf("%s\n", text);
    free(text);
    cJSON_Delete(j);
}

static int upload_table(device_src *d, const cal_run *r)
{
    int rc = wdr_cal_board_store_table(&d->board, r->table, r->table_len);
    if (rc)
        return wdrctl_conn_fail(&d->conn, rc);
    fprintf(stderr, "wdrctl: calibration table uploaded and active\n");
    return EX_OK;
}

static int calibrate_with(const cal_opts *o, const wdr_cal_source *src, cal_run *r, uint32_t sensor_id, int op_id,
                          int model)
{
    int rc = cal_plan_currents(o, src, r, o->select_n ? o->select_n : cal_default_currents(model));
    if (rc == EX_OK)
        rc = cal_acquire_and_fit(o, src, r, sensor_id, op_id);
    if (rc == EX_OK && o->out)
        rc = write_file(o->out, r->table, r->table_len);
    if (rc == EX_OK)
        print_summary(o, r);
    return rc;
}

int cmd_calibrate(int argc, char **argv)
{
    cal_opts o;
    wdr_board b;
    int model = WDR_MODEL_SPLINE, rc = cal_parse_options(argc, argv, "calibrate", &o);
    if (rc != EX_OK || (o.models && (rc = cal_model_from_name(o.models, &model)) != EX_OK))
        return rc;
    if (!o.out && !o.upload)
        return wdrctl_fail(EX_USAGE, "calibrate: give -o CAL.bin and/or --upload");
    if ((o.upload || o.lut) && !o.device)
        return wdrctl_fail(EX_USAGE, "calibrate: --upload and --lut need --device");
    cal_run r = {0};
    wdr_cal_config_defaults(&r.cfg, model);
    if (o.form == WDR_FORM_MOEBIUS && model != WDR_MODEL_SIMPLE3)
        return wdrctl_fail(EX_USAGE, "calibrate: --form moebius is exact only for --model simple3");
    if (o.form >= 0)
        r.cfg.form = o.form;
    if (o.device) {
        device_src d;
        wdr_cal_source src;
        if ((rc = open_device(&o, &d, &src)) == EX_OK && (rc = cal_load_board(o.board, &b)) == EX_OK) {
            cal_set_output(&o, &r.cfg, d.conn.c->info.adc_bits);
            cal_set_step(&b, &r.cfg); /* the DAC and ADC ranges of the board file (--board, default sim-vga) */
            rc = calibrate_with(&o, &src, &r, d.conn.c->info.sensor_id, WDR_OP_REINHARD, model);
            if (rc == EX_OK && o.upload)
                rc = upload_table(&d, &r);
        }
        close_device(&d);
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
    rc = calibrate_with(&o, &src, &r, b.sensor_id, op->id, model);
    cal_free_run(&r);
    cal_close_sim(&c);
    return rc;
}
