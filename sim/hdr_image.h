/* HDR images in, one luminance value per pixel out: OpenEXR (every compression, DWAA/DWAB
 * included, through the C++ library: exr_read.h), Radiance .hdr (radiance.h, bounded) and PFM (image_io.h).
 * Luminance is Y = 0.2126 R + 0.7152 G + 0.0722 B (Rec. 709 primaries, linear values). */
#ifndef WDR_HDR_IMAGE_H
#define WDR_HDR_IMAGE_H

/* Load path as a luminance map; *lum is malloc'd (free()), w*h values, rows top-down.
 * The format is told by the file's first bytes, not its name. Values are passed through as
 * stored: NaN, Inf and negatives are for the caller to judge (a scene must name them).
 * @retval WDR_OK
 * @retval WDR_E_IO           missing or unreadable (err names the file)
 * @retval WDR_E_INVAL        not an image we read, or damaged (err names the file and what)
 * @retval WDR_E_UNSUPPORTED  an EXR without R,G,B or Y channels, or deep data
 * @retval WDR_E_NOMEM */
int wdr_hdr_load(const char *path, float **lum, int *w, int *h, char *err, int errlen);

/* The one policy for pixels that are not a luminance, kept by every reader's caller (scenes,
 * statistics): NaN and Inf are errors (the message names file, pixel and value); negatives,
 * which lossy compression leaves beside black, are clamped to 0 and counted in *negatives.
 * @retval WDR_OK  @retval WDR_E_INVAL a NaN or Inf pixel */
int wdr_hdr_sanitize(const char *file, float *lum, int w, int h, long *negatives, char *err, int errlen);

/* wdr_hdr_load, then wdr_hdr_sanitize (on failure *lum is NULL). Same return codes as both. */
int wdr_hdr_load_checked(const char *path, float **lum, int *w, int *h, long *negatives, char *err, int errlen);

#endif
