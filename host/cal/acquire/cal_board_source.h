/* A board as the calibration frame source: frames captured over the protocol client, the
 * light set by the board itself (a simulated board, INFO capability ILLUMINANT) or by a person
 * (asked through a callback), and the tables calibration stores on the board when asked to.
 * Frames are captured raw (WDR_CAPTURE_RAW): the board's calibration table stays as it was. */
#ifndef CAL_BOARD_SOURCE_H
#define CAL_BOARD_SOURCE_H
#include "cal_engine.h"
#include "transport_client.h"
#include <stddef.h>
#include <stdint.h>

/* Ask a person to set a uniform light giving amps per pixel (0: dark). @retval WDR_OK, WDR_E_IO */
typedef int (*wdr_cal_ask_level_fn)(double amps);

typedef struct wdr_cal_board {
    wdr_client *client;
    int simulated;               /* the board takes SET_ILLUMINANT */
    double amps;                 /* level the light is at (-1: unknown) */
    uint16_t *codes;             /* one frame of raw codes */
    float *frame;                /* where the frame being captured goes */
    wdr_cal_ask_level_fn ask_level;
} wdr_cal_board;

/* Wrap a connected client; *src then captures from the board.
 * @retval WDR_OK, WDR_E_NOMEM */
int wdr_cal_board_open(wdr_cal_board *d, wdr_client *client, wdr_cal_ask_level_fn ask, wdr_cal_source *src);
/* Done with the board: a simulated board that calibration lit goes back to its scene, whether
 * calibration succeeded or not. @retval WDR_OK, or the client's error putting the scene back */
int wdr_cal_board_close(wdr_cal_board *d);

/* Store the LUT the board will image with, continued past its last code by margin_v of
 * calibration margin (wdr_cal_lut_with_margin), so that pixels with high thresholds cross at the
 * dimmest currents. *added_s and *done_v report the extension. With physics (the board file),
 * an exposure block's droop array is computed again for the longer integration.
 * @retval WDR_OK; WDR_E_INVAL or WDR_E_NOMEM from the extension (err says why); the client's error */
int wdr_cal_board_store_lut(wdr_cal_board *d, const uint8_t *lut, size_t len, const wdr_board *physics,
                            double margin_v, double *added_s, double *done_v, char *err, int errlen);

/* The two halves of wdr_cal_board_store_lut: the bytes it stores (*out malloc'd; the extension's
 * and the droop refresh's errors, err says which), and storing given bytes as the active LUT (the
 * client's error): calibrate stores the LUT again once its exposure block is anchored at the
 * calibration's levels (table/cal_exposure.h), which acquisition cannot call. */
int wdr_cal_lut_for_board(const uint8_t *lut, size_t len, const wdr_board *physics, double margin_v, uint8_t **out,
                          size_t *out_len, double *added_s, double *done_v, char *err, int errlen);
int wdr_cal_board_upload_lut(wdr_cal_board *d, const uint8_t *lut, size_t len);

/* The board's margin setter for wdr_cal_margin_size (cal_margin.h): ctx is a wdr_cal_board_lut,
 * the LUT file's bytes, stored again with each margin tried. */
typedef struct wdr_cal_board_lut {
    wdr_cal_board *board;
    const uint8_t *lut;
    size_t len;
    const wdr_board *physics; /* the board file: the exposure block's droop is refitted to the margin (NULL: kept) */
} wdr_cal_board_lut;
int wdr_cal_board_set_margin(void *ctx, double margin_v, double *done_v, double *added_s, char *err, int errlen);

/* Whether the board plays a LUT (STATUS: an active LUT slot): without one it refuses every
 * capture, so calibration asks before it captures. @retval WDR_OK (*has_lut set), or the client's error */
int wdr_cal_board_has_lut(wdr_cal_board *d, int *has_lut);

/* Store a calibration table and make it active. @retval WDR_OK, or the client's error */
int wdr_cal_board_store_table(wdr_cal_board *d, const uint8_t *table, size_t len);

#endif
