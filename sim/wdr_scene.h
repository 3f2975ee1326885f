/* Scene files (sim/SPEC.md): what the simulated sensor looks at, and which effects to
 * simulate. Shared by wdrsim, the simulated HAL's board program and the tests. */
#ifndef WDR_SCENE_H
#define WDR_SCENE_H
#include "board.h"
#include "wdr_sim.h"
#include <stdint.h>
#include <stdio.h>

typedef struct wdr_scene {
    int width, height;             /* the sensor's: a scene is always rendered at the board's size */
    float *amps;                   /* width*height photocurrents, A, rows top-down */
    wdr_fx_mode effects[WDR_FX_COUNT];
    double tolerance_lsb;          /* auto's tolerance */
    int reference;                 /* a noiseless reference frame */
    uint64_t chip_seed, frame_seed;
    double lum_to_amp, exposure;   /* as the file says (exposure 1 when it says "auto") */
    double amp_per_lum;            /* the scale used: A per cd/m2 (after auto or an override) */
    int exposure_auto;             /* 1 if amp_per_lum was chosen by auto exposure */
    double l_avg;                  /* log-average luminance of the map, cd/m2 (before scaling) */
    double key_amp;                /* auto's target: the log-average current of the board's default ramps */
    int from_image;                /* 1 if the illumination is an image file */
    double below_floor, above_ceiling; /* fractions of pixels under i_min_a and over i_max_a */
    double i_min, i_max;           /* photocurrent range of the map */
    wdr_sim_defects defects;       /* "defects": rates and listed pixels (index/kind arrays malloc'd) */
    int has_defects;
    char illumination[160];        /* what lights it, for reports */
    char warning[640];             /* non-fatal remarks (clamped negatives, resampling), or "" */
} wdr_scene;

/* How the host tools place a scene in the sensor's range (--exposure auto|A_per_cd/m2). */
enum wdr_exposure_mode {
    WDR_EXPOSURE_SCENE = 0, /* the scene file's lum_to_amp * exposure (or its "exposure": "auto") */
    WDR_EXPOSURE_AUTO = 1,  /* log-average luminance to key_amp */
    WDR_EXPOSURE_FIXED = 2  /* amp_per_lum A per cd/m2 */
};
typedef struct wdr_exposure {
    int mode;               /* enum wdr_exposure_mode */
    double amp_per_lum;
} wdr_exposure;

/* "auto" or a number of A per cd/m2 in (0, 1]. @retval WDR_OK  @retval WDR_E_INVAL */
int wdr_exposure_parse(const char *text, wdr_exposure *out);

/* Read a scene for board b: path is a scene file, or a name ("window") looked up in
 * $WDR_SCENES_DIR or the installed scenes (sim/data_path.h; an unknown name's message lists the
 * known ones). Every error names the file, the field and the value.
 * @retval WDR_OK
 * @retval WDR_E_IO        scene or image file missing or unreadable
 * @retval WDR_E_INVAL     not JSON, unknown field or value, out of range, NaN/Inf pixels
 * @retval WDR_E_GEOMETRY  "size", or the image without a "fit" (crop, letterbox, stretch), differs from the board
 * @retval WDR_E_NOMEM */
int wdr_scene_load(const char *path, const wdr_board *b, wdr_scene *out, char *err, int errlen);
/* The same, with the exposure chosen by the caller (NULL: the scene's own). */
int wdr_scene_load_exposed(const char *path, const wdr_board *b, const wdr_exposure *ex, wdr_scene *out, char *err,
                           int errlen);
void wdr_scene_free(wdr_scene *sc);

/* Say, before a capture or render, the exposure used and what the sensor cannot see: the
 * fractions of pixels below its floor (i_min_a) and above its ceiling (i_max_a). */
void wdr_scene_print_range(FILE *f, const char *tool, const wdr_scene *sc, const wdr_board *b);

/* Give a chip the scene: effects, tolerance, reference flag and photocurrents.
 * @retval WDR_OK, WDR_E_GEOMETRY (chip of another size), WDR_E_INVAL */
int wdr_scene_apply(const wdr_scene *sc, wdr_sim *s);

#endif
