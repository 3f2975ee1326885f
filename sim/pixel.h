/* Device equations of the pixel of the paper's Fig. 1: the physics that both the ramp
 * generator (nominal devices) and the simulator (per-pixel devices) evaluate.
 * This is not a calibration model: it is threshold, body effect and junction charge. */
#ifndef WDR_PIXEL_H
#define WDR_PIXEL_H
#include "board.h"

typedef struct wdr_pixel_dev {
    double vdd, reset_gate;
    double vt0_m1, vt0_m2, vt0_m3; /* zero-bias thresholds */
    double gamma, phi2f;           /* body effect */
    double c_pd, c_pd_ref_v, pb, mj; /* junction capacitance C(V) */
    double beta3, sf_bias;         /* source follower */
} wdr_pixel_dev;

/* Nominal (mismatch-free) devices of a board. */
void wdr_pixel_nominal(const wdr_board *b, wdr_pixel_dev *d);

/* Threshold with body effect for a source-to-bulk voltage vsb (bulk at ground). */
double wdr_vt(double vt0, double gamma, double phi2f, double vsb);

/* Reset level V_N0: M1 (gate reset_gate, drain vdd) charges N1 until it turns off. */
double wdr_pixel_reset_level(const wdr_pixel_dev *d);

/* Charge on the photodiode, Q(v) = integral of C(u) du from 0 to v (coulomb). */
double wdr_pixel_charge(const wdr_pixel_dev *d, double v);

/* Node voltage holding charge q: the inverse of wdr_pixel_charge. */
double wdr_pixel_voltage(const wdr_pixel_dev *d, double q);

/* Node voltage at which M2 turns off while its source (node G) sits at v_g. */
double wdr_pixel_turnoff_node(const wdr_pixel_dev *d, double v_g);

/* G level that a pixel with no light holds at t = 0: solves v + V_T2(v) = v_n0. */
double wdr_pixel_dark_level(const wdr_pixel_dev *d, double v_n0);

/* Source-follower output for gate voltage v_g (M3 with body effect, biased at sf_bias). */
double wdr_pixel_sf_out(const wdr_pixel_dev *d, double v_g);

#endif
