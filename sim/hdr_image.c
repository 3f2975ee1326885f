#include "hdr_image.h"
#include "image_io.h"
#include "wdr_err.h"
#include "file_io.h"
#include "radiance.h"
#include <errno.h>
#include <openexr.h>
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

/* ---- OpenEXR ---- */

typedef struct exr_image {
    exr_context_t ctx;
    exr_attr_box2i_t dw;
    int w, h;
    int chan[3];   /* channel index of R, G, B (all three Y for a luminance-only file) */
    float *planes; /* three float planes of w*h */
} exr_image;

static void exr_quiet(exr_const_context_t ctx, exr_result_t code, const char *msg)
{
    (void)ctx, (void)code, (void)msg; /* errors are reported through our own message */
}

static int exr_fail(const char *path, const char *what, exr_result_t rc, char *err, int errlen)
{
    snprintf(err, (size_t)errlen, "%s: OpenEXR %s: %s", path, what, exr_get_default_error_message(rc));
    return WDR_E_INVAL;
}

static int find_channel(const exr_attr_chlist_t *cl, const char *name)
{
    for (int i = 0; i < cl->num_channels; i++)
        if (!strcmp(cl->entries[i].name.str, name))
            return cl->entries[i].x_sampling == 1 && cl->entries[i].y_sampling == 1 ? i : -1;
    return -1;
}

static int pick_channels(exr_image *im, const char *path, char *err, int errlen)
{
    const exr_attr_chlist_t *cl;
    exr_result_t rc = exr_get_channels(im->ctx, 0, &cl);
    if (rc)
        return exr_fail(path, "channels", rc, err, errlen);
    const char *names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; c++)
        im->chan[c] = find_channel(cl, names[c]);
    if (im->chan[0] < 0 || im->chan[1] < 0 || im->chan[2] < 0)
        im->chan[0] = im->chan[1] = im->chan[2] = find_channel(cl, "Y");
    if (im->chan[0] < 0) {
        snprintf(err, (size_t)errlen, "%s: OpenEXR channels: need full-resolution R, G, B or Y", path);
        return WDR_E_UNSUPPORTED;
    }
    return WDR_OK;
}

/* Point the decoder's channels at our float planes for a chunk at (x0, y0) of the data window. */
static void aim_decoder(exr_image *im, exr_decode_pipeline_t *dec, int x0, int y0)
{
    for (int c = 0; c < dec->channel_count; c++)
        dec->channels[c].decode_to_ptr = NULL;
    for (int k = 0; k < 3; k++) {
        exr_coding_channel_info_t *ch = &dec->channels[im->chan[k]];
        if (ch->decode_to_ptr) /* Y feeds all three planes: decode once, copy later */
            continue;
        ch->decode_to_ptr = (uint8_t *)(im->planes + (size_t)k * im->w * im->h + (size_t)y0 * im->w + x0);
        ch->user_pixel_stride = sizeof(float);
        ch->user_line_stride = im->w * (int32_t)sizeof(float);
        ch->user_data_type = EXR_PIXEL_FLOAT;
        ch->user_bytes_per_element = sizeof(float);
    }
}

static int decode_chunk(exr_image *im, exr_decode_pipeline_t *dec, int *started, const exr_chunk_info_t *ci,
                        int x0, int y0)
{
    exr_result_t rc = *started ? exr_decoding_update(im->ctx, 0, ci, dec) : exr_decoding_initialize(im->ctx, 0, ci, dec);
    if (rc)
        return rc;
    *started = 1;
    aim_decoder(im, dec, x0, y0);
    rc = exr_decoding_choose_default_routines(im->ctx, 0, dec);
    return rc ? rc : exr_decoding_run(im->ctx, 0, dec);
}

static exr_result_t read_scanlines(exr_image *im, exr_decode_pipeline_t *dec, int *started)
{
    int32_t lines;
    exr_result_t rc = exr_get_scanlines_per_chunk(im->ctx, 0, &lines);
    for (int y = im->dw.min.y; !rc && y <= im->dw.max.y; y += lines) {
        exr_chunk_info_t ci;
        rc = exr_read_scanline_chunk_info(im->ctx, 0, y, &ci);
        if (!rc)
            rc = decode_chunk(im, dec, started, &ci, 0, ci.start_y - im->dw.min.y);
    }
    return rc;
}

static exr_result_t read_tiles(exr_image *im, exr_decode_pipeline_t *dec, int *started)
{
    int32_t tw, th;
    exr_result_t rc = exr_get_tile_sizes(im->ctx, 0, 0, 0, &tw, &th);
    for (int ty = 0; !rc && ty * th < im->h; ty++)
        for (int tx = 0; !rc && tx * tw < im->w; tx++) {
            exr_chunk_info_t ci;
            rc = exr_read_tile_chunk_info(im->ctx, 0, tx, ty, 0, 0, &ci);
            if (!rc)
                rc = decode_chunk(im, dec, started, &ci, tx * tw, ty * th);
        }
    return rc;
}

