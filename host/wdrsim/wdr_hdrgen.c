/* wdr-hdrgen: HDR test images as EXR in any compression OpenEXR writes (DWAB included), for the
 * demo and for trying the scene loader: a synthetic 2:1 panorama (sky, a sun, a dim room with
 * small lamps: about five decades), or any HDR image we read, re-encoded.
 *   wdr-hdrgen -o OUT.exr [--compression dwab] [--size 1024x512] [--from IMAGE] [--half]
 * Options are one table (host/lib/cli_options.h): --help, --version and the man page follow.
 * Exit codes follow sysexits. */
#include "cli_options.h"
#include "exr_read.h"
#include "hdr_image.h"
#include "image_io.h"
#include "wdr_err.h"
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sysexits.h>

typedef struct opts {
    const char *out, *from, *compression, *size;
    int w, h, half;
} opts;

/* ---- arguments: one row each (host/lib/cli_options.h) ---- */

#define O(f) offsetof(opts, f)
static const cli_option rows[] = {
    {"output", 'o', CLI_STRING, O(out), "OUT.exr", "the image to write", .flags = CLI_REQUIRED},
    {"compression", 0, CLI_STRING, O(compression), "KIND",
     "none, rle, zips, zip, piz, pxr24, b44, b44a, dwaa or dwab (default dwab)",
     .values = "none rle zips zip piz pxr24 b44 b44a dwaa dwab"},
    {"size", 0, CLI_STRING, O(size), "WxH", "the panorama's size, 8..16384 each (default 1024x512)"},
    {"from", 0, CLI_STRING, O(from), "IMAGE", "re-encode this HDR image (EXR, .hdr, .pfm) instead"},
    {"half", 0, CLI_FLAG, O(half), NULL, "16-bit half floats (default 32-bit float)"},
    {0}};
#undef O

static const cli_command hdrgen_command = {NULL, NULL, 0, 0, "HDR test images as EXR in any compression", NULL,
                                           rows, NULL, 0};

static const cli_section sections[] = {
    {"EXAMPLES", "wdr-hdrgen -o pano.exr --compression dwab\n"
                 "bash .ci/demo pano.exr      # the demo on that panorama (from the source tree)"},
    {"EXIT STATUS", "0 on success; otherwise a sysexits(3) code: 64 usage (a compression OpenEXR does not know), "
                    "65 an input that is not an HDR image, 66 an input that cannot be read, 71 out of memory, "
                    "73 an output that cannot be created."},
    {"SEE ALSO", "wdrsim(1), wdr-simboard(1), wdrctl(1)"},
    {NULL, NULL}};

static const cli_program hdrgen_program = {
    .name = "wdr-hdrgen",
    .summary = "HDR test images as EXR in any compression (DWAB included)",
    .description = "wdr-hdrgen writes a synthetic 2:1 panorama (sky, a sun, a dim room with small lamps: about "
                   "five decades of luminance, in cd/m2), or any HDR image wdrcam reads, re-encoded, as an "
                   "OpenEXR file in the compression asked for. A scene file can name it as its image.",
    .single = &hdrgen_command,
    .sections = sections,
};

static int parse(int argc, char **argv, opts *o, int *done)
{
    int n_args;
    *o = (opts){NULL, NULL, "dwab", NULL, 1024, 512, 0};
    char err[300];
    int rc = cli_main_single(&hdrgen_program, argc, argv, o, &n_args, done);
    if (rc != EX_OK || *done)
        return rc;
    if (wdr_output_name_check(o->out, ".exr", err, sizeof err))
        return fprintf(stderr, "wdr-hdrgen: %s\n", err), EX_USAGE;
    if (!o->size)
        return EX_OK;
    char tail;
    if (sscanf(o->size, "%dx%d%c", &o->w, &o->h, &tail) != 2 || o->w < 8 || o->h < 8 || o->w > 16384 || o->h > 16384)
        return fprintf(stderr, "wdr-hdrgen: option --size: '%s' must be WxH, 8..16384 each\n", o->size), EX_USAGE;
    return EX_OK;
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
    int done = 0, rc = parse(argc, argv, &o, &done);
    if (rc || done)
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
