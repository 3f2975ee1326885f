/* Internal to the study library: the simulated chip of one design point. */
#ifndef WDR_STUDY_INTERNAL_H
#define WDR_STUDY_INTERNAL_H
#include "board.h"
#include "operators.h"
#include "study.h"
#include "wdr_sim.h"
#include <stddef.h>

/* Margin added on each side of a fitted converter range, as a share of the signal's span. */
#define STUDY_FIT_MARGIN 0.04

typedef struct study_chip {
    wdr_board b;    /* the point's board: simulated size, converters as the point asks */
    wdr_board full; /* the board as described: costs are for its geometry */
    wdr_operator op;
    wdr_sim *sim; /* every effect on, temporal noise included */
    uint8_t *lut;
    size_t lut_len;
    double t_ramp_s; /* integration time of the LUT, calibration margin included */
    double ramp_span_v;
    double sf_gain; /* dV_out / dV_G of the nominal source follower mid-ramp */
} study_chip;

/* Build the chip of point p. @retval WDR_OK or a negative enum wdr_err (err says why) */
int study_chip_open(const study *s, const study_point *p, study_chip *c, char *err, int errlen);
void study_chip_close(study_chip *c);

#endif
