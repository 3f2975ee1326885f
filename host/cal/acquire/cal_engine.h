/* Calibration acquisition: uniform frames at chosen photocurrents plus a dark frame, M frames
 * averaged per level, from any frame source (the simulator directly, a board through the
 * protocol, or a real board with a person setting the light). */
#ifndef WDR_CAL_ENGINE_H
#define WDR_CAL_ENGINE_H
#include "cal_levels.h"
#include "wdr_sim.h"
#include <stdint.h>

/* Capture one frame of width*height codes under uniform photocurrent amps (0: dark).
 * frame_no counts every capture of the run. @retval WDR_OK or a negative enum wdr_err */
typedef int (*wdr_cal_capture_fn)(void *ctx, double amps, int frame_no, float *frame);

typedef struct wdr_cal_source {
    int width, height;
    wdr_cal_capture_fn capture;
    void *ctx;
} wdr_cal_source;

/* Told after every captured frame: done of total frames, at the level's current. */
typedef void (*wdr_cal_progress_fn)(void *ctx, int done, int total, double amps);

/* Calibration currents closer than this (relative) are refused by wdr_cal_acquire: the
 * response difference between them is below what the fits can use. */
#define WDR_CAL_MIN_SEPARATION 0.01

/* Capture n levels (amps rising, > 0, at least WDR_CAL_MIN_SEPARATION apart) and, with with_dark, a dark frame, m_avg frames each.
 * out->frames and out->dark are malloc'd (wdr_cal_levels_free).
 * @retval WDR_OK
 * @retval WDR_E_INVAL  bad counts or currents (err names which)
 * @retval WDR_E_NOMEM
 * @retval the source's error, with err naming the level */
int wdr_cal_acquire(const wdr_cal_source *src, const double *amps, int n, int m_avg, int with_dark,
                    wdr_cal_progress_fn progress, void *pctx, wdr_cal_levels *out, char *err, int errlen);
void wdr_cal_levels_free(wdr_cal_levels *lv);

/* Pick levels (by index, rising) out of a larger acquisition into a new one (frames copied,
 * no dark frame). Index -1, first only, takes the dark frame as a level at 0 A (the paper's
 * dark reference). @retval WDR_OK, WDR_E_INVAL, WDR_E_NOMEM */
int wdr_cal_levels_subset(const wdr_cal_levels *all, const int *idx, int n, wdr_cal_levels *out);

/* ---- the simulator as a frame source ---- */
typedef struct wdr_cal_simsrc {
    wdr_sim *sim;
    int quantised;       /* 1: 16-bit ADC codes as the board sends them; 0: unquantised (studies) */
    uint64_t seed;       /* frame seeds are seed + frame_no */
} wdr_cal_simsrc;

int wdr_cal_sim_capture(void *ctx, double amps, int frame_no, float *frame);

/* A chip of board b tone-mapping with operator op_name (default parameters): static effects on
 * (mismatch, dark current, DAC steps, leakage, clipping), temporal noise off, ADC quantisation
 * as asked. The LUT gets a calibration margin of margin_v (wdr_cal_lut_extend; 0: none).
 * *lut_bytes is malloc'd and must outlive the chip's use of the LUT.
 * @retval WDR_OK, WDR_E_NOMEM, or the LUT builder's error (err says which) */
int wdr_cal_sim_setup(const wdr_board *b, const char *op_name, uint64_t chip_seed, int adc_quant, double margin_v,
                      wdr_sim **sim, uint8_t **lut_bytes, char *err, int errlen);

/* A fixed calibration margin, for the tests and the study that use one chip of the 0.35 um
 * defaults: 60 mV is about six sigma of their reset-level and M2-threshold spread, in at most twice
 * the ramp's integration time. It is not enough for every chip (twice the mismatch left 87 pixels
 * flat; Tumblin-Rushmeier's slow end got 37 mV): wdrctl calibrate sizes the margin from the
 * chip's frames instead (cal_margin.h). */
#define WDR_CAL_MARGIN_V 0.06
#define WDR_CAL_MARGIN_MAX_TIME_FRAC 2.0

/* Continue a LUT's ramp at its final slope for margin_v volts, so pixels with thresholds above
 * nominal still cross at the dimmest current and in the dark frame. The extension stops early
 * at max_time_frac of the integration time or the DAC's top code: *margin_done_v says how far
 * it got, *added_s how much integration time it added. One entry per extra code, or per tick
 * where the ramp ends steeper than one code per tick (times always rise).
 * *out is malloc'd. @retval WDR_OK, WDR_E_INVAL (err says why: flat end, no room), WDR_E_NOMEM,
 *         or the LUT parser's error */
int wdr_cal_lut_extend(const uint8_t *in, size_t in_len, double margin_v, double max_time_frac, uint8_t **out,
                       size_t *out_len, double *added_s, double *margin_done_v, char *err, int errlen);

#endif
