/* Auto exposure: for this sensor, exposure is the ramp. For operators that see light through
 * L / L_avg, a scene m times brighter wants V_ref'(t) = V_ref(m t) (tests/sim/test_exposure_scaling
 * checks it on the physics), so the firmware keeps the LUT and only changes its tick.
 *
 * Per pixel (integer only): each corrected code's bin in the LUT's exposure table gives
 * ln(I / I_key) at the LUT's own tick; a row's mean, then the frame's mean of row means, is the
 * scene's log-average against the key, shifted by the gain already in force. At the frame's end
 * the gain moves by half of that (damped), the new tick must keep every DAC step at least
 * WDR_FW_DAC_MIN_UPDATE_PS long and the integration at most WDR_FW_MAX_INTEGRATION_NS; a step that
 * would break either is halved until it fits. */
#include "wdr_fw.h"

#define LOG2E_Q8 369 /* 1/ln 2 in 1/256 */

/* 2^(f/16) for f = 0..16, Q15: the fraction of exp2 between table points is interpolated. */
static const uint16_t exp2_q15[17] = {32768, 34219, 35734, 37316, 38968, 40693, 42495, 44376, 46341,
                                      48393, 50535, 52773, 55109, 57549, 60097, 62757, 65535};

/* own * exp(-gain / 256), in ps; gain in ln units of 1/256. 0 if it overflows 32 bits or falls
 * below 1 ps. Defined for every gain: own * frac is below 2^48, so a factor under 2^-48 is 0
 * (a shift by 64 or more, reached once the gain passed about 8,600, was undefined). */
static uint32_t tick_for_gain(uint32_t own_ps, int32_t gain_q8)
{
    int64_t x64 = -(((int64_t)gain_q8 * LOG2E_Q8) >> 8); /* log2 of the factor, 1/256 */
    if (x64 >= 40 * 256)
        return 0u; /* overflows 32 bits */
    if (x64 < -48 * 256)
        return 0u; /* below 1 ps */
    uint32_t biased = (uint32_t)(x64 + 48 * 256); /* 0..88*256-1: no shift of a negative value */
    int32_t n = (int32_t)(biased >> 8) - 48;      /* floor of x64 / 256: -48..39 */
    uint32_t f = biased & 255u, i = f >> 4, r = f & 15u;
    uint32_t frac = exp2_q15[i] + (((uint32_t)(exp2_q15[i + 1] - exp2_q15[i]) * r) >> 4);
    uint64_t t = (uint64_t)own_ps * frac; /* Q15 */
    t = n >= 15 ? t << (n - 15) : t >> (15 - n); /* shifts 0..24 and 1..63 */
    return t > UINT32_MAX ? 0u : (uint32_t)t;
}

static uint32_t min_step_ticks(const wdr_lut_view *lut)
{
    uint32_t best = UINT32_MAX, prev = 0, t;
    uint16_t code;
    for (uint32_t i = 1; i < lut->h.entry_count; i++, prev = t) {
        wdr_lut_entry(lut, i, &t, &code);
        if (i == 1)
            wdr_lut_entry(lut, 0, &prev, &code);
        best = t - prev < best ? t - prev : best;
    }
    return best;
}

static bool tick_allowed(const wdr_fw *fw, uint32_t tick_ps)
{
    uint64_t step_ps = (uint64_t)fw->expo_min_step_ticks * tick_ps;
    uint64_t t_int_ns = (uint64_t)fw->lut.h.t_integration_ticks * tick_ps / 1000u;
    return tick_ps && step_ps >= WDR_FW_DAC_MIN_UPDATE_PS && t_int_ns <= WDR_FW_MAX_INTEGRATION_NS;
}

/* A new LUT: its own tick again, its table (or none), the gain back to 0. */
void wdr_fw_expo_reset(wdr_fw *fw)
{
    fw->expo_gain_q8 = 0;
    fw->expo_last_q8 = 0;
    fw->expo_tick_ps = fw->lut_slot >= 0 ? fw->lut.h.tick_ps : 0;
    fw->expo_min_step_ticks = fw->lut_slot >= 0 ? min_step_ticks(&fw->lut) : 0;
    if (!fw->expo_has_table)
        fw->expo_auto = false;
}

int wdr_fw_set_exposure(wdr_fw *fw, uint8_t mode)
{
    if (mode > 1)
        return WDR_E_INVAL;
    if (fw->lut_slot < 0)
        return WDR_E_NO_TABLE;
    if (mode == 1 && !fw->expo_has_table)
        return WDR_E_UNSUPPORTED;
    fw->expo_auto = mode == 1;
    if (!fw->expo_auto) {
        fw->expo_gain_q8 = 0;
        fw->expo_tick_ps = fw->lut.h.tick_ps;
    }
    return WDR_OK;
}

void wdr_fw_expo_frame_start(wdr_fw *fw)
{
    fw->expo_frame_sum = 0;
    fw->expo_rows = 0;
}

/* The per-pixel part: integers only. The table holds ln(I / I_key) at each bin's first code;
 * codes between are interpolated (a uniform scene would otherwise see steps of 1/64 of the range). */
void wdr_fw_expo_row(wdr_fw *fw, const uint16_t *codes, uint16_t width)
{
    if (!fw->expo_auto || width == 0)
        return;
    int32_t sum = 0;
    const int16_t *table = fw->expo.ln_q8;
    uint8_t shift = fw->expo.code_shift;
    uint32_t mask = (1u << shift) - 1u;
    for (uint16_t x = 0; x < width; x++) {
        uint32_t bin = (uint32_t)codes[x] >> shift;
        if (bin >= WDR_LUT_EXPO_BINS - 1u) { /* the last bin, and codes above the table: flat */
            sum += table[WDR_LUT_EXPO_BINS - 1u];
            continue;
        }
        int32_t lo = table[bin], hi = table[bin + 1u];
        sum += lo + (((hi - lo) * (int32_t)(codes[x] & mask)) >> shift);
    }
    fw->expo_frame_sum += sum / (int32_t)width;
    fw->expo_rows++;
}

/* After a whole frame: move the gain by half the measured error, within the limits. */
void wdr_fw_expo_frame_end(wdr_fw *fw, bool complete)
{
    if (!fw->expo_auto || !complete || fw->expo_rows == 0)
        return;
    int32_t error = fw->expo_frame_sum / (int32_t)fw->expo_rows; /* ln(L_avg / key) at the tick in force */
    fw->expo_last_q8 = error;
    int32_t step = error / (1 << WDR_FW_EXPO_DAMP_SHIFT);
    /* Near the DAC's rate or the longest integration, halve the step until it fits: the tick
     * then stops within 1/256 of the limit. */
    for (int tries = 0; tries < 9 && step; tries++, step /= 2) {
        uint32_t tick = tick_for_gain(fw->lut.h.tick_ps, fw->expo_gain_q8 + step);
        if (tick_allowed(fw, tick)) {
            fw->expo_gain_q8 += step;
            fw->expo_tick_ps = tick;
            return;
        }
    }
}
