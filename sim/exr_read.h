/* Every EXR that OpenEXR reads (all compressions, DWAA/DWAB included; scanline or tiled; half,
 * float or uint; RGB(A) or Y), through OpenEXR's C++ library behind this C interface.
 * Luminance is Y = 0.2126 R + 0.7152 G + 0.0722 B; a Y-only file gives Y itself. Part 0 is read.
 *
 * Bounds, checked before any pixel is allocated: each side at most WDR_EXR_MAX_SIDE, at most
 * WDR_EXR_MAX_PIXELS pixels, and no more chunks than the file has room for in its offset table
 * (8 bytes per chunk), so a small file cannot claim a huge image; at most WDR_EXR_MAX_PARTS parts,
 * counted in constant memory before OpenEXR parses them. An uncompressed chunk must hold exactly
 * its lines' bytes ("damaged" otherwise: OpenEXR would fill the rest from uninitialised memory),
 * and every strip is read into zeroed planes. */
#ifndef WDR_EXR_READ_H
#define WDR_EXR_READ_H
#ifdef __cplusplus
extern "C" {
#endif

#define WDR_EXR_MAX_SIDE 32768
#define WDR_EXR_MAX_PIXELS (1L << 26) /* 64 Mpixel: 256 MB of luminance */
#define WDR_EXR_MAX_PARTS 64           /* part headers, counted before any is parsed */

/* Load part 0 of an EXR as luminance; *lum is malloc'd (free()), w*h values, rows top-down.
 * Values are passed through as stored (the caller applies wdr_hdr_sanitize).
 * Every error names the file, the part and its compression.
 * @retval WDR_OK
 * @retval WDR_E_INVAL        damaged, truncated, or over the bounds above
 * @retval WDR_E_UNSUPPORTED  deep data, or no full-resolution R, G, B or Y channels
 * @retval WDR_E_NOMEM */
int wdr_exr_read(const char *path, float **lum, int *w, int *h, char *err, int errlen);

/* Write a w x h EXR for tests and demos: one channel "Y" (rgb == NULL) or R, G, B planes of
 * w*h floats each (rgb[0..2]); compression by OpenEXR name ("zip", "piz", "pxr24", "b44",
 * "dwaa", "dwab", "none", ...), half or float pixels.
 * @retval WDR_OK  @retval WDR_E_INVAL unknown compression  @retval WDR_E_IO cannot write */
int wdr_exr_write(const char *path, const float *y, const float *const rgb[3], int w, int h, const char *compression,
                  int half, char *err, int errlen);

#ifdef __cplusplus
}
#endif
#endif
