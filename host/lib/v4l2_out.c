/* Frames into a V4L2 output device (see v4l2_out.h). */
#include "v4l2_out.h"
#include "wdr_err.h"
#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <unistd.h>

static const struct {
    const char *name;
    uint32_t fourcc;
    int bytes; /* per pixel */
} formats[] = {{"GREY", V4L2_PIX_FMT_GREY, 1}, {"Y16", V4L2_PIX_FMT_Y16, 2}};

const char *wdr_v4l2_format_name(wdr_v4l2_format f) { return formats[f].name; }

int wdr_v4l2_format_of(const char *name)
{
    for (int k = 0; k < (int)(sizeof formats / sizeof *formats); k++)
        if (!strcasecmp(name, formats[k].name))
            return k;
    return -1;
}

/* ---- Pixels ---------------------------------------------------------------------------------- */

void wdr_v4l2_pack(wdr_v4l2_format f, const uint16_t *codes, int width, int height, unsigned adc_bits,
                   uint32_t bytesperline, uint8_t *out)
{
    double full = (double)((1u << adc_bits) - 1u);
    memset(out, 0, (size_t)bytesperline * height);
    for (int y = 0; y < height; y++) {
        uint8_t *row = out + (size_t)y * bytesperline;
        const uint16_t *c = codes + (size_t)y * width;
        for (int x = 0; x < width; x++) {
            if (f == WDR_V4L2_Y16) {
                row[2 * x] = (uint8_t)(c[x] & 0xffu);
                row[2 * x + 1] = (uint8_t)(c[x] >> 8);
            } else { /* the display image: the codes fall with light */
                double v = (full - c[x]) * 255.0 / full;
                row[x] = (uint8_t)lround(v < 0 ? 0 : v > 255 ? 255 : v);
            }
        }
    }
}

/* ---- Negotiation ------------------------------------------------------------------------------- */

static int xioctl(int fd, unsigned long req, void *arg)
{
    int r;
    do
        r = ioctl(fd, req, arg);
    while (r < 0 && errno == EINTR);
    return r;
}

static char *fourcc_text(uint32_t f, char out[5])
{
    for (int k = 0; k < 4; k++)
        out[k] = (char)((f >> (8 * k)) & 0xff);
    out[4] = 0;
    return out;
}

/* An output device that takes write(): what v4l2loopback offers a writer. */
static int check_caps(wdr_v4l2_out *v, const char *path, char *err, int errlen)
{
    struct v4l2_capability cap;
    memset(&cap, 0, sizeof cap);
    if (xioctl(v->fd, VIDIOC_QUERYCAP, &cap) < 0) {
        snprintf(err, (size_t)errlen, "%s: not a V4L2 device (VIDIOC_QUERYCAP: %s)", path, strerror(errno));
        return WDR_E_UNSUPPORTED;
    }
    uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    if (!(caps & V4L2_CAP_VIDEO_OUTPUT) || !(caps & V4L2_CAP_READWRITE)) {
        snprintf(err, (size_t)errlen, "%s (%s, driver %s): not a video output that takes write() (capabilities 0x%08x); "
                 "a v4l2loopback device is (modprobe v4l2loopback)", path, (const char *)cap.card,
                 (const char *)cap.driver, caps);
        return WDR_E_UNSUPPORTED;
    }
    return WDR_OK;
}

/* VIDIOC_S_FMT, then take what the driver set: the format and size must be ours, its line
 * length and image size are what we write. */
