/* Text drawn into RGB images without a font library: a 5x7 bitmap font of the capitals, digits
 * and a few signs, scaled by whole pixels. For the labels of the side-by-side images. */
#ifndef WDR_LABEL_FONT_H
#define WDR_LABEL_FONT_H
#include <stdint.h>

#define WDR_LABEL_GLYPH_W 5
#define WDR_LABEL_GLYPH_H 7

/* Draw text (capitals, digits, space, ( ) - . : /; anything else as a box) at (x, y), its top
 * left, each font pixel a scale x scale square of grey level ink, into an RGB image of width
 * stride and height h; what falls outside is clipped. */
void wdr_label_draw(uint8_t *rgb, int stride, int h, int x, int y, int scale, uint8_t ink, const char *text);

/* Width in image pixels of text at scale (one font column between glyphs). */
int wdr_label_width(const char *text, int scale);

#endif
