/* Frames into a V4L2 output device (a v4l2loopback device), so that any V4L2 program (v4l2-ctl,
 * ffmpeg, GStreamer, OBS, a browser) sees the camera: `wdrctl stream --v4l2 /dev/videoN`.
 * The format, size and frame rate are negotiated as V4L2 writers do: VIDIOC_S_FMT, then the
 * format the driver set is what is written (its bytesperline and sizeimage), VIDIOC_S_PARM for
 * the time per frame; frames go out with write(). A path that is not a character device (a
 * regular file, a pipe) takes the same frames back to back, with no negotiation: for tests and
 * for piping into another program. */
#ifndef WDR_V4L2_OUT_H
#define WDR_V4L2_OUT_H
#include <stdint.h>

typedef enum wdr_v4l2_format {
    WDR_V4L2_GREY = 0, /* 8-bit grey, the display image: brighter light brighter, the ADC range onto 0..255 */
    WDR_V4L2_Y16 = 1,  /* 16-bit grey, little-endian: the corrected codes as the board sends them */
} wdr_v4l2_format;

typedef struct wdr_v4l2_out {
    int fd;
    int is_device;          /* 0: a file or a pipe, raw frames */
    wdr_v4l2_format format;
    int width, height;
    unsigned adc_bits;
    uint32_t bytesperline;  /* as the driver set it (at least width * bytes per pixel) */
    uint32_t sizeimage;     /* bytes written per frame */
    uint32_t fps_num, fps_den; /* frames per second the driver took: num/den (0/0: not settable) */
    uint8_t *frame;         /* sizeimage bytes */
} wdr_v4l2_out;

/* Name of a format ("GREY", "Y16"), and the format of a name (case-insensitive); -1 if unknown. */
const char *wdr_v4l2_format_name(wdr_v4l2_format f);
int wdr_v4l2_format_of(const char *name);

/* Open path and negotiate width x height in format f at fps_num/fps_den frames per second.
 * err names the device, the request and what the driver answered.
 * @retval WDR_OK  @retval WDR_E_IO (cannot open or write)  @retval WDR_E_UNSUPPORTED (not a
 * video output device, or it refused the format or size)  @retval WDR_E_NOMEM */
int wdr_v4l2_open(wdr_v4l2_out *v, const char *path, wdr_v4l2_format f, int width, int height, unsigned adc_bits,
                  uint32_t fps_num, uint32_t fps_den, char *err, int errlen);

/* One frame of width*height codes, packed (wdr_v4l2_pack) and written whole.
 * @retval WDR_OK  @retval WDR_E_IO (err says why) */
int wdr_v4l2_write(wdr_v4l2_out *v, const uint16_t *codes, char *err, int errlen);

void wdr_v4l2_close(wdr_v4l2_out *v);

/* Pack codes into a frame of the format: rows bytesperline apart (padding zero). GREY maps
 * code c to round((2^adc_bits - 1 - c) * 255 / (2^adc_bits - 1)), as `wdrctl capture --bits 8
 * --negate` writes its PNG; Y16 keeps c. */
void wdr_v4l2_pack(wdr_v4l2_format f, const uint16_t *codes, int width, int height, unsigned adc_bits,
                   uint32_t bytesperline, uint8_t *out);

#endif
