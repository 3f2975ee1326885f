/* wdr-hdrgen: HDR test images as EXR in any compression OpenEXR writes (DWAB included), for the
 * demo and for trying the scene loader: a synthetic 2:1 panorama (sky, a sun, a dim room with
 * small lamps: about five decades), or any HDR image we read, re-encoded.
 *   wdr-hdrgen -o OUT.exr [--compression dwab] [--size 1024x512] [--from IMAGE] [--half]
 * Exit codes follow sysexits. */
#include "exr_read.h"
#include "hdr_image.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sysexits.h>

typedef struct opts {
    const char *out, *from, *compression;
    int w, h, half;
} opts;

static int usage(int code)
{
    fprintf(code ? stderr : stdout, "usage: wdr-hdrgen -o OUT.exr [--compression none|rle|zips|zip|piz|pxr24|b44|b44a|"
                                    "dwaa|dwab] [--size WxH] [--from IMAGE] [--half]\n");
    return code;
}

static int parse(int argc, char **argv, opts *o)
{
    *o = (opts){NULL, NULL, "dwab", 1024, 512, 0};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--half")) {
            o->half = 1;
            continue;
        }
        if (!v)
            return fprintf(stderr, "wdr-hdrgen: %s needs a value\n", a), usage(EX_USAGE);
        i++;
        if (!strcmp(a, "-o"))
            o->out = v;
        else if (!strcmp(a, "--from"))
            o->from = v;
        else if (!strcmp(a, "--compression"))
            o->compression = v;
        else if (!strcmp(a, "--size")) {
            if (sscanf(v, "%dx%d", &o->w, &o->h) != 2 || o->w < 8 || o->h < 8 || o->w > 16384 || o->h > 16384)
                return fprintf(stderr, "wdr-hdrgen: --size '%s' must be WxH, 8..16384 each\n", v), EX_USAGE;
        } else
            return fprintf(stderr, "wdr-hdrgen: unknown option '%s'\n", a), usage(EX_USAGE);
    }
    return o->out ? EX_OK : usage(EX_USAGE);
}

/* A panorama: sky 3e3 cd/m2 at the zenith falling to 3e2 at the horizon, a sun of 5e4 cd/m2 (half and DWA keep values below 65504)
 * (radius 1 % of the height), a room below from 3 cd/m2 to 0.03 with 40 lamps of 2e4 cd/m2. */
static void panorama(float *lum, int w, int h)
{
    double sx = 0.7 * w, sy = 0.18 * h, sr = 0.01 * h;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double fy = (y + 0.5) / h, v;
            if (fy < 0.45)
                v = 3e3 * pow(0.1, fy / 0.45);
            else
                v = 3.0 * pow(0.01, (fy - 0.45) / 0.55) * (1 + 0.5 * sin(12.566 * x / w));
            if (hypot(x - sx, y - sy) < sr)
                v = 5e4;
            lum[(long)y * w + x] = (float)v;
        }
    for (int k = 0; k < 40; k++) { /* 3x3-pixel lamps in two rows along the room */
        int lx = (int)((k % 20 + 0.5) * w / 20), ly = (int)((k < 20 ? 0.6 : 0.8) * h);
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++)
                lum[(long)(ly + dy) * w + lx + dx] = 2e4f;
    }
}

int main(int argc, char **argv)
{
    opts o;
    char err[1024];
    if (argc > 1 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")))
        return usage(EX_OK);
    int rc = parse(argc, argv, &o);
    if (rc)
        return rc;
    float *lum = NULL;
    if (o.from) {
        long neg;
        rc = wdr_hdr_load_checked(o.from, &lum, &o.w, &o.h, &neg, err, sizeof err);
        if (rc)
            return fprintf(stderr, "wdr-hdrgen: %s\n", err), rc == WDR_E_IO ? EX_NOINPUT : EX_DATAERR;
    } else if ((lum = malloc(sizeof *lum * (size_t)o.w * o.h)) != NULL) {
        panorama(lum, o.w, o.h);
    } else {
        return fprintf(stderr, "wdr-hdrgen: out of memory\n"), EX_OSERR;
    }
    rc = wdr_exr_write(o.out, lum, NULL, o.w, o.h, o.compression, o.half, err, sizeof err);
    free(lum);
    if (rc)
        return fprintf(stderr, "wdr-hdrgen: %s\n", err), rc == WDR_E_INVAL ? EX_USAGE : EX_CANTCREAT;
    printf("wrote %s: %dx%d luminance (Y), %s, %s\n", o.out, o.w, o.h, o.compression, o.half ? "half" : "float");
    return EX_OK;
}
