/* What acquisition hands to the rest of calibration: averaged frames at known photocurrents.
 * Apart from the fits (cal_fit.h) so that acquisition and the statistics need nothing later in
 * the pipeline. */
#ifndef WDR_CAL_LEVELS_H
#define WDR_CAL_LEVELS_H

#define WDR_CAL_MAX_LEVELS 48
#define WDR_PCHIP_MAX 64 /* knots of a curve through the levels (and the statistics' scratch) */

/* Averaged frames: frames[k * width * height + pixel] is the mean code at amps[k]. Levels rise
 * strictly in amps; dark (may be NULL) is a frame with no light, used for hot pixels and DSNU. */
typedef struct wdr_cal_levels {
    int width, height, n;
    double amps[WDR_CAL_MAX_LEVELS];
    float *frames;
    float *dark;
    /* Temporal noise measured from the frames themselves (wdr_cal_acquire with m_avg >= 2):
     * noise[k] is one frame's sd at level k (codes, RMS over the array), dark_noise the dark
     * frame's; m_avg frames were averaged. m_avg 0: not measured (ties judged by tie_codes alone). */
    double noise[WDR_CAL_MAX_LEVELS], dark_noise;
    int m_avg;
} wdr_cal_levels;

#endif
