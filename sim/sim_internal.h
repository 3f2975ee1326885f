/* Inside the simulator: the chip's fixed pattern, the ramp tables the crossing search walks,
 * and the per-pixel physics shared by expose, read_row and render. Not for other folders. */
#ifndef WDR_SIM_INTERNAL_H
#define WDR_SIM_INTERNAL_H
#include "pixel.h"
#include "wdr_sim.h"
#include <stdint.h>
#include <string.h>

#define SIM_Q_E 1.602176634e-19  /* electron charge, C */
#define SIM_K_B 1.380649e-23     /* Boltzmann constant, J/K */
#define SIM_MAX_AMPS 1.0         /* photocurrents above are refused (and would overflow the guess's float) */

/* One node of a ramp table: a DAC step (held value v, ends at t) or, for the continuous ramp,
 * one sample of V_ref(t). a, ch, ch2 are the nominal device's charge terms at the M2 turn-off
 * node h(v): a = Q(V_N0) - Q(h), ch = C(h), ch2 = C'(h)/2, so a pixel whose M2 threshold is
 * off by d has Q(V_N0) - Q(h + d) = a - d (ch + d ch2) to third order in d (d ~ 10 mV). */
typedef struct sim_node {
    double t, a, ch, ch2;
    float v, inv_t; /* inv_t: 1/t, 0 at t = 0 */
} sim_node;

/* The ramp as the crossing search sees it, plus a guess table indexed by the float bits of the
 * photocurrent (a cheap piecewise-linear log2) holding the nominal crossing node. */
typedef struct sim_ramp_table {
    int n;
    sim_node *node;
    double t_int;          /* end of integration */
    int continuous;        /* nodes are samples of a continuous ramp: interpolate the crossing */
    const wdr_pixel_dev *dev; /* nominal devices, and their reset charge, for coarse DAC jumps */
    double q0_nom;
    uint32_t guess_base;   /* float bits >> SIM_GUESS_SHIFT of the lowest bucket */
    int n_guess;
    uint16_t *guess;       /* first node crossed by a nominal pixel at the bucket's lower edge */
} sim_ramp_table;

#define SIM_GUESS_SHIFT 11 /* 4096 buckets per octave of current: a 12-bit ramp has ~100 steps per octave */
#define SIM_MAX_NODES 65535 /* guess entries are 16-bit */

/* Per-pixel fixed pattern, float arrays of width*height. Charges are in the nominal
 * device's units (true charge / C_PD scale), so the search compares like with like. */
typedef struct sim_fixed {
    float *dq0;      /* Q_nom(V_N0 of this pixel) - Q_nom(V_N0 nominal): M1 threshold */
    float *dvt2;     /* M2 threshold offset, V */
    float *cinv;     /* nominal C_PD / this pixel's: currents divide by the C_PD scale */
    float *idark;    /* dark current, A (lognormal spread) */
    float *sf_k;     /* source-follower constant: phi + gamma sqrt(phi) - vt0_3 - sqrt(2 I_b / beta3) */
    float *ktc_q;    /* reset-noise charge sigma sqrt(kT C(V_N0)), in nominal units */
} sim_fixed;

/* Device values of one pixel for one frame, as the crossing search wants them. */
typedef struct sim_px {
    double e0;       /* charge offset: dq0 + reset noise - shot noise, nominal units */
    double d;        /* M2 threshold offset */
    double ie;       /* (photo + dark current) / C_PD scale */
} sim_px;

/* The fixed pattern one render uses: the chip's arrays (stride 1) or, with mismatch off, the
 * nominal values (stride 0). */
typedef struct sim_fixed_view {
    const float *dq0, *dvt2, *cinv, *idark, *sf_k, *ktc_q;
    long stride;
} sim_fixed_view;

/* Effects `auto` can switch per photocurrent band (their size depends strongly on the
 * current, and skipping them where they are small saves work per pixel). */
#define SIM_BAND_SHIFT 20  /* 8 bands per octave of photocurrent */
#define SIM_MAX_BANDS 512
#define SIM_BAND_DARK 1u
#define SIM_BAND_SHOT 2u
#define SIM_BAND_KTC 4u

/* Effects as they apply to one render (after auto has decided). */
typedef struct sim_plan {
    sim_fixed_view fixed;
    uint32_t band_base;                 /* float bits >> SIM_BAND_SHIFT of band 0 */
    int n_bands;
    int banded;                         /* 0: every band has band_mask[0] (no look-up per pixel) */
    uint8_t band_mask[SIM_MAX_BANDS];   /* SIM_BAND_* bits that run in each band */
    int on[WDR_FX_COUNT];
    double leak_v_per_s; /* hold droop rate, V/s (0 if leakage is off) */
    double adc_scale, adc_zero; /* code = adc_scale * v_sf + adc_zero, before rounding */
    double adc_full;            /* 2^bits - 1 */
} sim_plan;

