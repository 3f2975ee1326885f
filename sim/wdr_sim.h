/* The simulated sensor: a physical pixel array (paper Fig. 1) behind the simulated HAL and
 * the wdrsim front end. A "chip" draws its fixed-pattern parameters once from a seed; temporal
 * noise is drawn per frame from the frame seed. Same seeds, same bits.
 * This is the contract between sim/ and hal/sim; sim/ may add functions, never change these. */
#ifndef WDR_SIM_H
#define WDR_SIM_H
#include "board.h"
#include "wdr_lut.h"
#include <stddef.h>
#include <stdint.h>

typedef struct wdr_sim wdr_sim;

enum wdr_effect {
    WDR_FX_MISMATCH,   /* per-pixel V_T (M1..M3), beta, C_PD and dark-current spread */
    WDR_FX_DARK,       /* dark current */
    WDR_FX_SHOT,       /* photon shot noise */
    WDR_FX_KTC,        /* reset noise on C_PD */
    WDR_FX_READ,       /* read noise of the column chain */
    WDR_FX_DAC_QUANT,  /* stepped ramp: DAC codes and step times (off: ideal continuous ramp) */
    WDR_FX_ADC_QUANT,  /* column ADC quantisation (off: continuous output code) */
    WDR_FX_LEAKAGE,    /* hold-node droop until the row is read */
    WDR_FX_CLIPPING,   /* DAC and ADC rails */
    WDR_FX_DEFECTS,    /* planted defective pixels: dead, stuck, hot, saturated (wdr_sim_set_defects) */
    WDR_FX_COUNT
};

typedef enum wdr_fx_mode { WDR_FX_OFF = 0, WDR_FX_ON = 1, WDR_FX_AUTO = 2 } wdr_fx_mode;

/* What one run did with each effect, and why. */
typedef struct wdr_fx_report {
    wdr_fx_mode requested;
    int ran;                 /* 1 if the effect was simulated */
    double estimate_lsb;     /* estimated worst-case size for this scene, in ADC LSB */
    char why[160];
} wdr_fx_report;

const char *wdr_effect_name(int fx);          /* "mismatch", "dark", ... as in scene files */
int wdr_effect_from_name(const char *name);   /* -1 if unknown */

/* Create a chip for board b; fixed-pattern parameters come from chip_seed. NULL on no memory. */
wdr_sim *wdr_sim_create(const wdr_board *b, uint64_t chip_seed);
void wdr_sim_destroy(wdr_sim *s);

void wdr_sim_set_effect(wdr_sim *s, int fx, wdr_fx_mode mode);
void wdr_sim_set_auto_tolerance(wdr_sim *s, double lsb); /* default 0.25 ADC LSB */
void wdr_sim_set_threads(wdr_sim *s, int n);              /* 0: all cores */

/* The ramp the DAC plays next (copied). @retval WDR_OK, WDR_E_INVAL */
int wdr_sim_set_lut(wdr_sim *s, const wdr_lut_view *lut);

/* Illumination as photocurrent in amperes: one value for all pixels, or a width*height map.
 * @retval WDR_OK, WDR_E_INVAL (NaN, negative or above 1 A), WDR_E_NOMEM */
int wdr_sim_set_uniform(wdr_sim *s, double amps);
int wdr_sim_set_photocurrent(wdr_sim *s, const float *amps);
/* The illumination set now: the width*height map (owned by s, valid until the next set), or
 * NULL when every pixel sees *uniform_amps. Lets a caller put a scene back after uniform light. */
const float *wdr_sim_photocurrent(const wdr_sim *s, double *uniform_amps);

/* Global reset, integration and compare for every pixel; afterwards each hold node holds its
 * value. @retval WDR_OK, WDR_E_NO_TABLE (no LUT set) */
int wdr_sim_expose(wdr_sim *s, uint64_t frame_seed);

/* Read one row t_after_s seconds after integration ended: leakage, source follower, read noise,
 * ADC. codes gets width values. @retval WDR_OK, WDR_E_INVAL (row out of range or not exposed) */
int wdr_sim_read_row(wdr_sim *s, int row, double t_after_s, uint16_t *codes);

/* Expose and read every row at the board's row time: a whole raw frame (width*height codes). */
int wdr_sim_render(wdr_sim *s, uint64_t frame_seed, uint16_t *frame);

/* Same, but float codes: unrounded unless adc_quant is on, and outside [0, 2^bits - 1] only if
 * clipping is off (for studies and calibration truth). */
