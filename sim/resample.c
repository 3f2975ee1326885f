/* Fitting images onto the sensor with stb_image_resize (libstb). The filter is chosen per axis:
 * box (area average) to shrink, triangle to grow. */
#include "resample.h"
#include "wdr_err.h"
#include <stb_image_resize.h>
#include <stdio.h>
#include <string.h>

static const char *const fit_names[] = {"exact", "crop", "letterbox", "stretch"};

int wdr_fit_from_name(const char *name)
{
    if (!strcmp(name, "resample"))
        return WDR_FIT_CROP;
    for (int k = 0; k < 4; k++)
        if (!strcmp(name, fit_names[k]))
            return k;
    return -1;
}

const char *wdr_fit_name(wdr_fit fit) { return fit_names[fit]; }

typedef struct rect {
    int x, y, w, h;
} rect;

static stbir_filter filter_for(int from, int to) { return to < from ? STBIR_FILTER_BOX : STBIR_FILTER_TRIANGLE; }

static const char *filter_name(int from, int to) { return to < from ? "area" : to > from ? "triangle" : "none"; }

/* src (a window of img) onto dst (a window of out). */
static int resize(const float *img, int iw, rect src, float *out, int w, rect dst)
{
    const float *in = img + (long)src.y * iw + src.x;
    float *o = out + (long)dst.y * w + dst.x;
    int ok = stbir_resize(in, src.w, src.h, iw * (int)sizeof(float), o, dst.w, dst.h, w * (int)sizeof(float),
                          STBIR_TYPE_FLOAT, 1, STBIR_ALPHA_CHANNEL_NONE, 0, STBIR_EDGE_CLAMP, STBIR_EDGE_CLAMP,
                          filter_for(src.w, dst.w), filter_for(src.h, dst.h), STBIR_COLORSPACE_LINEAR, NULL);
    return ok ? WDR_OK : WDR_E_NOMEM;
}

static int round_pos(double v) { return v < 1 ? 1 : (int)(v + 0.5); }

int wdr_resample_fit(const float *img, int iw, int ih, float *out, int w, int h, wdr_fit fit, char *what,
                     int whatlen)
{
    rect src = {0, 0, iw, ih}, dst = {0, 0, w, h};
    double img_aspect = (double)iw / ih, sensor_aspect = (double)w / h;
    if (iw == w && ih == h) {
        memcpy(out, img, sizeof *out * (size_t)w * h);
        snprintf(what, (size_t)whatlen, "%dx%d used as is", iw, ih);
        return WDR_OK;
    }
    if (fit == WDR_FIT_EXACT)
        return WDR_E_GEOMETRY;
    if (fit == WDR_FIT_CROP && img_aspect > sensor_aspect) { /* too wide: keep the centre columns */
        src.w = round_pos(ih * sensor_aspect);
        src.x = (iw - src.w) / 2;
    } else if (fit == WDR_FIT_CROP && img_aspect < sensor_aspect) {
        src.h = round_pos(iw / sensor_aspect);
        src.y = (ih - src.h) / 2;
    } else if (fit == WDR_FIT_LETTERBOX && img_aspect > sensor_aspect) { /* bars top and bottom */
        dst.h = round_pos(w / img_aspect);
        dst.y = (h - dst.h) / 2;
    } else if (fit == WDR_FIT_LETTERBOX && img_aspect < sensor_aspect) {
        dst.w = round_pos(h * img_aspect);
        dst.x = (w - dst.w) / 2;
    }
    if (fit == WDR_FIT_LETTERBOX)
        memset(out, 0, sizeof *out * (size_t)w * h);
    int rc = resize(img, iw, src, out, w, dst);
    snprintf(what, (size_t)whatlen,
             "resampled from %dx%d to %dx%d (fit %s: source %dx%d at (%d, %d) onto %dx%d at (%d, %d); "
             "filter %s x, %s y)",
             iw, ih, w, h, wdr_fit_name(fit), src.w, src.h, src.x, src.y, dst.w, dst.h, dst.x, dst.y,
             filter_name(src.w, dst.w), filter_name(src.h, dst.h));
    return rc;
}
