/* `wdrctl study`: what accuracy costs. A study is a list of design points (converters, ramp,
 * operator, calibration model, levels, frames, table form, sensor size); each point is built on
 * the simulator with a fixed seed, calibrated, judged, and costed. The fronts and the cheapest
 * point that meets a target follow from the table of points. */
#ifndef WDR_STUDY_H
#define WDR_STUDY_H
#include <stdint.h>

#define STUDY_MAX_POINTS 4096
#define STUDY_OP_PARAMS 128
#define STUDY_MAX_TARGETS 4

enum study_levels_choice {
    STUDY_LEVELS_LOG = 0,   /* log-spaced over the requested range: cheap, deterministic */
    STUDY_LEVELS_SELECT = 1 /* chosen from a probe of the grid (wdr_cal_select_currents) */
};

/* One design. Voltages NAN: the board's own. */
typedef struct study_point {
    int adc_bits, dac_bits;
    int fit_ranges; /* 1: each converter's range fitted to the signal it sees */
    double adc_lo_v, adc_hi_v, dac_lo_v, dac_hi_v;
    int timing;               /* enum wdr_lut_timing */
    uint32_t uniform_entries; /* UNIFORM: clock ticks over the ramp */
    double dac_timer_hz;      /* STAMPED: resolution of the step times */
    char op[32];
    char op_params[STUDY_OP_PARAMS]; /* "key=value;key=value" (empty: defaults) */
    int model, form, n_coeffs;       /* enum wdr_cal_model_id, enum wdr_cal_form; n_coeffs 0: default */
    int coeff_bits;                  /* 32: float32 as stored; 16: rounded to IEEE half (modelled bytes) */
    int n_levels, levels_choice;     /* N-current models; the paper models take 3 / 4 plus dark */
    int frames_cal, frames_img;      /* frames averaged per calibration level, and in the image */
    int width, height;               /* simulated array (a sample of the board's) */
} study_point;

/* What one point costs and reaches. Costs are per the board's full geometry unless named. */
typedef struct study_result {
    int ok;
    char why[200]; /* when !ok: what failed */
    /* accuracy, % of contrast (100 sd across pixels of ln(x_hat / x), cal_metrics.h) over the range */
    double worst_total_pct, median_total_pct; /* one image of frames_img frames, noise on */
    double worst_fpn_pct, median_fpn_pct;     /* the same image without temporal noise */
    double worst_temporal_pct;                /* 100 sd of ln(x_total / x_fpn): the temporal part */
    double floor_pct, floor_median_pct;       /* quantisation floor from the response slope */
    double floor_adc_pct;                     /* the ADC's share of the floor (worst point) */
    double display_levels;                    /* worst rms display error, 8-bit levels (gamma 2.2) */
    double display_off1_frac;                 /* share of pixel readings off by more than 1 level */
    double flagged_frac;                      /* share of pixels the calibration flagged */
    double beyond_frac;                       /* worst share of readings past the curve's ends */
    /* costs: modelled from the board description */
    double t_reset_s, t_ramp_s, t_readout_s, frame_s;
    double image_s;                /* frames averaged in the image x frame time */
    double cal_s;                  /* (levels + dark) x frames x frame time */
    double table_bpp, table_bytes; /* per pixel; total at the board's size */
    double bandwidth_Bps;          /* table bytes read per second at the study's fps */
    double bus_Bps;                /* the board's table bus (controller.table_bus_MBps), 0: not given */
    int bus_feeds;                 /* bandwidth within the bus (or no bus given): else --target skips it */
    /* costs: measured here */
    double fit_s_per_mp;  /* fit + table build per megapixel (+ the basis's fixed learning) */
    double correct_ns_px; /* float32 correction kernel, per pixel */
    double m7_instr_px;   /* Cortex-M7 instructions per pixel, correction alone (study_m7.c, measured) */
    double m7_row_px;     /* the same for the whole row path (correction, framing, CRC) */
    /* what the point used */
    double adc_lo_v, adc_hi_v, dac_lo_v, dac_hi_v;
    int levels_used;
    double eval_s; /* wall time of this point */
} study_result;

/* The study as asked: the points, and what is shared by all of them. */
typedef struct study {
    const char *board;
    double range_lo, range_hi; /* requested photocurrent range (A) */
    double fps;                /* frame rate for the table bandwidth */
    uint64_t seed;
    int jobs;
    int n;
    study_point *pts;  /* malloc'd, n */
    study_result *res; /* malloc'd, n */
    int *index;        /* a shard: each point's index in the full study (malloc'd, n); else NULL */
    int full_n;        /* a shard: the full study's point count */
} study;

/* ---- study_space.c: knobs as lists and ranges ---- */

/* The knobs as text, one list per knob, as on the command line (NULL: the default). */
typedef struct study_knobs {
    const char *adc_bits, *adc_range, *dac_bits, *dac_range, *ranges, *timing, *entries, *timer_hz;
    const char *op, *params, *model, *form, *coeffs, *coeff_bits, *levels, *levels_choice, *frames, *image_frames,
        *size;
} study_knobs;

/* Fill a study file's keys (JSON object, keys as the long options) into k; strings are owned by
 * *keep (cJSON, free with study_knobs_free_file). @return a sysexits code; the failure printed */
