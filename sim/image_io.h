/* Image files written and read by the host tools: PNG (8/16-bit grey, libpng) and PFM
 * (float, little-endian, bottom-up rows as the format requires). */
#ifndef WDR_IMAGE_IO_H
#define WDR_IMAGE_IO_H
#include <stdint.h>

/* Largest image any reader here accepts (8192 x 8192): a header claiming more is refused before
 * anything is allocated, as is one claiming more pixels than the file's bytes can hold. */
#define WDR_IMAGE_MAX_PIXELS (64u << 20)

/* The one output-name rule of every program: an output's name ends in one of the extensions
 * exts lists (".png .pfm"; any case), and that extension says the format written.
 * @retval WDR_OK  @retval WDR_E_INVAL (err: "output 'w.tiff' must end in .png or .pfm") */
int wdr_output_name_check(const char *path, const char *exts, char *err, int errlen);
/* Whether path ends in ext (".pfm"), in any case, after at least one character. */
int wdr_path_has_ext(const char *path, const char *ext);

/* Write a grey PNG of w*h samples; bits is 8 or 16 (16-bit samples are big-endian in the file).
 * @retval WDR_OK, WDR_E_IO (err names the file), WDR_E_INVAL */
int wdr_png_write_gray(const char *path, const uint16_t *px, int w, int h, int bits, char *err, int errlen);

/* Write an 8-bit RGB PNG (rgb has 3*w*h bytes). */
int wdr_png_write_rgb(const char *path, const uint8_t *rgb, int w, int h, char *err, int errlen);

/* Write a one-channel PFM; rows given top-down. */
int wdr_pfm_write(const char *path, const float *px, int w, int h, char *err, int errlen);

/* Read a PFM (1 or 3 channels; 3 are reduced to luminance Y = 0.2126 R + 0.7152 G + 0.0722 B).
 * *px is malloc'd, rows top-down. @retval WDR_OK, WDR_E_IO, WDR_E_INVAL (err names file and field) */
int wdr_pfm_read(const char *path, float **px, int *w, int *h, char *err, int errlen);

#endif
