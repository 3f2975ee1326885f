#include "hdr_image.h"
#include "image_io.h"
#include "wdr_err.h"
#include "exr_read.h"
#include "file_io.h"
#include "radiance.h"
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static float luminance(float r, float g, float b) { return 0.2126f * r + 0.7152f * g + 0.0722f * b; }

/* ---- Radiance .hdr ---- */

/* Our own bounded reader (radiance.h), not stb_image: Debian 12's 2.27 hangs on a crafted run. */
static int load_radiance(const char *path, float **lum, int *w, int *h, char *err, int errlen)
{
    uint8_t *buf;
    size_t len;
    if (wdr_read_file(path, &buf, &len)) {
        snprintf(err, (size_t)errlen, "%s: cannot read image: %s", path, strerror(errno));
        return WDR_E_IO;
    }
    float *rgb;
    int rc = wdr_radiance_decode(buf, len, path, &rgb, w, h, err, errlen);
    free(buf);
    if (rc)
        return rc;
    size_t count = (size_t)*w * (size_t)*h;
    *lum = malloc(count * sizeof **lum);
    if (*lum)
        for (size_t i = 0; i < count; i++)
            (*lum)[i] = luminance(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
    free(rgb);
    return *lum ? WDR_OK : WDR_E_NOMEM;
}

/* ---- dispatch on the first bytes ---- */

int wdr_hdr_load(const char *path, float **lum, int *w, int *h, char *err, int errlen)
{
    unsigned char magic[4] = {0};
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(err, (size_t)errlen, "%s: cannot open image", path);
        return WDR_E_IO;
    }
    size_t got = fread(magic, 1, sizeof magic, f);
    fclose(f);
    *lum = NULL;
    if (got == 4 && magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01)
        return wdr_exr_read(path, lum, w, h, err, errlen);
    if (got >= 2 && magic[0] == '#' && magic[1] == '?')
        return load_radiance(path, lum, w, h, err, errlen);
    if (got >= 2 && magic[0] == 'P' && (magic[1] == 'f' || magic[1] == 'F'))
        return wdr_pfm_read(path, lum, w, h, err, errlen);
    snprintf(err, (size_t)errlen, "%s: not an OpenEXR, Radiance .hdr or PFM image (unknown first bytes)", path);
    return WDR_E_INVAL;
}

/* ---- the one policy for what is not a luminance ---- */

int wdr_hdr_sanitize(const char *file, float *lum, int w, int h, long *negatives, char *err, int errlen)
{
    *negatives = 0;
    for (long i = 0; i < (long)w * h; i++) {
        if (!isfinite(lum[i])) {
            snprintf(err, (size_t)errlen, "%s: pixel (%ld, %ld) is %g: not a finite luminance", file, i % w, i / w,
                     lum[i]);
            return WDR_E_INVAL;
        }
        if (lum[i] < 0) {
            lum[i] = 0;
            (*negatives)++;
        }
    }
    return WDR_OK;
}

int wdr_hdr_load_checked(const char *path, float **lum, int *w, int *h, long *negatives, char *err, int errlen)
{
    int rc = wdr_hdr_load(path, lum, w, h, err, errlen);
    if (!rc && (rc = wdr_hdr_sanitize(path, *lum, *w, *h, negatives, err, errlen))) {
        free(*lum);
        *lum = NULL;
    }
    return rc;
}
