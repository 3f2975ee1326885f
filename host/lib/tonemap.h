/* From sensor codes back to display values, and the software tone mapping they are compared
 * with: the demo's side-by-side and the users' sanity check of a capture. */
#ifndef WDR_TONEMAP_H
#define WDR_TONEMAP_H
#include "ramp.h"
#include <stdint.h>

/* Display value T in [0,1] that a nominal pixel reports with ADC code `code` (raw or
 * corrected: a calibration table outputs nominal-pixel codes): undo the ADC, the source
 * follower (closed form) and g = v_dark - swing T. */
double wdr_code_to_display(const wdr_ideal_pixel *px, const wdr_board *b, double code);

/* A response as codes at rising ln x (codes falling: brighter light, lower code), e.g. the nominal
 * response a calibration maps every pixel onto (`wdrctl calibrate --json`, "nominal_response"). */
typedef struct wdr_response_curve {
    int n;
    const double *ln_x, *code;
} wdr_response_curve;

/* Photocurrent (A) that code stands for on the curve: linear in ln x between its points, clamped
 * to its ends. */
double wdr_response_current(const wdr_response_curve *c, double code);

/* Display value T in [0,1] of a corrected code: through the calibration's own nominal response
 * (droop and dark current included, as the array answered) to the current, then the operator,
 * T(k x). The ideal-pixel mapping above assumes a pixel without droop: a corrected capture's
 * shadows then come out brighter than the software tone map (+2 levels at 1e-14 A). */
double wdr_code_to_display_curve(const wdr_response_curve *c, const wdr_operator *op, double lum_per_amp, double code);

/* Display-linear T to an 8-bit sRGB-like grey level (gamma 1/2.2). */
uint8_t wdr_display_to_u8(double t);

/* Side by side: two w*h grey 8-bit images with a 4-pixel white gap, under a white band that
 * names each half (left_label over the left, right_label over the right), as RGB of
 * WDR_SIDE_BY_SIDE_W(w) x wdr_side_by_side_h(w, h) pixels. */
#define WDR_SIDE_BY_SIDE_W(w) (2 * (w) + 4)
int wdr_side_by_side_h(int w, int h);
void wdr_side_by_side(const uint8_t *left, const uint8_t *right, int w, int h, const char *left_label,
                      const char *right_label, uint8_t *rgb);

#endif
