// OpenEXR through its C++ library (Imf), behind the C interface of exr_read.h. The C API of
// OpenEXR 3.1 refuses DWAA/DWAB ("Feature not yet implemented"); the C++ library reads them.
// No exception leaves this file: each becomes a WDR_E_* code and a message naming the file,
// the part and the compression.
#include "exr_read.h"
#include "wdr_err.h"
#include <openexr.h>
#include <Imath/half.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputPart.h>
#include <ImfMultiPartInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
#include <ImfTileDescription.h>
#include <ImfPartType.h>
#include <ImfVersion.h>
#include <cstdio>
#include <cstdlib>
#include <algorithm>
#include <cstring>
#include <exception>
#include <new>
#include <sys/stat.h>
#include <vector>

namespace {

struct compression_info {
    Imf::Compression id;
    const char *name;
};

const compression_info compressions[] = {
    {Imf::NO_COMPRESSION, "none"},   {Imf::RLE_COMPRESSION, "rle"},     {Imf::ZIPS_COMPRESSION, "zips"},
    {Imf::ZIP_COMPRESSION, "zip"},  {Imf::PIZ_COMPRESSION, "piz"},    {Imf::PXR24_COMPRESSION, "pxr24"},
    {Imf::B44_COMPRESSION, "b44"},  {Imf::B44A_COMPRESSION, "b44a"},  {Imf::DWAA_COMPRESSION, "dwaa"},
    {Imf::DWAB_COMPRESSION, "dwab"},
};

static_assert(sizeof compressions / sizeof compressions[0] == EXR_COMPRESSION_LAST_TYPE,
              "compressions[] is indexed by exr_compression_t");

const compression_info *compression_by_name(const char *name)
{
    for (const compression_info &ci : compressions)
        if (!strcmp(ci.name, name))
            return &ci;
    return nullptr;
}

// What the error messages say about where it went wrong.
struct where {
    const char *path;
    int part = -1;
    const char *compression = nullptr;
    char *err;
    int errlen;

    int fail(int code, const char *what) const
    {
        if (part < 0)
            snprintf(err, (size_t)errlen, "%s: OpenEXR: %s", path, what);
        else
            snprintf(err, (size_t)errlen, "%s: OpenEXR part %d (compression %s): %s", path, part,
                     compression ? compression : "unknown", what);
        return code;
    }
};

long file_size(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 ? (long)st.st_size : -1;
}

void quiet(exr_const_context_t, exr_result_t, const char *) {} // errors go through our message

int probe_bounds(const char *path, where &at, exr_storage_t storage, const exr_attr_box2i_t &dw, int32_t chunks);

// Skip one header's attributes (name, type, i32 size, value) up to its terminating NUL.
// 1: a header was there, 0: an empty header (the end of a multi-part list), -1: damaged.
int skip_header(FILE *f)
{
    for (int attrs = 0;; attrs++) {
        int strings = 0, c;
        for (long len = 0; strings < 2; len++) { // the name, then the type, each NUL-terminated
            if ((c = getc(f)) == EOF || len > 255)
                return -1;
            if (c == 0) {
                if (strings == 0 && len == 0)
                    return attrs ? 1 : 0; // a NUL where a name would start: the header's end
                strings++;
                len = -1;
            }
        }
        unsigned char size[4];
        if (fread(size, 1, 4, f) != 4)
            return -1;
        long n = (long)((uint32_t)size[0] | (uint32_t)size[1] << 8 | (uint32_t)size[2] << 16 | (uint32_t)size[3] << 24);
        if (n < 0 || fseek(f, n, SEEK_CUR) != 0)
            return -1;
    }
}

// Count the part headers with a constant amount of memory, before any library parses them all
// (20,000 parts held 195 MB for 2.4 s before they were refused).
int bound_parts(const char *path, where &at)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return at.fail(WDR_E_INVAL, "cannot open");
    unsigned char head[8];
    int parts = 0;
    if (fread(head, 1, 8, f) == 8 && head[0] == 0x76 && head[1] == 0x2f && head[2] == 0x31 && head[3] == 0x01) {
        const bool multi = head[5] & 0x10; // version flags bit 12: multi-part
        while (parts <= WDR_EXR_MAX_PARTS && skip_header(f) == 1) {
            parts++;
            if (!multi)
                break;
        }
    }
    fclose(f);
    if (parts > WDR_EXR_MAX_PARTS) {
        char why[96];
        snprintf(why, sizeof why, "header: more than %d parts (refused before reading them)", WDR_EXR_MAX_PARTS);
        return at.fail(WDR_E_INVAL, why);
    }
    return WDR_OK; // a damaged header is the C API's to name
}

