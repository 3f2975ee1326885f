/* What `wdrctl calibrate` and `wdrctl fpn report` share: their options, the board and the
 * simulated chip they calibrate, the choice of currents, and one calibration run. */
#ifndef WDRCTL_CAL_COMMON_H
#define WDRCTL_CAL_COMMON_H
#include "board.h"
#include "cal_design.h"
#include "cal_engine.h"
#include "cal_form_measure.h"
#include "cal_margin.h"
#include "cal_select.h"
#include "wdrctl.h"
#include <stddef.h>
#include <stdint.h>

/* The photocurrents calibrate probes on every board, and the range given levels must lie in: a
 * level of 1e-20 A or 1 A read as a flat response, fitted to NaN/Inf and exited 0. */
#define GRID_LO 1e-14
#define GRID_HI 1e-8
#define GRID_PER_DECADE 6
#define GRID_LEVELS 37 /* 6 decades x GRID_PER_DECADE + 1: the most levels --select can choose */
#define N_EVAL 31
#define MIN_SLOPE_CODES 2.0

/* The fewest levels --select can choose that a model's fit and the selection's checks accept
 * (simple3 3, complex4 4, spline 4, lsq WDR_LSQ_PARAMS + 2, polymap n_coeffs + 2); 3 is the
 * least of any, GRID_LEVELS the most. */
int cal_min_select(int model, int n_coeffs);
#define CAL_SELECT_MIN 3

/* "1.23 %" for a finite percentage, else "n/a (why)": no NaN or Inf reaches a printed figure. */
const char *cal_pct_text(double pct, const char *why, char *buf, size_t cap);

/* calibrate --max-flagged N|Nppm: the most pixels the fit may flag (N pixels, or N parts per
 * million of the chip) before calibrate fails with EX_DATAERR and writes and uploads nothing. */
typedef struct cal_flag_limit {
    double value; /* pixels, or ppm of the chip's pixels when ppm is set */
    int ppm;
    const char *text; /* as given (or the default) */
} cal_flag_limit;
#define CAL_MAX_FLAGGED_DEFAULT "100ppm"
/* "N" (a whole number of pixels) or "Nppm" (a number >= 0 of parts per million).
 * @return EX_OK, or EX_USAGE with the message naming the option and the value */
int cal_parse_flag_limit(const char *text, cal_flag_limit *out);
/* The limit in pixels on a chip of n_pixels (ppm * n_pixels / 1e6 for a rate: not rounded). */
double cal_flag_limit_pixels(const cal_flag_limit *l, long n_pixels);

typedef struct cal_opts {
    const char *board, *op_name, *models, *currents, *levels_file, *out, *outdir, *device, *lut;
    int select_n, frames, adc, dac, upload, json, sample, out_scale;
    int noise;       /* simulated chip: temporal noise (shot, kTC, read); calibrate --noise, fpn report per condition */
    int noise_asked; /* --noise was given (a board has its own noise: calibrate --device refuses it) */
    int op_asked;    /* --operator was given (calibrate --device --lut otherwise takes the LUT's own) */
    const char *frames_text;      /* --frames M or auto */
    const char *max_flagged_text; /* calibrate --max-flagged N|Nppm */
    cal_flag_limit max_flagged;   /* parsed (default CAL_MAX_FLAGGED_DEFAULT) */
    int frames_auto;              /* --frames auto (the default): chosen from the probe's measured noise */
    int form;                     /* enum wdr_cal_form; CAL_FORM_AUTO (the default): chosen by the target */
    uint64_t seed;
} cal_opts;

/* calibrate's default for the simulated chip's temporal noise: on, the condition a real chip
 * calibrates in. It costs 25.5 s instead of 10.0 s on sim-vga (--frames auto takes 64 frames
 * per level instead of 2), and the figures then hold for what a user will capture. */
#define CAL_NOISE_DEFAULT 1
#define CAL_NOISE_DEFAULT_NAME "on"

/* Rows both commands' option tables use (cmd_calibrate.c, cmd_fpn_report.c): one row each. */
#define CAL_O(f) offsetof(cal_opts, f)
extern const cli_choice cal_on_off[], cal_forms[];
#define CAL_FORM_AUTO (-1) /* --form auto: the smallest form that meets the target (cal_form_auto.h) */
#define CAL_ROW_BOARD                                                                                                  \
    {                                                                                                                  \
        "board", 0, CLI_STRING, CAL_O(board), "NAME|FILE",                                                          \
            "board: a name (sim-vga) or a board.json file (with --device: the board's own, by the name it gives)",     \
            .values = "@boards"                                                                                        \
    }
#define CAL_ROW_OPERATOR                                                                                               \
    {                                                                                                                  \
        "operator", 0, CLI_STRING, CAL_O(op_name), "NAME", "operator of the LUT (default reinhard; calibrate --device --lut: that LUT's)", \
            .values = "@operators"                                                                                     \
    }
#define CAL_ROW_ADC                                                                                                    \
    {                                                                                                                  \
        "adc", 0, CLI_CHOICE, CAL_O(adc), "on|off", "the simulated column ADC quantises (default on)",                 \
            .choices = cal_on_off                                                                                      \
    }
#define CAL_ROW_DAC                                                                                                    \
    {                                                                                                                  \
        "dac", 0, CLI_CHOICE, CAL_O(dac), "on|off", "the simulated ramp DAC quantises (default on)",                   \
            .choices = cal_on_off                                                                                      \
    }
#define CAL_ROW_NOISE                                                                                                  \
    {                                                                                                                  \
        "noise", 0, CLI_CHOICE, CAL_O(noise), "on|off",                                                                \
            "the simulated chip's temporal noise: shot, kTC, read (default " CAL_NOISE_DEFAULT_NAME ")",               \
            .choices = cal_on_off                                                                                      \
    }
