#include "image_io.h"
#include "wdr_err.h"
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

static int io_fail(char *err, int errlen, const char *path, const char *what)
{
    snprintf(err, (size_t)errlen, "%s: %s", path, what);
    return WDR_E_IO;
}

/* One writer for grey and RGB: rows are handed to libpng already in file byte order. */
static int write_png_rows(const char *path, int w, int h, int bits, int color, const uint8_t *bytes, size_t stride,
                          char *err, int errlen)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return io_fail(err, errlen, path, "cannot create file");
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info || setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        fclose(f);
        return io_fail(err, errlen, path, "PNG write failed");
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, bits, color, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int y = 0; y < h; y++)
        png_write_row(png, (png_const_bytep)(bytes + (size_t)y * stride));
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    return fclose(f) ? io_fail(err, errlen, path, "write failed (disk full?)") : WDR_OK;
}

int wdr_png_write_gray(const char *path, const uint16_t *px, int w, int h, int bits, char *err, int errlen)
{
    if (w <= 0 || h <= 0 || (bits != 8 && bits != 16)) {
        snprintf(err, (size_t)errlen, "%s: bad PNG size %dx%d or depth %d", path, w, h, bits);
        return WDR_E_INVAL;
    }
    size_t stride = (size_t)w * (size_t)(bits / 8);
    uint8_t *bytes = malloc(stride * (size_t)h);
    if (!bytes)
        return WDR_E_NOMEM;
    for (size_t i = 0; i < (size_t)w * (size_t)h; i++) {
        if (bits == 8) {
            bytes[i] = (uint8_t)(px[i] > 255 ? 255 : px[i]);
        } else {
            bytes[2 * i] = (uint8_t)(px[i] >> 8);
            bytes[2 * i + 1] = (uint8_t)px[i];
        }
    }
    int rc = write_png_rows(path, w, h, bits, PNG_COLOR_TYPE_GRAY, bytes, stride, err, errlen);
    free(bytes);
    return rc;
}

int wdr_png_write_rgb(const char *path, const uint8_t *rgb, int w, int h, char *err, int errlen)
{
    if (w <= 0 || h <= 0) {
        snprintf(err, (size_t)errlen, "%s: bad PNG size %dx%d", path, w, h);
        return WDR_E_INVAL;
    }
    return write_png_rows(path, w, h, 8, PNG_COLOR_TYPE_RGB, rgb, (size_t)w * 3, err, errlen);
}

int wdr_pfm_write(const char *path, const float *px, int w, int h, char *err, int errlen)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return io_fail(err, errlen, path, "cannot create file");
    fprintf(f, "Pf\n%d %d\n-1.0\n", w, h); /* negative scale: little-endian */
    for (int y = h - 1; y >= 0; y--)        /* PFM stores the bottom row first */
        fwrite(px + (size_t)y * (size_t)w, sizeof(float), (size_t)w, f);
    return fclose(f) ? io_fail(err, errlen, path, "write failed (disk full?)") : WDR_OK;
}

/* The raster the header promises must be in the file before it is allocated. */
static int pfm_fits_file(FILE *f, const char *path, int ch, int w, int h, char *err, int errlen)
{
    struct stat st;
    long at = ftell(f);
    uint64_t need = (uint64_t)w * (uint64_t)h * (uint64_t)ch * 4u;
    if (fstat(fileno(f), &st) != 0 || !S_ISREG(st.st_mode) || at < 0) {
        snprintf(err, (size_t)errlen, "%s: not a regular file", path);
        return WDR_E_INVAL;
    }
    if ((uint64_t)st.st_size - (uint64_t)at < need || (uint64_t)st.st_size < (uint64_t)at) {
        snprintf(err, (size_t)errlen, "%s: field 'raster': truncated (%dx%dx%d floats need %llu bytes, %lld left)",
                 path, w, h, ch, (unsigned long long)need, (long long)(st.st_size - at));
        return WDR_E_INVAL;
    }
    return WDR_OK;
}