// Uncompressed chunks must hold exactly the bytes of their lines: OpenEXR 3.1 fills what a
// short one lacks from a buffer it never initialised, and reports success.
int check_chunk(const exr_chunk_info_t &ci, where &at)
{
    if (ci.compression != EXR_COMPRESSION_NONE || ci.packed_size == ci.unpacked_size)
        return WDR_OK;
    char why[200];
    snprintf(why, sizeof why, "damaged: the uncompressed chunk at x %d, y %d (level %u,%u) holds %llu bytes, its "
             "%dx%d pixels need %llu", ci.start_x, ci.start_y, ci.level_x, ci.level_y,
             (unsigned long long)ci.packed_size, ci.width, ci.height, (unsigned long long)ci.unpacked_size);
    return at.fail(WDR_E_INVAL, why);
}

int check_scanline_chunks(exr_context_t ctx, const exr_attr_box2i_t &dw, where &at)
{
    int32_t lines = 0;
    exr_result_t rc = exr_get_scanlines_per_chunk(ctx, 0, &lines);
    for (int64_t y = dw.min.y; !rc && lines > 0 && y <= dw.max.y; y += lines) {
        exr_chunk_info_t ci;
        if ((rc = exr_read_scanline_chunk_info(ctx, 0, (int)y, &ci)) == EXR_ERR_SUCCESS && check_chunk(ci, at))
            return WDR_E_INVAL;
    }
    return rc ? at.fail(WDR_E_INVAL, exr_get_default_error_message(rc)) : WDR_OK;
}

int check_tile_chunks(exr_context_t ctx, where &at)
{
    int32_t levels_x = 0, levels_y = 0;
    uint32_t tw, th;
    exr_tile_level_mode_t mode;
    exr_tile_round_mode_t round;
    exr_result_t rc = exr_get_tile_levels(ctx, 0, &levels_x, &levels_y);
    if (!rc)
        rc = exr_get_tile_descriptor(ctx, 0, &tw, &th, &mode, &round);
    for (int lx = 0; !rc && lx < levels_x; lx++)
        for (int ly = 0; !rc && ly < levels_y; ly++) {
            int32_t lw, lh, sx, sy;
            if ((mode == EXR_TILE_MIPMAP_LEVELS && lx != ly) || (mode == EXR_TILE_ONE_LEVEL && (lx || ly)))
                continue;
            if ((rc = exr_get_level_sizes(ctx, 0, lx, ly, &lw, &lh)) || (rc = exr_get_tile_sizes(ctx, 0, lx, ly, &sx, &sy)))
                break;
            for (int ty = 0; !rc && sy > 0 && ty < (lh + sy - 1) / sy; ty++)
                for (int tx = 0; !rc && sx > 0 && tx < (lw + sx - 1) / sx; tx++) {
                    exr_chunk_info_t ci;
                    if ((rc = exr_read_tile_chunk_info(ctx, 0, tx, ty, lx, ly, &ci)) == EXR_ERR_SUCCESS &&
                        check_chunk(ci, at))
                        return WDR_E_INVAL;
                }
        }
    return rc ? at.fail(WDR_E_INVAL, exr_get_default_error_message(rc)) : WDR_OK;
}

