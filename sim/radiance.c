/* Radiance .hdr reader (see radiance.h): header lines, the resolution line, then flat or
 * new-style run-length scanlines of R, G, B, E bytes. */
#include "radiance.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct rd {
    const uint8_t *p, *end;
    const char *path;
    char *err;
    int errlen;
} rd;

static int bad(rd *r, int code, const char *field, const char *what)
{
    snprintf(r->err, (size_t)r->errlen, "%s: Radiance field '%s': %s", r->path, field, what);
    return code;
}

/* One header line without its newline into line (cut to cap - 1); 0 at the end of the data. */
static int next_line(rd *r, char *line, size_t cap)
{
    if (r->p >= r->end)
        return 0;
    size_t n = 0;
    while (r->p < r->end && *r->p != '\n') {
        if (n + 1 < cap)
            line[n++] = (char)*r->p;
        r->p++;
    }
    if (r->p < r->end)
        r->p++;
    line[n] = 0;
    return 1;
}

static int read_header(rd *r)
{
    char line[256];
    if (!next_line(r, line, sizeof line) || (strcmp(line, "#?RADIANCE") && strcmp(line, "#?RGBE")))
        return bad(r, WDR_E_INVAL, "magic", "not #?RADIANCE or #?RGBE");
    int format_ok = 0;
    for (;;) {
        if (!next_line(r, line, sizeof line))
            return bad(r, WDR_E_INVAL, "header", "ends before the blank line");
        if (!line[0])
            break;
        if (!strncmp(line, "FORMAT=", 7)) {
            if (strcmp(line + 7, "32-bit_rle_rgbe"))
                return bad(r, WDR_E_UNSUPPORTED, "FORMAT", "only 32-bit_rle_rgbe is read");
            format_ok = 1;
        }
    }
    return format_ok ? WDR_OK : bad(r, WDR_E_INVAL, "FORMAT", "missing");
}

/* "-Y H +X W" with 1 <= W, H and W * H <= WDR_IMAGE_MAX_PIXELS. */
static int read_size(rd *r, int *w, int *h)
{
    char line[256], tail;
    long hh, ww;
    if (!next_line(r, line, sizeof line))
        return bad(r, WDR_E_INVAL, "resolution", "missing");
    if (sscanf(line, "-Y %ld +X %ld%c", &hh, &ww, &tail) != 2) {
        char ax[3], bx[3];
        return sscanf(line, "%2s %ld %2s %ld", ax, &hh, bx, &ww) == 4
                   ? bad(r, WDR_E_UNSUPPORTED, "resolution", "only -Y H +X W (top-down rows) is read")
                   : bad(r, WDR_E_INVAL, "resolution", "not '-Y H +X W'");
    }
    if (ww < 1 || hh < 1 || ww > 0x7fffffffL || hh > 0x7fffffffL ||
        (uint64_t)ww * (uint64_t)hh > WDR_IMAGE_MAX_PIXELS) {
        char what[128];
        snprintf(what, sizeof what, "%ld x %ld is not 1 to %u pixels", ww, hh, WDR_IMAGE_MAX_PIXELS);
        return bad(r, WDR_E_INVAL, "resolution", what);
    }
    *w = (int)ww;
    *h = (int)hh;
    return WDR_OK;
}

/* Fewest bytes a scanline of w pixels can take: run-length runs cover at most 127 bytes for
 * 2 bytes of file, per channel, after a 4-byte marker; flat pixels take 4 bytes each. */
static uint64_t min_scanline_bytes(int w)
{
    uint64_t flat = 4u * (uint64_t)w;
    if (w < 8 || w > 0x7fff)
        return flat;
    uint64_t rle = 4u + 8u * (((uint64_t)w + 126u) / 127u);
    return rle < flat ? rle : flat;
}