typedef void (*wdr_sim_progress_fn)(void *ctx, int rows_done, int rows_total);

/* One planted defective pixel (sim_defects.c); the list is sorted by index, row_start[r] is the
 * first entry of row r (height + 1 entries). */
typedef struct sim_defect {
    long i;
    uint8_t kind;   /* enum wdr_defect_kind */
    float v_stuck;  /* stuck: the hold node's voltage */
} sim_defect;

struct wdr_sim {
    wdr_board board;
    uint64_t chip_seed;
    int width, height, threads;
    wdr_pixel_dev nom;
    double v_n0_nom, q0_nom, sf_k_nom, ktc_q_nom, sqrt_phi;
    sim_fixed fx;
    float nominal_fx[6];   /* dq0, dvt2, cinv, idark, sf_k, ktc_q of the nominal pixel */
    wdr_fx_mode mode[WDR_FX_COUNT];
    double tolerance_lsb;
    int reference;
    /* ramp: the stepped LUT and the continuous ramp (from the caller or the LUT mid-points) */
    int have_lut;
    sim_ramp_table stepped, continuous;
    int caller_ramp;
    /* illumination */
    float *amps;           /* NULL: uniform */
    double uniform_amps;
    double scene_i_min, scene_i_max;
    /* last exposure */
    int exposed;
    uint64_t frame_seed;
    sim_plan plan;
    int plan_stale;        /* effects, tolerance, ramp or light changed since the plan was made */
    float *hold_v, *hold_t;
    wdr_fx_report report[WDR_FX_COUNT];
    sim_defect *defects;
    long n_defects, *defect_row_start;
    double hot_amps;
    wdr_sim_progress_fn progress;
    void *progress_ctx;
};

/* sim_ramp.c */
int sim_table_from_lut(const wdr_sim *s, const wdr_lut_view *lut, sim_ramp_table *out);
int sim_table_from_ramp(const wdr_sim *s, const double *t, const double *v, int n, double t_int,
                        sim_ramp_table *out);
void sim_table_free(sim_ramp_table *t);

/* sim_pixel.c */
void sim_pixel_hold(const sim_ramp_table *tab, const sim_px *p, int need_t, double *v_hold, double *t_cross);
double sim_sf_out(const wdr_sim *s, double sf_k, double v_g);
double sim_adc(const wdr_board *b, double v, int quantise, int clip);
void sim_adc_line(const wdr_board *b, double *scale, double *zero);
void sim_expose_row(const wdr_sim *s, const sim_plan *plan, const sim_ramp_table *tab, int row, float *v_hold,
                    float *t_cross);
/* Rows out: exactly one of out_f (float codes) and out_u16 (integer codes) is not NULL. */
void sim_read_row(const wdr_sim *s, const sim_plan *plan, double t_int, int row, const float *v_hold,
                  const float *t_cross, double t_after, float *out_f, uint16_t *out_u16);
void sim_render_row(const wdr_sim *s, const sim_plan *plan, const sim_ramp_table *tab, int row, double t_after,
                    float *out_f, uint16_t *out_u16);

/* sim_defects.c: the planted pixels of one batch [i0, i0 + n) after the healthy physics ran:
 * held voltages and times of dead and hot pixels (expose), codes before rounding of stuck and
 * saturated pixels (read), or both (render). */
void sim_defects_hold(const wdr_sim *s, const sim_plan *plan, const sim_ramp_table *tab, long i0, int n, float *v_hold,
                      float *t_cross);
void sim_defects_codes(const wdr_sim *s, const sim_plan *plan, long i0, int n, double *code);
void sim_defects_free(wdr_sim *s);

/* sim_auto.c; band_of: the band of a photocurrent (same float-bits log2 as the guess table) */
static inline int sim_band_of(const sim_plan *plan, double amps)
{
    float f = (float)amps;
    int32_t u;
    memcpy(&u, &f, sizeof u);
    int32_t b = (u >> SIM_BAND_SHIFT) - (int32_t)plan->band_base;
    b = b < 0 ? 0 : b;
    return b >= plan->n_bands ? plan->n_bands - 1 : b;
}
void sim_plan_effects(wdr_sim *s, sim_plan *plan);

/* sim_chip.c: reset charge change (nominal units) for an M1 threshold offset */
double sim_reset_dq0(const wdr_sim *s, double dvt1);

/* The bits of a float and back: the current-to-step guess table is indexed by them. */
static inline uint32_t sim_float_bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static inline float sim_bits_float(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

#endif
