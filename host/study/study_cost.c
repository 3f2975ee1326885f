/* Costs modelled from the board description (sim/board.h), with the formulas in one place.
 *
 * frame time   = t_reset + t_ramp + t_readout
 *   t_reset    = STUDY_RESET_S: the board file has no reset time; M1 charges C_PD in well under
 *                a microsecond, so 1 us is a safe figure for a global reset
 *   t_ramp     = the LUT's integration time (its last step, the calibration margin included)
 *   t_readout  = rows x row_time_s x 2^(adc_bits - board adc_bits): the board's row time is for
 *                its own ADC; a column-parallel single-slope ADC counts 2^bits clock cycles,
 *                so its conversion time doubles with every bit
 * calibration  = (light levels + 1 dark) x frames per level x frame time (a grid probe, with
 *                --levels-choice select, is the levels captured)
 * table bytes  = header + shared block + pixels x (coefficients x bytes + 1 flag byte) at the
 *                board's geometry (the firmware format, firmware/SPEC.md)
 * bandwidth    = table bytes x frame rate: the kernel reads every pixel's coefficients per frame */
#include "board.h"
#include "study.h"
#include <math.h>

#define STUDY_RESET_S 1e-6

void study_frame_time(const wdr_board *b, int adc_bits, double t_ramp_s, study_result *r)
{
    r->t_reset_s = STUDY_RESET_S;
    r->t_ramp_s = t_ramp_s;
    r->t_readout_s = b->height * b->row_time_s * ldexp(1.0, adc_bits - b->adc_bits);
    r->frame_s = r->t_reset_s + r->t_ramp_s + r->t_readout_s;
}

double study_cal_time(const study_result *r, int levels, int frames)
{
    return (levels + 1.0) * frames * r->frame_s;
}
