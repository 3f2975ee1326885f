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

/* Display-linear T to an 8-bit sRGB-like grey level (gamma 1/2.2). */
uint8_t wdr_display_to_u8(double t);

/* Side by side: two w*h grey 8-bit images with a 4-pixel white gap, as RGB (3*(2w+4)*h bytes). */
void wdr_side_by_side(const uint8_t *left, const uint8_t *right, int w, int h, uint8_t *rgb);

#endif