// The header as the C API parses it (no pixels): part 0's compression, data window, storage and
// chunk count, checked against the bounds before the C++ library allocates anything; then the
// size of each uncompressed chunk against its lines.
int probe(const char *path, where &at)
{
    if (int bad = bound_parts(path, at))
        return bad;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = quiet;
    exr_context_t ctx = nullptr;
    exr_result_t rc = exr_start_read(&ctx, path, &init);
    exr_compression_t comp;
    exr_attr_box2i_t dw;
    exr_storage_t storage;
    int32_t chunks = 0;
    char why[240];
    at.part = 0;
    if (!rc && !(rc = exr_get_compression(ctx, 0, &comp)))
        at.compression = (unsigned)comp < sizeof compressions / sizeof compressions[0] ? compressions[comp].name
                                                                                         : nullptr;
    if (!rc)
        rc = exr_get_data_window(ctx, 0, &dw);
    if (!rc)
        rc = exr_get_storage(ctx, 0, &storage);
    if (!rc)
        rc = exr_get_chunk_count(ctx, 0, &chunks);
    snprintf(why, sizeof why, "header: %s", exr_get_default_error_message(rc));
    if (rc) {
        exr_finish(&ctx);
        return at.fail(WDR_E_INVAL, why);
    }
    int bad = probe_bounds(path, at, storage, dw, chunks);
    if (!bad && comp == EXR_COMPRESSION_NONE)
        bad = storage == EXR_STORAGE_TILED ? check_tile_chunks(ctx, at) : check_scanline_chunks(ctx, dw, at);
    exr_finish(&ctx);
    return bad;
}

bool window_in_limits(long w, long h)
{
    return w > 0 && h > 0 && w <= WDR_EXR_MAX_SIDE && h <= WDR_EXR_MAX_SIDE && w * h <= WDR_EXR_MAX_PIXELS;
}

int probe_bounds(const char *path, where &at, exr_storage_t storage, const exr_attr_box2i_t &dw, int32_t chunks)
{
    char why[240];
    if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED)
        return at.fail(WDR_E_UNSUPPORTED, "deep data is not supported");
    long w = (long)dw.max.x - dw.min.x + 1, h = (long)dw.max.y - dw.min.y + 1, bytes = file_size(path);
    if (!window_in_limits(w, h)) {
        snprintf(why, sizeof why, "data window %ldx%ld outside the limits (sides 1..%d, at most %ld pixels)", w, h,
                 WDR_EXR_MAX_SIDE, WDR_EXR_MAX_PIXELS);
        return at.fail(WDR_E_INVAL, why);
    }
    if ((long)chunks * 8 > bytes) { /* each chunk costs 8 bytes of offset table at least */
        snprintf(why, sizeof why, "data window %ldx%ld needs %d chunks but the file has only %ld bytes", w, h,
                 (int)chunks, bytes);
        return at.fail(WDR_E_INVAL, why);
    }
    return WDR_OK;
}

// Names of the three channels to read (all "Y" for a luminance-only file), or an error.
int pick_channels(const Imf::ChannelList &cl, const where &at, const char *names[3])
{
    auto full = [&](const char *n) {
        const Imf::Channel *c = cl.findChannel(n);
        return c && c->xSampling == 1 && c->ySampling == 1;
    };
    if (full("R") && full("G") && full("B")) {
        names[0] = "R", names[1] = "G", names[2] = "B";
        return WDR_OK;
    }
    if (full("Y")) {
        names[0] = names[1] = names[2] = "Y";
        return WDR_OK;
    }
    return at.fail(WDR_E_UNSUPPORTED, "need full-resolution R, G, B or Y channels");
}

// Rows y0..y0+rows-1 of the data window into lum, a strip at a time (memory stays small).
void read_strip(Imf::InputPart &in, const IMATH_NAMESPACE::Box2i &dw, const char *const names[3], int y0, int rows,
                std::vector<float> &planes, float *lum)
{
    const int w = dw.max.x - dw.min.x + 1;
    const bool grey = !strcmp(names[0], names[1]);
    const size_t n = (size_t)w * rows;
    Imf::FrameBuffer fb;
    for (int k = 0; k < (grey ? 1 : 3); k++)
        fb.insert(names[k], Imf::Slice::Make(Imf::FLOAT, planes.data() + k * n, IMATH_NAMESPACE::V2i(dw.min.x, y0), w,
                                              rows, sizeof(float), (size_t)w * sizeof(float)));
    std::fill(planes.begin(), planes.end(), 0.0f); // no strip shows what an earlier one left
    in.setFrameBuffer(fb);
    in.readPixels(y0, y0 + rows - 1);
    for (size_t i = 0; i < n; i++)
        lum[i] = grey ? planes[i] : 0.2126f * planes[i] + 0.7152f * planes[n + i] + 0.0722f * planes[2 * n + i];
}