int wdr_sim_render_float(wdr_sim *s, uint64_t frame_seed, float *frame);

/* Report of the last expose/render, indexed by enum wdr_effect. */
const wdr_fx_report *wdr_sim_report(const wdr_sim *s);

/* ---- Additions (sim/SPEC.md) ---------------------------------------------------------- */

/* Defective pixels (effect "defects", sim/SPEC.md), planted by physics, not by code:
 * dead: the photodiode gives no current (neither photo nor dark current);
 * stuck: the hold node is shorted to a fixed voltage (drawn per pixel over the ramp's span);
 * hot: a dark current of hot_amps on top of the photocurrent;
 * saturated: the column output sits at the ADC's top rail. */
enum wdr_defect_kind { WDR_DEFECT_NONE, WDR_DEFECT_DEAD, WDR_DEFECT_STUCK, WDR_DEFECT_HOT, WDR_DEFECT_SATURATED,
                       WDR_DEFECT_KINDS };
const char *wdr_defect_name(int kind); /* "dead", "stuck", "hot", "saturated" */

typedef struct wdr_sim_defects {
    double ppm[WDR_DEFECT_KINDS]; /* rate of each kind (per million pixels), at positions drawn from seed */
    double hot_amps;              /* a hot pixel's dark current (A; 0: 1e-11) */
    uint64_t seed;                /* positions of the rates; 0: the chip seed */
    int n_listed;                 /* and pixels at given positions: */
    const long *listed_index;     /* y * width + x */
    const uint8_t *listed_kind;   /* enum wdr_defect_kind */
} wdr_sim_defects;

/* Plant defects (replacing earlier ones; NULL clears). Rates give round(ppm * pixels / 1e6)
 * distinct pixels of each kind; a listed pixel overrides a drawn one.
 * @retval WDR_OK, WDR_E_INVAL (negative or > 1e6 ppm, kind or index out of range), WDR_E_NOMEM */
int wdr_sim_set_defects(wdr_sim *s, const wdr_sim_defects *d);
/* The ground truth: kind per pixel (width*height, WDR_DEFECT_NONE for healthy), and the count
 * of one kind (WDR_DEFECT_NONE: all defective pixels). */
void wdr_sim_defect_map(const wdr_sim *s, uint8_t *kind);
long wdr_sim_defect_count(const wdr_sim *s, int kind);

/* Mode of one effect (WDR_FX_OFF for an unknown effect). New chips have every effect ON. */
wdr_fx_mode wdr_sim_get_effect(const wdr_sim *s, int fx);

/* The continuous V_ref(t) used when DAC quantisation is off: n points, t rising from >= 0 (s),
 * v non-decreasing (V); copied, held flat after the last point until the LUT's integration end.
 * n = 0 goes back to the default: a line through the mid-points of the LUT's steps.
 * @retval WDR_OK, WDR_E_INVAL (non-finite, not rising), WDR_E_NOMEM */
int wdr_sim_set_ramp(wdr_sim *s, const double *t_s, const double *v, int n);

/* Mark the next frames as a noiseless reference: `auto` then skips shot, kTC and read noise. */
void wdr_sim_set_reference(wdr_sim *s, int reference);

/* Called from the rendering caller's thread as rows finish (rows_done rises to rows_total). */
void wdr_sim_set_progress(wdr_sim *s, void (*fn)(void *ctx, int rows_done, int rows_total), void *ctx);

const wdr_board *wdr_sim_board(const wdr_sim *s);

/* End of integration of the LUT set (s), 0 before any LUT: rows are read after it. */
double wdr_sim_integration_time(const wdr_sim *s);

/* Fixed-pattern devices of one pixel as this chip drew them: calibration's ground truth. */
typedef struct wdr_sim_pixel_truth {
    double dq0_c;      /* reset charge minus the nominal pixel's (M1 threshold and C_PD), C */
    double dvt2_v;     /* M2 threshold offset, V */
    double c_pd_scale; /* C_PD relative to nominal */
    double dark_a;     /* dark current, A */
    double sf_k_v;     /* source-follower constant phi + gamma sqrt(phi) - V_T0,3 - sqrt(2 I_b / beta3) */
} wdr_sim_pixel_truth;

/* @retval WDR_OK, WDR_E_INVAL (outside the array) */
int wdr_sim_pixel_devices(const wdr_sim *s, int x, int y, wdr_sim_pixel_truth *out);

#endif
