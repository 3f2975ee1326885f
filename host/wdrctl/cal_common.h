/* What `wdrctl calibrate` and `wdrctl fpn report` share: their options, the board and the
 * simulated chip they calibrate, the choice of currents, and one calibration run. */
#ifndef WDRCTL_CAL_COMMON_H
#define WDRCTL_CAL_COMMON_H
#include "board.h"
#include "cal_design.h"
#include "cal_engine.h"
#include "cal_select.h"
#include "wdrctl.h"

#define GRID_LO 1e-14
#define GRID_HI 1e-8
#define GRID_PER_DECADE 6
#define N_EVAL 31
#define MIN_SLOPE_CODES 2.0

typedef struct cal_opts {
    const char *board, *op_name, *models, *currents, *levels_file, *out, *outdir, *device, *lut;
    int select_n, frames, adc, dac, upload, json, sample, out_scale;
    int noise; /* simulated chip: temporal noise (shot, kTC, read) on; not an option yet (fpn report sets it) */
    int frames_auto; /* --frames auto (the default): chosen from the probe's measured noise */
    int form; /* enum wdr_cal_form; -1: the model's default */
    unsigned long seed;
} cal_opts;

typedef struct sim_chip {
    wdr_sim *sim;
    uint8_t *lut;
    wdr_cal_simsrc ss;
    wdr_cal_design design; /* the chip's designed response (end slopes, quantisation floor) */
} sim_chip;

typedef struct cal_run {
    wdr_cal_config cfg;
    wdr_cal_choice choice;
    wdr_cal_levels levels;
    wdr_cal_result res;
    uint8_t *table;
    size_t table_len;
    double lo, hi;
    int frames;                  /* frames per level used (0: o->frames) */
    wdr_cal_frames_choice why;   /* how --frames auto chose (frames 0: not chosen) */
} cal_run;

/* --frames auto: a contrast error of this much from temporal noise at any level (%: half the eye's 1 %), and the most
 * frames it may ask for per level */
#define AUTO_FRAMES_TARGET_PCT 0.5
#define AUTO_FRAMES_MAX 64 /* where the issue found no false flag even with a fixed tolerance */
/* The probe averages two frames per level: enough to measure the temporal noise. */
#define PROBE_FRAMES 2

/* Parse the options of cmd ("calibrate" or "fpn report"); a board from $WDR_DEVICE when none
 * is named. Prints what is wrong. @return a sysexits code */
int cal_parse_options(int argc, char **argv, const char *cmd, cal_opts *o);
int cal_model_from_name(const char *name, int *model);
const char *cal_model_name(int model);
const char *cal_form_name(int form);

/* @return a sysexits code; the failure is printed */
int cal_load_board(const char *name, wdr_board *b);
/* The designed response of board b under operator op_name for a LUT of integration time t_int_s
 * (0: the ramp design's), read at the middle row. @return a sysexits code */
int cal_design_for(const wdr_board *b, const char *op_name, double t_int_s, wdr_cal_design *d);
int cal_open_sim(const cal_opts *o, const wdr_board *b, sim_chip *c);
void cal_close_sim(sim_chip *c);
wdr_cal_progress_fn cal_progress_fn(void);

/* Number of currents a model calibrates with by default; the probe grid's currents. */
int cal_default_currents(int model);
void cal_grid_amps(double *amps, int *n);

/* Currents as given (--currents, --levels-file), or chosen from a probe of the source. */
int cal_plan_currents(const cal_opts *o, const wdr_cal_source *src, cal_run *r, int n_cur);
/* Acquire the chosen levels, fit every pixel and build the table. */
int cal_acquire_and_fit(const cal_opts *o, const wdr_cal_source *src, cal_run *r, uint32_t sensor_id, int op_id);
/* Output codes: raw_max * out_scale, at most 16 bits. */
void cal_set_output(const cal_opts *o, wdr_cal_config *cfg, unsigned adc_bits);
/* One DAC step in output codes (follower gain taken as 1, an upper bound): the smallest step
 * between calibration levels the ramp resolves. */
void cal_set_step(const wdr_board *b, wdr_cal_config *cfg);
void cal_free_run(cal_run *r);

#endif