int read_part0(const char *path, where &at, float **lum, int *w, int *h)
{
    int rc = probe(path, at);
    if (rc)
        return rc;
    Imf::MultiPartInputFile file(path);
    const Imf::Header &hdr = file.header(0);
    const IMATH_NAMESPACE::Box2i dw = hdr.dataWindow();
    // The C++ library parses the header again and need not agree with the C API's reading that
    // probe() bounded: a fuzzed file passed the probe and then asked for a 50 GB strip here.
    const long wl = (long)dw.max.x - dw.min.x + 1, hl = (long)dw.max.y - dw.min.y + 1;
    if (!window_in_limits(wl, hl)) {
        char why[240];
        snprintf(why, sizeof why,
                 "data window %ldx%ld as the OpenEXR library reads the header, outside the limits (sides 1..%d, at "
                 "most %ld pixels)",
                 wl, hl, WDR_EXR_MAX_SIDE, WDR_EXR_MAX_PIXELS);
        return at.fail(WDR_E_INVAL, why);
    }
    *w = (int)wl;
    *h = (int)hl;
    const char *names[3];
    if ((rc = pick_channels(hdr.channels(), at, names)))
        return rc;
    Imf::InputPart in(file, 0);
    const int strip = 256;
    std::vector<float> planes((size_t)3 * *w * strip);
    *lum = (float *)malloc((size_t)*w * *h * sizeof(float));
    if (!*lum)
        return at.fail(WDR_E_NOMEM, "out of memory");
    for (int y = 0; y < *h; y += strip)
        read_strip(in, dw, names, dw.min.y + y, *h - y < strip ? *h - y : strip, planes, *lum + (size_t)y * *w);
    return WDR_OK;
}

} // namespace

extern "C" int wdr_exr_read(const char *path, float **lum, int *w, int *h, char *err, int errlen)
{
    where at{path, -1, nullptr, err, errlen};
    *lum = nullptr;
    *w = *h = 0;
    int rc;
    try {
        rc = read_part0(path, at, lum, w, h);
    } catch (const std::bad_alloc &) {
        rc = at.fail(WDR_E_NOMEM, "out of memory");
    } catch (const std::exception &e) {
        rc = at.fail(WDR_E_INVAL, e.what());
    }
    if (rc) {
        free(*lum);
        *lum = nullptr;
    }
    return rc;
}

extern "C" int wdr_exr_write(const char *path, const float *y, const float *const rgb[3], int w, int h,
                             const char *compression, int half, char *err, int errlen)
{
    const compression_info *ci = compression_by_name(compression);
    if (!ci) {
        snprintf(err, (size_t)errlen, "%s: unknown OpenEXR compression '%s' (none, rle, zips, zip, piz, pxr24, b44, "
                 "b44a, dwaa, dwab)", path, compression);
        return WDR_E_INVAL;
    }
    try {
        Imf::Header hdr(w, h);
        hdr.compression() = ci->id;
        const Imf::PixelType type = half ? Imf::HALF : Imf::FLOAT;
        const char *names[3] = {"R", "G", "B"};
        const int nch = rgb ? 3 : 1;
        for (int k = 0; k < nch; k++)
            hdr.channels().insert(rgb ? names[k] : "Y", Imf::Channel(type));
        // Output files do not convert pixel types: half files get half planes made here.
        const size_t n = (size_t)w * h;
        std::vector<IMATH_NAMESPACE::half> halves(half ? n * nch : 0);
        Imf::FrameBuffer fb;
        for (int k = 0; k < nch; k++) {
            const float *src = rgb ? rgb[k] : y;
            for (size_t i = 0; half && i < n; i++)
                halves[k * n + i] = src[i];
            char *base = half ? (char *)(halves.data() + k * n) : (char *)src;
            size_t px = half ? sizeof(IMATH_NAMESPACE::half) : sizeof(float);
            fb.insert(rgb ? names[k] : "Y", Imf::Slice(type, base, px, (size_t)w * px));
        }
        Imf::OutputFile out(path, hdr);
        out.setFrameBuffer(fb);
        out.writePixels(h);
    } catch (const std::exception &e) {
        snprintf(err, (size_t)errlen, "%s: OpenEXR write (compression %s): %s", path, ci->name, e.what());
        return WDR_E_IO;
    }
    return WDR_OK;
}
