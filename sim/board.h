/* A board and its sensor, read from boards/<name>/board.json. Every number is a documented
 * default that a board file may override (see boards/README.md for units and meaning). */
#ifndef WDR_BOARD_H
#define WDR_BOARD_H
#include <stdint.h>

typedef struct wdr_mos {
    double w_um, l_um;
} wdr_mos;

typedef struct wdr_board {
    char name[64];
    char backend[16];     /* "sim" or "linux" */
    uint32_t sensor_id;
    uint16_t width, height;

    /* supply and devices (0.35 um NMOS) */
    double vdd_v;         /* pixel supply, M1 drain */
    double reset_gate_v;  /* M1 gate during reset */
    double vt0_v;         /* zero-bias threshold of M1..M3 */
    double gamma_sqrt_v;  /* body-effect coefficient */
    double phi2f_v;       /* surface potential 2*phi_F */
    double kp_a_per_v2;   /* process transconductance mu*Cox */
    double sf_bias_a;     /* column source-follower bias current */
    wdr_mos m1, m2, m3;

    /* photodiode: C(V) = c_pd_f * ((1 + c_pd_ref_v/pb_v) / (1 + V/pb_v))^mj */
    double c_pd_f, c_pd_ref_v, pb_v, mj;
    double dark_current_a;

    /* hold node (gate of M3) */
    double c_hold_f, hold_leak_a;

    /* mismatch (Pelgrom) */
    double avt_mv_um, abeta_pct_um, c_pd_sigma_pct, dark_sigma_ln;

    /* temporal noise */
    double temperature_k, read_noise_v;

    /* photocurrent range and current-to-luminance scale */
    double i_min_a, i_max_a, i_center_a, lum_per_amp;

    /* wanted output: g(I) = v_dark - swing * T(k I), v_dark = V_N0' - dark_offset */
    double swing_v, dark_offset_v;

    /* DAC driving V_ref */
    int dac_bits;
    double dac_lo_v, dac_hi_v;
    int dac_timing;       /* enum wdr_lut_timing */
    double dac_timer_hz;  /* resolution of the step time stamps */
    uint32_t dac_uniform_entries;

    /* column ADC reading the source follower */
    int adc_bits;
    double adc_lo_v, adc_hi_v, adc_offset_v, adc_gain;

    /* readout */
    double row_time_s;

    /* the controller's memory bus the calibration table is read over, MB/s (10^6 B/s) of
     * sustained reads; 0: not given (wdrctl study then checks no bandwidth) */
    double table_bus_mbps;
} wdr_board;

/* Fill b with the documented defaults (0.35 um process, 640x480, 12-bit DAC and ADC). */
void wdr_board_defaults(wdr_board *b);

/* Read a board file over the defaults. On error, writes a message naming the file, the
 * field and the value into err (errlen bytes).
 * @retval WDR_OK
 * @retval WDR_E_IO     file missing or unreadable
 * @retval WDR_E_INVAL  not JSON, unknown field, wrong type or value out of range */
int wdr_board_load(const char *path, wdr_board *b, char *err, int errlen);

/* Check ranges of every field; same message and codes as wdr_board_load. */
int wdr_board_validate(const wdr_board *b, const char *path, char *err, int errlen);

/* Path of a board by name: NAME/board.json in $WDR_BOARDS_DIR or the installed boards folder
 * (sim/data_path.h); a path is kept as given. */
void wdr_board_path(const char *name, char *out, int outlen);

/* A board by name or path, read as wdr_board_load does. An unknown name gets a message that
 * lists the known ones. @retval as wdr_board_load */
int wdr_board_load_named(const char *name, wdr_board *b, char *err, int errlen);

#endif
