/* Fitting an HDR luminance image onto the sensor: a windowed filter (stb_image_resize), never a
 * point sample, so small bright sources keep their energy; aspect kept unless asked otherwise. */
#ifndef WDR_RESAMPLE_H
#define WDR_RESAMPLE_H

typedef enum wdr_fit {
    WDR_FIT_EXACT = 0,     /* sizes must match */
    WDR_FIT_CROP = 1,      /* scale to cover the sensor, cut the centre (aspect kept; the default) */
    WDR_FIT_LETTERBOX = 2, /* scale to fit inside, black (0 cd/m2) bars around (aspect kept) */
    WDR_FIT_STRETCH = 3    /* scale each axis on its own (aspect changes) */
} wdr_fit;

/* "exact", "crop", "letterbox", "stretch" ("resample", the old name, is crop); -1 if unknown. */
int wdr_fit_from_name(const char *name);
const char *wdr_fit_name(wdr_fit fit);

/* Fit img (iw x ih) onto out (w x h) as fit says, with an area filter (box) where an axis shrinks
 * and a triangle where it grows; both have no negative lobes, so no ringing below 0 and the mean
 * of every region is kept. what receives one sentence of what was done (sizes, crop, bars, filter).
 * @retval WDR_OK  @retval WDR_E_GEOMETRY exact with other sizes  @retval WDR_E_NOMEM */
int wdr_resample_fit(const float *img, int iw, int ih, float *out, int w, int h, wdr_fit fit, char *what,
                     int whatlen);

#endif