#define CAL_ROW_FRAMES                                                                                                 \
    {                                                                                                                  \
        "frames", 0, CLI_STRING, CAL_O(frames_text), "M|auto",                                                         \
            "frames averaged per level, 1..4096 (default auto: from the measured noise)"                               \
    }
#define CAL_ROW_SAMPLE                                                                                                 \
    {                                                                                                                  \
        "sample", 0, CLI_INT, CAL_O(sample), "N", "pixels sampled to choose currents (default 256)", .min = 16,        \
                                                                                                     .max = 1 << 20    \
    }
#define CAL_ROW_SEED                                                                                                   \
    {                                                                                                                  \
        "seed", 0, CLI_U64, CAL_O(seed), "N", "chip seed of the simulated sensor (default 1)"                          \
    }
#define CAL_ROW_OUT_SCALE                                                                                              \
    {                                                                                                                  \
        "out-scale", 0, CLI_INT, CAL_O(out_scale), "K", "corrected codes span raw_max * K (default 1)", .min = 1,      \
                                                                                                        .max = 16      \
    }
#define CAL_ROW_JSON                                                                                                   \
    {                                                                                                                  \
        "json", 0, CLI_FLAG, CAL_O(json), NULL, "print the summary as JSON"                                            \
    }

typedef struct sim_chip {
    wdr_sim *sim;
    uint8_t *lut;
    wdr_cal_simsrc ss;
    wdr_cal_design design; /* the chip's designed response (end slopes, quantisation floor) */
    wdr_cal_margin margin; /* the calibration margin its ramp carries, sized from its frames */
} sim_chip;

/* --form auto, measured on the chip (cal_form_choice.c): the forms tried and the one chosen. */
typedef struct cal_form_choice {
    wdr_form_trial trial[WDR_FORM_CANDIDATES];
    int tried, chosen;    /* chosen: index into trial, -1 when none met (the nearest kept) */
    int currents, frames; /* judged currents, frames averaged at each */
    int noise_removed;    /* the temporal noise measured (a second set of frames) and taken out */
    wdr_form_target target;
} cal_form_choice;

typedef struct cal_run {
    wdr_cal_config cfg;
    wdr_cal_choice choice;
    wdr_cal_levels levels;
    wdr_cal_result res;
    uint8_t *table;
    size_t table_len;
    double lo, hi;
    int frames;                /* frames per level used (0: o->frames) */
    wdr_cal_frames_choice why; /* how --frames auto chose (frames 0: not chosen) */
    wdr_cal_margin margin;     /* the ramp's calibration margin, as sized (rounds 0: none sized) */
    cal_form_choice form_auto; /* --form auto: the forms tried on the chip's frames (tried 0: not chosen) */
    int table_later;           /* cal_acquire_and_fit builds no table: --form auto builds the one it keeps */
} cal_run;

/* --form auto for a spline fit (r->res, r->table already built): the smallest form meeting the
 * target on this chip's frames becomes r->table, and r->cfg says which: judged on fresh frames
 * from src at currents over [r->lo, r->hi] (temporal: two sets, the noise measured and taken
 * out); when !how->can_light a person sets each of those currents, asked once each.
 * Prints each rejected form. @return a sysexits code */
typedef struct cal_form_frames_how {
    int can_light, temporal;
} cal_form_frames_how;
int cal_choose_form(const wdr_cal_source *src, const cal_form_frames_how *how, uint32_t sensor_id, int op_id,
                    cal_run *r);
/* The choice for calibrate --json (a cJSON object). */
struct cJSON *cal_form_choice_json(const cal_form_choice *c);

/* --frames auto: a contrast error of this much from temporal noise at any level (%: half the eye's 1 %), and the most
 * frames it may ask for per level */
#define AUTO_FRAMES_TARGET_PCT 0.5
/* At most 64: on the demo's sim-vga board a frame costs ~49 ms (19 levels: 64 more frames per level add
 * ~60 s to the 149 s of .ci/demo), and the 119 frames the floor asks for would bring the dark end's
 * temporal contrast error from 0.72 % to 0.53 % only (1e-13 A, 27.4 codes per unit ln I). */
#define AUTO_FRAMES_MAX 64
/* The probe averages two frames per level: enough to measure the temporal noise. */
#define PROBE_FRAMES 2

/* Parse the options of cmd (wdrctl_cmd_calibrate or wdrctl_cmd_fpn_report) by its table; a board
 * command takes the board from --device or $WDR_DEVICE. Prints what is wrong. @return a sysexits code */
int cal_parse_options(int argc, char **argv, const cli_command *cmd, cal_opts *o);
int cal_model_from_name(const char *name, int *model);
const char *cal_model_name(int model);
const char *cal_form_name(int form);

/* @return a sysexits code; the failure is printed */
int cal_load_board(const char *name, wdr_board *b);
/* The designed response of board b under operator op_name for a LUT of integration time t_int_s
 * (0: the ramp design's), read at the middle row. @return a sysexits code */
int cal_design_for(const wdr_board *b, const char *op_name, double t_int_s, wdr_cal_design *d);
/* The simulated chip, its ramp's calibration margin sized from its own frames (cal_margin.h:
 * the latest-crossing pixel crosses at GRID_LO, the dimmest level calibrate may take). */
int cal_open_sim(const cal_opts *o, const wdr_board *b, sim_chip *c);
/* Size the margin of the LUT the source images with (set puts a LUT with a margin in front of
 * it), print the margin chosen and its cost. @return a sysexits code; the failure is printed */
int cal_size_margin(const wdr_cal_source *src, const wdr_cal_design *d, wdr_cal_margin_set_fn set, void *ctx,
                    wdr_cal_margin *m);
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