static int read_pixels(exr_image *im, const char *path, char *err, int errlen)
{
    exr_storage_t storage;
    exr_result_t rc = exr_get_storage(im->ctx, 0, &storage);
    if (rc)
        return exr_fail(path, "storage", rc, err, errlen);
    if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED) {
        snprintf(err, (size_t)errlen, "%s: OpenEXR storage: deep images are not supported", path);
        return WDR_E_UNSUPPORTED;
    }
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int started = 0;
    rc = storage == EXR_STORAGE_SCANLINE ? read_scanlines(im, &dec, &started) : read_tiles(im, &dec, &started);
    if (started)
        exr_decoding_destroy(im->ctx, &dec);
    return rc ? exr_fail(path, "pixel data", rc, err, errlen) : WDR_OK;
}

static int exr_to_luminance(exr_image *im, float **lum)
{
    size_t n = (size_t)im->w * im->h;
    const float *p[3];
    for (int k = 0; k < 3; k++) /* a Y file decoded only into the first plane */
        p[k] = im->planes + (im->chan[k] == im->chan[0] ? 0 : (size_t)k * n);
    if (!(*lum = malloc(n * sizeof **lum)))
        return WDR_E_NOMEM;
    int grey = im->chan[0] == im->chan[1];
    for (size_t i = 0; i < n; i++)
        (*lum)[i] = grey ? p[0][i] : luminance(p[0][i], p[1][i], p[2][i]);
    return WDR_OK;
}

/* The data window in 64 bits (max - min + 1 overflows int for a hostile box), within
 * WDR_IMAGE_MAX_PIXELS, and no taller than the chunks the file's offset table can list (8 bytes
 * each): all before the planes are allocated. */
static int exr_size(exr_image *im, const char *path, char *err, int errlen)
{
    int64_t w = (int64_t)im->dw.max.x - im->dw.min.x + 1, h = (int64_t)im->dw.max.y - im->dw.min.y + 1;
    int32_t chunks = 0;
    FILE *f = fopen(path, "rb");
    long size = f && fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1;
    if (f)
        fclose(f);
    if (w < 1 || h < 1 || (uint64_t)w * (uint64_t)h > WDR_IMAGE_MAX_PIXELS) {
        snprintf(err, (size_t)errlen, "%s: OpenEXR data window: %lld x %lld is not 1 to %u pixels", path,
                 (long long)w, (long long)h, WDR_IMAGE_MAX_PIXELS);
        return WDR_E_INVAL;
    }
    if (exr_get_chunk_count(im->ctx, 0, &chunks) || chunks < 1 || size < 0 || (int64_t)chunks * 8 > size) {
        snprintf(err, (size_t)errlen, "%s: OpenEXR data window: %lld x %lld needs %d chunks, more than %ld bytes hold",
                 path, (long long)w, (long long)h, chunks, size);
        return WDR_E_INVAL;
    }
    im->w = (int)w;
    im->h = (int)h;
    return WDR_OK;
}

static int load_exr(const char *path, float **lum, int *w, int *h, char *err, int errlen)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_quiet;
    exr_image im = {0};
    exr_result_t rc = exr_start_read(&im.ctx, path, &init);
    if (rc)
        return exr_fail(path, "header", rc, err, errlen);
    int result = (rc = exr_get_data_window(im.ctx, 0, &im.dw)) ? exr_fail(path, "data window", rc, err, errlen)
                                                                : pick_channels(&im, path, err, errlen);
    if (!result)
        result = exr_size(&im, path, err, errlen);
    if (!result) {
        im.planes = calloc((size_t)3 * im.w * im.h, sizeof(float));
        result = im.planes ? read_pixels(&im, path, err, errlen) : WDR_E_NOMEM;
    }
    if (!result)
        result = exr_to_luminance(&im, lum);
    *w = im.w;
    *h = im.h;
    free(im.planes);
    exr_finish(&im.ctx);
    return result;
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
        return load_exr(path, lum, w, h, err, errlen);
    if (got >= 2 && magic[0] == '#' && magic[1] == '?')
        return load_radiance(path, lum, w, h, err, errlen);
    if (got >= 2 && magic[0] == 'P' && (magic[1] == 'f' || magic[1] == 'F'))
        return wdr_pfm_read(path, lum, w, h, err, errlen);
    snprintf(err, (size_t)errlen, "%s: not an OpenEXR, Radiance .hdr or PFM image (unknown first bytes)", path);
    return WDR_E_INVAL;
}
