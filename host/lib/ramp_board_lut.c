/* A LUT built on the spot from an operator, for studies, tests and benchmarks that have no
 * LUT file: the same ramp generator and quantiser as `wdrctl lut build`. */
#include "ramp.h"
#include "wdr_err.h"
#include <stdlib.h>

#define RAMP_SAMPLES 8192

int wdr_ramp_board_lut(const wdr_board *b, const char *op_name, uint8_t **bytes, size_t *len, wdr_ramp *ramp,
                      char *err, int errlen)
{
    wdr_lum_stats st;
    wdr_operator op;
    wdr_ideal_pixel px;
    wdr_ramp local;
    wdr_ramp *r = ramp ? ramp : &local;
    wdr_lum_stats_default(b->i_min_a, b->i_center_a, b->i_max_a, b->lum_per_amp, 0.18, &st);
    int rc = wdr_operator_init(&op, op_name, &st, err, errlen);
    if (rc)
        return rc;
    wdr_ideal_pixel_init(b, &px);
    rc = wdr_ramp_build(&px, &op, b->i_min_a, b->i_max_a, RAMP_SAMPLES, WDR_RAMP_REPAIR, r, err, errlen);
    if (rc)
        return rc;
    rc = wdr_ramp_quantise(r, b, &op, b->dac_timing, b->dac_uniform_entries, bytes, len, err, errlen);
    if (rc || !ramp)
        wdr_ramp_free(r);
    return rc;
}