static int set_format(wdr_v4l2_out *v, const char *path, char *err, int errlen)
{
    struct v4l2_format fmt;
    memset(&fmt, 0, sizeof fmt);
    fmt.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    fmt.fmt.pix.width = (uint32_t)v->width;
    fmt.fmt.pix.height = (uint32_t)v->height;
    fmt.fmt.pix.pixelformat = formats[v->format].fourcc;
    fmt.fmt.pix.field = V4L2_FIELD_NONE;
    fmt.fmt.pix.bytesperline = (uint32_t)(v->width * formats[v->format].bytes);
    fmt.fmt.pix.sizeimage = fmt.fmt.pix.bytesperline * (uint32_t)v->height;
    fmt.fmt.pix.colorspace = V4L2_COLORSPACE_RAW;
    char got[5];
    if (xioctl(v->fd, VIDIOC_S_FMT, &fmt) < 0) {
        snprintf(err, (size_t)errlen, "%s: VIDIOC_S_FMT %s %dx%d refused: %s (another program may hold its format)",
                 path, formats[v->format].name, v->width, v->height, strerror(errno));
        return WDR_E_UNSUPPORTED;
    }
    struct v4l2_pix_format *p = &fmt.fmt.pix;
    uint32_t min_line = (uint32_t)(v->width * formats[v->format].bytes);
    if (p->pixelformat != formats[v->format].fourcc || p->width != (uint32_t)v->width ||
        p->height != (uint32_t)v->height || p->bytesperline < min_line || p->sizeimage < p->bytesperline * p->height) {
        snprintf(err, (size_t)errlen, "%s: asked for %s %dx%d, the driver set %s %ux%u (%u bytes per line, %u per image)",
                 path, formats[v->format].name, v->width, v->height, fourcc_text(p->pixelformat, got), p->width,
                 p->height, p->bytesperline, p->sizeimage);
        return WDR_E_UNSUPPORTED;
    }
    v->bytesperline = p->bytesperline;
    v->sizeimage = p->sizeimage;
    return WDR_OK;
}

/* VIDIOC_S_PARM: the time per frame readers see; the driver's answer is kept (0/0: it has none). */
static void set_rate(wdr_v4l2_out *v, uint32_t fps_num, uint32_t fps_den)
{
    struct v4l2_streamparm parm;
    memset(&parm, 0, sizeof parm);
    parm.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    parm.parm.output.timeperframe.numerator = fps_den; /* seconds per frame: the inverse */
    parm.parm.output.timeperframe.denominator = fps_num;
    v->fps_num = v->fps_den = 0;
    if (fps_num && fps_den && xioctl(v->fd, VIDIOC_S_PARM, &parm) == 0 &&
        parm.parm.output.timeperframe.numerator && parm.parm.output.timeperframe.denominator) {
        v->fps_num = parm.parm.output.timeperframe.denominator;
        v->fps_den = parm.parm.output.timeperframe.numerator;
    }
}

int wdr_v4l2_open(wdr_v4l2_out *v, const char *path, wdr_v4l2_format f, int width, int height, unsigned adc_bits,
                  uint32_t fps_num, uint32_t fps_den, char *err, int errlen)
{
    struct stat st;
    memset(v, 0, sizeof *v);
    v->fd = -1;
    v->format = f, v->width = width, v->height = height, v->adc_bits = adc_bits;
    v->is_device = stat(path, &st) == 0 && S_ISCHR(st.st_mode);
    v->fd = v->is_device ? open(path, O_RDWR) : open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (v->fd < 0) {
        snprintf(err, (size_t)errlen, "%s: cannot open: %s", path, strerror(errno));
        return WDR_E_IO;
    }
    int rc = WDR_OK;
    if (v->is_device && (rc = check_caps(v, path, err, errlen)) == WDR_OK && (rc = set_format(v, path, err, errlen)) == WDR_OK)
        set_rate(v, fps_num, fps_den);
    if (!v->is_device) { /* a file or a pipe: the frames as the format packs them, back to back */
        v->bytesperline = (uint32_t)(width * formats[f].bytes);
        v->sizeimage = v->bytesperline * (uint32_t)height;
        v->fps_num = fps_num, v->fps_den = fps_den;
    }
    if (rc == WDR_OK && !(v->frame = calloc(1, v->sizeimage)))
        rc = WDR_E_NOMEM;
    if (rc != WDR_OK)
        wdr_v4l2_close(v);
    return rc;
}

int wdr_v4l2_write(wdr_v4l2_out *v, const uint16_t *codes, char *err, int errlen)
{
    wdr_v4l2_pack(v->format, codes, v->width, v->height, v->adc_bits, v->bytesperline, v->frame);
    size_t done = 0;
    while (done < v->sizeimage) {
        ssize_t n = write(v->fd, v->frame + done, v->sizeimage - done);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            snprintf(err, (size_t)errlen, "writing a frame: %s", n < 0 ? strerror(errno) : "nothing written");
            return WDR_E_IO;
        }
        done += (size_t)n;
    }
    return WDR_OK;
}

void wdr_v4l2_close(wdr_v4l2_out *v)
{
    if (v->fd >= 0)
        close(v->fd);
    free(v->frame);
    v->fd = -1;
    v->frame = NULL;
}
