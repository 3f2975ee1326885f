/* Radiance .hdr (RGBE) reader of our own: bounded at every step. Debian 12's stb_image (2.27)
 * loops forever on a run count of 0 in a new-style RLE scanline (CVE-2021-42715) and trusts a
 * header's size before it has seen the pixels; this reader checks the size against the file's
 * length and WDR_IMAGE_MAX_PIXELS (image_io.h) before it allocates, and every run against its scanline. */
#ifndef WDR_RADIANCE_H
#define WDR_RADIANCE_H
#include "image_io.h"
#include <stddef.h>
#include <stdint.h>


/* Decode a whole .hdr file held in memory into *rgb (malloc'd, free(); 3 floats per pixel,
 * rows top-down). err names the file (path) and the field at fault.
 * @retval WDR_OK
 * @retval WDR_E_INVAL        not a Radiance file, a bad header or size, a damaged or short scanline
 * @retval WDR_E_UNSUPPORTED  an orientation other than -Y H +X W, a format other than 32-bit_rle_rgbe
 * @retval WDR_E_NOMEM */
int wdr_radiance_decode(const uint8_t *buf, size_t len, const char *path, float **rgb, int *w, int *h, char *err,
                        int errlen);

#endif