static void rgbe_to_float(const uint8_t *e, float *out)
{
    if (!e[3]) {
        out[0] = out[1] = out[2] = 0.0f;
        return;
    }
    float f = ldexpf(1.0f, (int)e[3] - (128 + 8)); /* as stb_image: no half-unit bias */
    for (int c = 0; c < 3; c++)
        out[c] = (float)e[c] * f;
}

/* One channel of a run-length scanline into line[x * 4 + ch]: every count is checked against
 * what is left of the row and of the file (a count of 0 is an error, not a loop). */
static int rle_channel(rd *r, uint8_t *line, int w, int ch)
{
    for (int x = 0; x < w;) {
        if (r->p >= r->end)
            return bad(r, WDR_E_INVAL, "scanline", "file ends inside a run");
        unsigned count = *r->p++;
        int run = count > 128;
        if (run)
            count -= 128;
        if (count == 0 || count > (unsigned)(w - x))
            return bad(r, WDR_E_INVAL, "scanline", "run count 0 or past the end of the row");
        if ((size_t)(r->end - r->p) < (run ? 1u : count))
            return bad(r, WDR_E_INVAL, "scanline", "file ends inside a run");
        for (unsigned i = 0; i < count; i++, x++)
            line[(size_t)x * 4 + (size_t)ch] = run ? r->p[0] : r->p[i];
        r->p += run ? 1 : count;
    }
    return WDR_OK;
}

static int read_scanline(rd *r, uint8_t *line, int w)
{
    size_t left = (size_t)(r->end - r->p);
    int rle = w >= 8 && w <= 0x7fff && left >= 4 && r->p[0] == 2 && r->p[1] == 2 && !(r->p[2] & 0x80);
    if (!rle) {
        if (left < 4u * (size_t)w)
            return bad(r, WDR_E_INVAL, "scanline", "file ends inside a flat scanline");
        memcpy(line, r->p, 4u * (size_t)w);
        r->p += 4u * (size_t)w;
        return WDR_OK;
    }
    if (((int)r->p[2] << 8 | r->p[3]) != w)
        return bad(r, WDR_E_INVAL, "scanline", "run-length scanline of another width");
    r->p += 4;
    for (int ch = 0; ch < 4; ch++) {
        int rc = rle_channel(r, line, w, ch);
        if (rc)
            return rc;
    }
    return WDR_OK;
}

static int read_pixels(rd *r, int w, int h, float *rgb)
{
    uint8_t *line = malloc(4u * (size_t)w);
    if (!line)
        return WDR_E_NOMEM;
    int rc = WDR_OK;
    for (int y = 0; y < h && !rc; y++) {
        rc = read_scanline(r, line, w);
        for (int x = 0; x < w && !rc; x++)
            rgbe_to_float(line + 4 * (size_t)x, rgb + 3 * ((size_t)y * (size_t)w + (size_t)x));
    }
    free(line);
    return rc;
}

int wdr_radiance_decode(const uint8_t *buf, size_t len, const char *path, float **rgb, int *w, int *h, char *err,
                        int errlen)
{
    rd r = {buf, buf + len, path, err, errlen};
    *rgb = NULL;
    int rc = read_header(&r);
    if (!rc)
        rc = read_size(&r, w, h);
    if (rc)
        return rc;
    if ((uint64_t)(r.end - r.p) < (uint64_t)*h * min_scanline_bytes(*w)) {
        char what[160];
        snprintf(what, sizeof what, "%d x %d pixels need at least %llu bytes, the file has %zu after its header", *w,
                 *h, (unsigned long long)*h * min_scanline_bytes(*w), (size_t)(r.end - r.p));
        return bad(&r, WDR_E_INVAL, "resolution", what);
    }
    if (!(*rgb = malloc((size_t)*w * (size_t)*h * 3u * sizeof(float))))
        return WDR_E_NOMEM;
    rc = read_pixels(&r, *w, *h, *rgb);
    if (rc) {
        free(*rgb);
        *rgb = NULL;
    }
    return rc;
}
