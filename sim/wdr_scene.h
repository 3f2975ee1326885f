/* Scene files (sim/SPEC.md): what the simulated sensor looks at, and which effects to
 * simulate. Shared by wdrsim, the simulated HAL's board program and the tests. */
#ifndef WDR_SCENE_H
#define WDR_SCENE_H
#include "board.h"
#include "wdr_sim.h"
#include <stdint.h>

typedef struct wdr_scene {
    int width, height;             /* the sensor's: a scene is always rendered at the board's size */
    float *amps;                   /* width*height photocurrents, A, rows top-down */
    wdr_fx_mode effects[WDR_FX_COUNT];
    double tolerance_lsb;          /* auto's tolerance */
    int reference;                 /* a noiseless reference frame */
    uint64_t chip_seed, frame_seed;
    double lum_to_amp, exposure;
    double i_min, i_max;           /* photocurrent range of the map */
    wdr_sim_defects defects;       /* "defects": rates and listed pixels (index/kind arrays malloc'd) */
    int has_defects;
    char illumination[160];        /* what lights it, for reports */
    char warning[256];             /* non-fatal remark (clamped negatives, resampling), or "" */
} wdr_scene;

/* Read a scene for board b. Every error names the file, the field and the value.
 * @retval WDR_OK
 * @retval WDR_E_IO        scene or image file missing or unreadable
 * @retval WDR_E_INVAL     not JSON, unknown field or value, out of range, NaN/Inf pixels
 * @retval WDR_E_GEOMETRY  "size" or the image (without "fit": "resample") differs from the board
 * @retval WDR_E_NOMEM */
int wdr_scene_load(const char *path, const wdr_board *b, wdr_scene *out, char *err, int errlen);
void wdr_scene_free(wdr_scene *sc);

/* Give a chip the scene: effects, tolerance, reference flag and photocurrents.
 * @retval WDR_OK, WDR_E_GEOMETRY (chip of another size), WDR_E_INVAL */
int wdr_scene_apply(const wdr_scene *sc, wdr_sim *s);

#endif