int study_knobs_from_file(const char *path, study_knobs *k, void **keep);
void study_knobs_free_file(void *keep);
/* Expand the knobs into every valid combination (invalid model/form pairs left out and counted).
 * @return a sysexits code; a bad list is printed naming the knob and the value */
int study_expand(const study_knobs *k, study *s, int *skipped);

/* ---- study_eval.c: one point ---- */

/* Build, calibrate, judge and cost point p. Never fails as a call: r->ok and r->why say. */
void study_eval_point(const study *s, const study_point *p, study_result *r);

/* ---- study_cost.c: costs modelled from the board ---- */
struct wdr_board;
/* Frame time: reset + ramp (integration) + readout of every row at the ADC's conversion time. */
void study_frame_time(const struct wdr_board *b, int adc_bits, double t_ramp_s, study_result *r);
/* Calibration time on a board: (levels + dark) x frames x frame time. */
double study_cal_time(const study_result *r, int levels, int frames);

/* ---- study_m7.c: what bench_target measured on the Cortex-M7 ---- */
typedef struct study_m7_count {
    int form, n_coeffs;
    double corr_px, row_px; /* instructions per pixel: correction alone, row path */
} study_m7_count;
const study_m7_count *study_m7_counts(int *n);
/* The counts of a form with n_coeffs coefficients (NAN both when bench_target does not run it). */
void study_m7_for(int form, int n_coeffs, double *corr_px, double *row_px);

/* ---- study_run.c: every point, in parallel ---- */

/* Evaluate every point on s->jobs worker processes, printing progress when show_progress.
 * @return a sysexits code */
int study_run(study *s, int show_progress, double *wall_s);

/* ---- study_shard.c: studies across machines ---- */

/* "K/N" of --shard. @return a sysexits code, the failure printed */
int study_shard_parse(const char *text, int *k, int *n);
/* Keep shard K of N of the expanded study: points K-1, K-1+N, ... (s->index must hold s->n). */
void study_shard_select(study *s, int k, int n);
/* The evaluated shard into path. @return a sysexits code */
int study_shard_write(const study *s, int k, int n, const char *path, double wall_s);
/* All N shards back into s (pts, res malloc'd; board copied into board), in the full study's
 * order; a missing shard is refused by its number, as are a shard given twice, another study's
 * shard and another build's. wall_s: the shards' walls summed. @return a sysexits code */
int study_shard_merge(char **paths, int n_paths, study *s, char *board, int board_len, double *wall_s);

/* ---- study_pareto.c: fronts and the target ---- */

enum study_acc { STUDY_ACC_TOTAL, STUDY_ACC_FPN, STUDY_ACC_FLOOR, STUDY_ACC_DISPLAY, STUDY_ACC_COUNT };
enum study_cost {
    STUDY_COST_FRAME,
    STUDY_COST_CAL,
    STUDY_COST_TABLE,
    STUDY_COST_BANDWIDTH,
    STUDY_COST_CORRECT,
    STUDY_COST_FIT,
    STUDY_COST_M7, /* correction instructions per pixel on the Cortex-M7 (NAN where not measured) */
    STUDY_COST_COUNT
};
const char *study_acc_name(int a);
const char *study_acc_unit(int a);
const char *study_cost_name(int c);
const char *study_cost_unit(int c);
int study_cost_measured(int c); /* 1: measured here, 0: modelled from the board */
double study_acc_value(const study_result *r, int a);
double study_cost_value(const study_result *r, int c);
/* Indices of the Pareto front of accuracy a against cost c, cheapest first. @return count */
int study_front(const study *s, int a, int c, int *idx);
/* Index of the cheapest ok point with accuracy figure a <= target_pct by cost c, among those the
 * board's bus can feed and whose cost c is known; -1 if none. */
int study_cheapest(const study *s, int a, int c, double target_pct);

/* ---- study_report.c: table, fronts, JSON, plots ---- */

void study_print_table(const study *s);
void study_print_fronts(const study *s);
/* The cheapest points meeting target_pct, by the total error and by FPN alone (what calibration
 * reaches once the image's temporal noise is averaged away), or why none does (the limiting knob). */
void study_print_target(const study *s, double target, int acc);
/* A target: a value and its accuracy figure (STUDY_ACC_TOTAL for "1%", STUDY_ACC_DISPLAY for
 * "0.5lev", the worst display error in 8-bit levels). */
/* What each knob buys: the best total and FPN-alone error at each value of every swept knob. */
void study_print_knobs(const study *s);
/* study.json in outdir (and on stdout with to_stdout), with the answer for each of n targets.
 * @return a sysexits code */
int study_write_json(const study *s, const char *outdir, const double *targets, const int *accs, int n, double wall_s,
                     int to_stdout);
/* study_vs_image_time.png, study_vs_cal_time.png, study_vs_table_bytes.png,
 * study_vs_m7_instructions.png, study_vs_table_bandwidth.png, each with a line per contrast target.
 * @return a sysexits code */
int study_plot(const study *s, const char *outdir, const double *targets, const int *accs, int n);
/* A point's knobs in one line (for tables and messages). */
void study_point_label(const study_point *p, char *out, int outlen);

/* Print "wdrctl: study: " and a message to stderr; returns code (a sysexits code). */
int study_fail(int code, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

#endif
