/* A board as the calibration frame source (see cal_board_source.h). */
#include "cal_board_source.h"
#include "cal_margin.h"
#include "ramp.h"
#include "wdr_cal.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include "wdr_proto.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int on_board_frame(void *ctx, const wdr_frame *f)
{
    wdr_cal_board *d = ctx;
    for (long i = 0; i < (long)f->width * f->height; i++)
        d->frame[i] = f->codes[i];
    return WDR_OK;
}

static int board_capture(void *ctx, double amps, int frame_no, float *frame)
{
    wdr_cal_board *d = ctx;
    (void)frame_no;
    if (amps != d->amps) {
        int rc = d->simulated ? wdr_client_set_illuminant(d->client, amps) : d->ask_level(amps);
        if (rc)
            return rc;
        d->amps = amps;
    }
    d->frame = frame;
    return wdr_client_capture_raw(d->client, 1, d->codes, on_board_frame, d); /* no table changed for it */
}

int wdr_cal_board_open(wdr_cal_board *d, wdr_client *client, wdr_cal_ask_level_fn ask, wdr_cal_source *src)
{
    memset(d, 0, sizeof *d);
    d->client = client;
    d->amps = -1;
    d->ask_level = ask;
    const wdr_info *in = &client->info;
    d->codes = malloc(sizeof(uint16_t) * (size_t)in->width * in->height);
    if (!d->codes)
        return WDR_E_NOMEM;
    d->simulated = (in->caps & WDR_INFO_CAP_ILLUMINANT) != 0;
    *src = (wdr_cal_source){in->width, in->height, board_capture, d};
    return WDR_OK;
}

int wdr_cal_board_close(wdr_cal_board *d)
{
    int rc = WDR_OK;
    if (d->simulated && d->amps >= 0) /* we lit it: every later capture must see the scene again */
        rc = wdr_client_restore_scene(d->client);
    d->amps = -1;
    free(d->codes);
    d->codes = NULL;
    return rc;
}

int wdr_cal_lut_for_board(const uint8_t *lut, size_t len, const wdr_board *physics, double margin_v, uint8_t **out,
                          size_t *out_len, double *added_s, double *done_v, char *err, int errlen)
{
    int rc = wdr_cal_lut_with_margin(lut, len, margin_v, out, out_len, added_s, done_v, err, errlen);
    if (rc)
        return rc;
    /* the margin lengthens the integration: every crossed pixel holds that much longer */
    if (physics && (rc = wdr_ramp_lut_refresh_droop(*out, *out_len, physics)) != WDR_OK) {
        snprintf(err, (size_t)errlen, "the LUT's exposure block with the margin: %s", wdr_strerror(rc));
        free(*out);
        *out = NULL;
    }
    return rc;
}

int wdr_cal_board_upload_lut(wdr_cal_board *d, const uint8_t *lut, size_t len)
{
    wdr_commit_reply reply;
    return wdr_client_upload(d->client, WDR_KIND_LUT, lut, len, NULL, NULL, &reply);
}

int wdr_cal_board_store_lut(wdr_cal_board *d, const uint8_t *lut, size_t len, const wdr_board *physics,
                            double margin_v, double *added_s, double *done_v, char *err, int errlen)
{
    uint8_t *ext = NULL;
    size_t ext_len;
    int rc = wdr_cal_lut_for_board(lut, len, physics, margin_v, &ext, &ext_len, added_s, done_v, err, errlen);
    if (rc)
        return rc;
    rc = wdr_cal_board_upload_lut(d, ext, ext_len);
    free(ext);
    return rc;
}

int wdr_cal_board_has_lut(wdr_cal_board *d, int *has_lut)
{
    wdr_status_report st;
    int rc = wdr_client_status(d->client, &st);
    *has_lut = rc == WDR_OK && st.lut_slot != WDR_SLOT_NONE;
    return rc;
}

int wdr_cal_board_store_table(wdr_cal_board *d, const uint8_t *table, size_t len)
{
    wdr_commit_reply reply;
    return wdr_client_upload(d->client, WDR_KIND_CAL, table, len, NULL, NULL, &reply);
}

int wdr_cal_board_set_margin(void *ctx, double margin_v, double *done_v, double *added_s, char *err, int errlen)
{
    wdr_cal_board_lut *l = ctx;
    int rc = wdr_cal_board_store_lut(l->board, l->lut, l->len, l->physics, margin_v, added_s, done_v, err, errlen);
    if (rc && rc != WDR_E_INVAL && rc != WDR_E_NOMEM)
        snprintf(err, (size_t)errlen, "storing the LUT with a %.1f mV margin: %s", margin_v * 1e3,
                 l->board->client->err[0] ? l->board->client->err : wdr_strerror(rc));
    return rc;
}