static int pfm_header(FILE *f, const char *path, int *ch, int *w, int *h, double *scale, char *err, int errlen)
{
    char magic[3] = {0};
    if (fscanf(f, "%2s", magic) != 1 || (strcmp(magic, "Pf") && strcmp(magic, "PF"))) {
        snprintf(err, (size_t)errlen, "%s: field 'magic': '%s' is not Pf or PF", path, magic);
        return WDR_E_INVAL;
    }
    *ch = magic[1] == 'F' ? 3 : 1;
    if (fscanf(f, "%d %d %lf", w, h, scale) != 3 || *w <= 0 || *h <= 0 ||
        (uint64_t)*w * (uint64_t)*h > WDR_IMAGE_MAX_PIXELS) {
        snprintf(err, (size_t)errlen, "%s: field 'size': bad width/height (1 to %u pixels)", path,
                 WDR_IMAGE_MAX_PIXELS);
        return WDR_E_INVAL;
    }
    if (!isfinite(*scale) || *scale == 0) {
        snprintf(err, (size_t)errlen, "%s: field 'scale': %g is not a non-zero number", path, *scale);
        return WDR_E_INVAL;
    }
    fgetc(f); /* the single whitespace before the raster */
    return pfm_fits_file(f, path, *ch, *w, *h, err, errlen);
}

static float to_host_float(const uint8_t *b, int big_endian)
{
    uint32_t u = big_endian ? ((uint32_t)b[0] << 24 | (uint32_t)b[1] << 16 | (uint32_t)b[2] << 8 | b[3])
                            : ((uint32_t)b[3] << 24 | (uint32_t)b[2] << 16 | (uint32_t)b[1] << 8 | b[0]);
    float v;
    memcpy(&v, &u, sizeof v);
    return v;
}

static int pfm_raster(FILE *f, const char *path, int ch, int w, int h, int big_endian, float *out, char *err,
                      int errlen)
{
    uint8_t *row = malloc((size_t)w * (size_t)ch * 4);
    if (!row)
        return WDR_E_NOMEM;
    for (int y = h - 1; y >= 0; y--) {
        if (fread(row, 4, (size_t)w * (size_t)ch, f) != (size_t)w * (size_t)ch) {
            free(row);
            snprintf(err, (size_t)errlen, "%s: field 'raster': truncated (%dx%dx%d floats expected)", path, w, h, ch);
            return WDR_E_INVAL;
        }
        for (int x = 0; x < w; x++) {
            const uint8_t *p = row + (size_t)x * (size_t)ch * 4;
            out[(size_t)y * (size_t)w + (size_t)x] =
                ch == 1 ? to_host_float(p, big_endian)
                        : 0.2126f * to_host_float(p, big_endian) + 0.7152f * to_host_float(p + 4, big_endian) +
                              0.0722f * to_host_float(p + 8, big_endian);
        }
    }
    free(row);
    return WDR_OK;
}

int wdr_pfm_read(const char *path, float **px, int *w, int *h, char *err, int errlen)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return io_fail(err, errlen, path, "cannot open file");
    int ch;
    double scale;
    int rc = pfm_header(f, path, &ch, w, h, &scale, err, errlen);
    *px = NULL;
    if (!rc) {
        *px = malloc((size_t)*w * (size_t)*h * sizeof(float));
        rc = *px ? pfm_raster(f, path, ch, *w, *h, scale > 0, *px, err, errlen) : WDR_E_NOMEM;
    }
    fclose(f);
    if (rc) {
        free(*px);
        *px = NULL;
    }
    return rc;
}

/* ---- Output names ---------------------------------------------------------------------- */

int wdr_path_has_ext(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    return n > e && !strcasecmp(path + n - e, ext);
}

int wdr_output_name_check(const char *path, const char *exts, char *err, int errlen)
{
    char ext[16], said[128] = "";
    int count = 0;
    for (const char *p = exts; *p;) {
        size_t len = strcspn(p, " ");
        if (len && len < sizeof ext) {
            snprintf(ext, sizeof ext, "%.*s", (int)len, p);
            if (wdr_path_has_ext(path, ext))
                return WDR_OK;
            count++;
        }
        p += len + (p[len] == ' ');
    }
    /* "must end in .png or .pfm": the list as a reader says it */
    for (const char *p = exts; *p; count--) {
        size_t len = strcspn(p, " ");
        size_t used = strlen(said);
        snprintf(said + used, sizeof said - used, "%s%.*s", used ? (count == 1 ? " or " : ", ") : "", (int)len, p);
        p += len + (p[len] == ' ');
    }
    snprintf(err, (size_t)errlen, "output '%s' must end in %s", path, said);
    return WDR_E_INVAL;
}
