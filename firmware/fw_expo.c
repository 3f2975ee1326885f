/* Auto exposure: for this sensor, exposure is the ramp. For operators that see light through
 * L / L_avg, a scene m times brighter wants V_ref'(t) = V_ref(m t) (tests/sim/test_exposure_scaling
 * checks it on the physics), so the firmware keeps the LUT and only changes its tick.
 *
 * Per pixel (integers, one histogram increment): the frame's corrected codes are counted. At the
 * frame's end each code's value in the LUT's exposure table (ln(I / I_key) at the LUT's own tick)
 * is weighted by its count: the scene's log-average against the key, shifted by the gain already
 * in force, counted as the software tone map counts it (wdr_lum_stats_measure: every pixel's log).
 * Codes at the floor or the ceiling only say "at most" / "at least" that current: they are
 * censored, not counted at the limit. Their mean is estimated from their fraction and the density
 * of the scene just inside the limit, continued past it (uniform in ln I, as over a log gradient):
 * a fraction p beyond the limit against q within a BAND that starts GAP inside it spans BAND p / q,
 * so its mean lies half that beyond. Where the LUT says its dark end is linear in current
 * (WDR_LUT_EXPO_LINEAR_DARK), a short dark tail's span comes from its codes' mean instead
 * (dark_tail_from_codes). The span is capped at WDR_FW_EXPO_TAIL_MAX_Q8, and below the top by the tone map's
 * guard (1e-9 of the maximum). Then the gain moves by half of the error (damped; wdr_fw_expo_step
 * also says how a key far off and a last 1/256 move), the new tick
 * must keep every DAC step at least WDR_FW_DAC_MIN_UPDATE_PS long and the integration at most
 * WDR_FW_MAX_INTEGRATION_NS; a step that would break either is halved until it fits. */
#include "wdr_fw.h"
#include <string.h>

#define LOG2E_Q8 369       /* 1/ln 2 in 1/256 */
#define LOG2E_Q16 94548    /* 1/ln 2 in 1/65536: in 1/256 the tick was 0.13 % of the gain off per ln */
#define EXPO_BAND_Q8 256   /* the density beyond a limit is the density over 1 ln inside it, */
#define EXPO_GAP_Q8 128    /* from 0.5 ln in: noise and mismatch blur which pixels a limit censors
                            * over about that much, and a band that starts at the limit counted
                            * 5 % too few (the HDR wedge's tail 0.27 ln too long: key -1.9 %) */
#define EXPO_RAMP_Q8 128   /* the band's edges ramp over 0.5 ln (band_weight_q8) */
#define EXPO_FAST_Q8 128   /* a key more than 0.5 ln off moves to 0.25 ln off at once */
#define EXPO_GUARD_Q8 5305 /* ln(1e9) * 256: the tone map counts nothing below 1e-9 of the maximum */
#ifndef WDR_FW_EXPO_TAIL_MAX_Q8
#define WDR_FW_EXPO_TAIL_MAX_Q8 2048 /* a censored tail spans at most 8 ln (3.5 decades) */
#endif

/* 2^(f/16) for f = 0..16, Q15: the fraction of exp2 between table points is interpolated. */
static const uint16_t exp2_q15[17] = {32768, 34219, 35734, 37316, 38968, 40693, 42495, 44376, 46341,
                                      48393, 50535, 52773, 55109, 57549, 60097, 62757, 65535};

/* own * exp(-gain / 256), in 1/65536 ps; gain in ln units of 1/256. 0 if its whole picoseconds
 * overflow 32 bits or it falls below 1 ps. Defined for every gain: own * frac is below 2^48, so a
 * factor under 2^-48 is 0 (a shift by 64 or more, reached once the gain passed about 8,600, was
 * undefined). The fraction of a picosecond is kept: at the 16-20 ps a bright scene wants one whole
 * picosecond is 5-6 %, and the key settled up to 9 % off (Schlick, Exponential on sim-qvga). */
static uint64_t tick_for_gain(uint32_t own_ps, int32_t gain_q8)
{
    int64_t x = -(((int64_t)gain_q8 * LOG2E_Q16) >> 8); /* log2 of the factor, 1/65536 */
    if (x >= 40 * 65536)
        return 0u; /* overflows 32 bits */
    if (x < -48 * 65536)
        return 0u;                                /* below 1 ps */
    uint32_t biased = (uint32_t)(x + 48 * 65536); /* 0..88*65536-1: no shift of a negative value */
    int32_t n = (int32_t)(biased >> 16) - 48;     /* floor of x / 65536: -48..39 */
    uint32_t f = biased & 0xffffu, i = f >> 12, r = f & 0xfffu; /* in 1/256 of log2 a step was 0.27 % */
    uint32_t frac = exp2_q15[i] + (((uint32_t)(exp2_q15[i + 1] - exp2_q15[i]) * r) >> 12);
    uint64_t t = (uint64_t)own_ps * frac; /* ps in Q15, below 2^48 */
    int32_t up = n + 1;                   /* Q15 to Q16, times 2^n: -47..40 */
    if (up > 0 && t > (UINT64_MAX >> up))
        return 0u;
    t = up >= 0 ? t << up : t >> -up;
    return t >> 48 || t < 65536u ? 0u : t;
}

/* The tick's whole picoseconds and fraction, as a LUT view carries them. */
static uint64_t ticks_ps_at(uint32_t ticks, uint64_t tick_q16)
{
    return wdr_ticks_ps(ticks, (uint32_t)(tick_q16 >> 16), (uint16_t)(tick_q16 & 0xffffu));
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

/* Which limit a tick breaks: the DAC's rate (a step shorter than WDR_FW_DAC_MIN_UPDATE_PS), the
 * longest integration, or none (WDR_EXPO_HELD_*). A tick of 0 (out of tick_for_gain's range) breaks
 * the integration when it was to be longer, else the rate. */
static uint8_t tick_breaks(const wdr_fw *fw, uint64_t tick_q16, bool longer)
{
    if (!tick_q16)
        return longer ? WDR_EXPO_HELD_INTEGRATION : WDR_EXPO_HELD_DAC_RATE;
    if (ticks_ps_at(fw->expo_min_step_ticks, tick_q16) < WDR_FW_DAC_MIN_UPDATE_PS)
        return WDR_EXPO_HELD_DAC_RATE;
    if (ticks_ps_at(fw->lut.h.t_integration_ticks, tick_q16) / 1000u > WDR_FW_MAX_INTEGRATION_NS)
        return WDR_EXPO_HELD_INTEGRATION;
    return 0u;
}

/* ln(I / I_key) * 256 of a code in 1/256 (the table interpolated linearly, flat past its last bin). */
static int32_t table_q8_fine(const wdr_lut_exposure *ex, int32_t code_q8)
{
    uint32_t c = code_q8 > 0 ? (uint32_t)code_q8 : 0u, sh = 8u + ex->code_shift;
    uint32_t bin = c >> sh;
    if (bin >= ex->bins - 1u)
        return ex->ln_q8[ex->bins - 1u];
    int32_t lo = ex->ln_q8[bin], hi = ex->ln_q8[bin + 1u];
    return lo + (int32_t)(((int64_t)(hi - lo) * (int32_t)(c & ((1u << sh) - 1u))) >> sh);
}

/* The histogram's resolution and the censoring limits, from the table: the floor lies in the bin
 * before the first bin at the table's lowest value (the table reads the floor past it), the
 * ceiling in the bin after the last at its highest; codes from one bin and WDR_LUT_EXPO_NOISE_CODES
 * before (after) that on are censored. */
static void expo_limits(wdr_fw *fw)
{
    const wdr_lut_exposure *ex = &fw->expo;
    uint32_t span = (uint32_t)ex->bins << ex->code_shift, hs = 0;
    while ((span >> hs) > WDR_FW_EXPO_HIST)
        hs++;
    fw->expo_hist_shift = (uint8_t)hs;
    uint32_t first_min, last_max;
    wdr_lut_exposure_flat_ends(ex, &first_min, &last_max);
    int32_t lo_code = WDR_LUT_EXPO_FLOOR_CODE(first_min, ex->code_shift);
    int32_t hi_code = (int32_t)((last_max + 1u) << ex->code_shift) + WDR_LUT_EXPO_NOISE_CODES;
    lo_code = lo_code < 0 ? 0 : lo_code;
    hi_code = hi_code > lo_code ? lo_code : hi_code;
    fw->expo_floor_bin = (uint16_t)first_min;
    fw->expo_lo_index = (uint16_t)((uint32_t)lo_code >> hs);
    fw->expo_hi_index = (uint16_t)(((uint32_t)hi_code + (1u << hs) - 1u) >> hs);
    /* a limit's value is the table's half a code before its first censored code, where tally()'s
     * nearest whole code changes sides: one code spans 0.1-0.3 ln at the ends, and the value at the
     * code itself put the HDR wedge's ceiling 0.15 ln low (its censored tail read 7.72 for 7.87) */
    fw->expo_lo_q8 = table_q8_fine(ex, (int32_t)(((uint32_t)fw->expo_lo_index << (8u + hs)) - 128u));
    fw->expo_hi_q8 = table_q8_fine(ex, (int32_t)(((uint32_t)fw->expo_hi_index << (8u + hs)) - 128u));
}

/* A new LUT: its own tick again, its table (or none), the gain back to 0. */
void wdr_fw_expo_reset(wdr_fw *fw)
{
    fw->expo_gain_q8 = 0;
    fw->expo_last_q8 = 0;
    fw->expo_last_nudge = 0;
    fw->expo_tick_q16 = fw->lut_slot >= 0 ? (uint64_t)fw->lut.h.tick_ps << 16 : 0u;
    fw->expo_held = 0;
    fw->expo_min_step_ticks = fw->lut_slot >= 0 ? min_step_ticks(&fw->lut) : 0;
    if (fw->expo_has_table)
        expo_limits(fw);
    else
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
        fw->expo_last_nudge = 0;
        fw->expo_held = 0;
        fw->expo_tick_q16 = (uint64_t)fw->lut.h.tick_ps << 16;
    }
    return WDR_OK;
}

void wdr_fw_expo_frame_start(wdr_fw *fw)
{
    if (fw->expo_auto)
        memset(fw->expo_hist, 0, sizeof fw->expo_hist);
}

/* The per-pixel part: one histogram increment (codes past the histogram count in its last entry,
 * which lies past the floor). */
void wdr_fw_expo_row(wdr_fw *fw, const uint16_t *codes, uint16_t width)
{
    if (!fw->expo_auto)
        return;
    uint32_t *hist = fw->expo_hist;
    const uint32_t shift = fw->expo_hist_shift;
    for (uint16_t x = 0; x < width; x++) {
        uint32_t i = (uint32_t)codes[x] >> shift;
        hist[i < WDR_FW_EXPO_HIST ? i : WDR_FW_EXPO_HIST - 1u]++;
    }
}

/* What a frame's histogram says, by part: the visible codes' sum of ln and count, the censored
 * counts at each limit, and the counts in the density band inside each limit (band_weight_q8). */
typedef struct expo_tally {
    int64_t sum_q8;
    uint32_t seen, below, above;
    uint32_t past;         /* of below: the codes past the floor (the rest: all dark current) */
    int64_t past_code_q8;  /* their codes' sum, 1/256 code */
    uint64_t near_lo_q8, near_hi_q8; /* weighted by band_weight_q8 */
    bool floor_dark;       /* dark current explains the floor's reading at this tick */
    int32_t top_q8;        /* the brightest visible value */
    int32_t lo_q8, hi_q8;  /* the limits' values, dark current out */
} expo_tally;

/* log2(1 + i/16) for i = 0..16, Q12: the fraction of log2 between table points is interpolated. */
static const uint16_t log2_q12[17] = {0,    358,  696,  1016, 1319, 1607, 1882, 2145, 2396,
                                      2637, 2869, 3092, 3307, 3514, 3715, 3908, 4096};

/* e^(z / 256) in Q16 for z <= 0 (1 for z > 0); 0 below 2^-17. */
static uint32_t exp_neg_q16(int32_t z_q8)
{
    if (z_q8 >= 0)
        return 65536u;
    uint32_t w = (uint32_t)(((uint64_t)(uint32_t)(-z_q8) * LOG2E_Q8) >> 8); /* -log2 of the result, 1/256 */
    if (w >= 17u * 256u)
        return 0u;
    uint32_t n = w >> 8, f = 256u - (w & 255u); /* 2^(-w/256) = 2^(f/256) / 2 / 2^n, f in 1..256 */
    uint32_t i = f >> 4, r = f & 15u;
    uint32_t frac = i >= 16u ? exp2_q15[16] : exp2_q15[i] + (((uint32_t)(exp2_q15[i + 1] - exp2_q15[i]) * r) >> 4);
    return frac >> n; /* 2^(f/256) in Q15 is 2^(f/256) / 2 in Q16 */
}

/* ln(v / 65536) * 256 for v > 0. */
static int32_t ln_q8_of_q16(uint32_t v)
{
    int p = 31;
    while (!(v >> p))
        p--;
    uint32_t r = p >= 15 ? v >> (p - 15) : v << (15 - p); /* Q15 in [1, 2) */
    uint32_t t = r - 32768u, i = t >> 11, rem = t & 2047u;
    int32_t l2 = (int32_t)log2_q12[i] + (int32_t)(((uint32_t)(log2_q12[i + 1] - log2_q12[i]) * rem) >> 11);
    int64_t total_q12 = (int64_t)(p - 16) * 4096 + l2;
    return (int32_t)(total_q12 * 45426 / (1 << 20)); /* ln 2 in Q16; Q12 to Q8 */
}

#define DARK_MAX_DROP_Q8 1420 /* ln(1/256) * -256: a reading at least 1/256 of it not dark current */

/* x, ln(J / key) * 256 of a reading, less the dark current the longer hold added: a tick m times
 * its own adds (m - 1) I_dark to J (the calibration took out one I_dark at the own tick). False
 * when dark current explains all but 1/256 of the reading: it then says only "at most". */
static bool dark_corrected(const wdr_fw *fw, int32_t excess_q8, int32_t *x)
{
    if (!(fw->expo.flags & WDR_LUT_EXPO_DARK) || excess_q8 == 0)
        return true;
    int64_t y = (int64_t)exp_neg_q16(fw->expo.dark_ln_q8 - *x) * excess_q8 / 256; /* (m - 1) I_dark / J, Q16 */
    int64_t v = 65536 - y;
    if (v < 256)
        return false;
    *x += ln_q8_of_q16((uint32_t)v);
    return true;
}

/* (tick in force / own tick - 1) * 256: how much longer than calibrated every pixel held its value. */
static int32_t hold_excess_q8(const wdr_fw *fw)
{
    uint64_t own_q16 = (uint64_t)(fw->lut.h.tick_ps ? fw->lut.h.tick_ps : 1u) << 16;
    return (int32_t)((fw->expo_tick_q16 * 256u + own_q16 / 2u) / own_q16) - 256;
}

/* The weight, in 1/256, of a value d (1/256 ln) inside a limit in the density band: 1 over
 * [GAP, GAP + BAND], its two edges ramped over EXPO_RAMP_Q8 (the same width in all). A log wedge
 * reaches the band row by row (on sim-qvga's HDR wedge a row is 0.13 ln and 14 % of the band's
 * count): with hard edges the estimate jumped as the exposure moved a row in or out, and the key
 * settled on whichever side (EXPO_GAP_Q8 48 / 64 / 96: -4.07 / -0.78 / -3.17 %). */
static uint32_t band_weight_q8(int32_t d)
{
    const int32_t ramp = EXPO_RAMP_Q8, a = EXPO_GAP_Q8 - ramp / 2, b = EXPO_GAP_Q8 + EXPO_BAND_Q8 - ramp / 2;
    if (d <= a || d >= b + ramp)
        return 0u;
    if (d < a + ramp)
        return (uint32_t)((d - a) * 256 / ramp);
    return d > b ? (uint32_t)((b + ramp - d) * 256 / ramp) : 256u;
}

static void tally(const wdr_fw *fw, expo_tally *t)
{
    const wdr_lut_exposure *ex = &fw->expo;
    const uint32_t hs = fw->expo_hist_shift, half_q8 = hs ? 128u << hs : 0u;
    const int32_t excess_q8 = hold_excess_q8(fw);
    const int32_t lo_q8 = (int32_t)fw->expo_lo_index << (8u + hs), hi_q8 = (int32_t)fw->expo_hi_index << (8u + hs);
    *t = (expo_tally){.top_q8 = fw->expo_hi_q8, .lo_q8 = fw->expo_lo_q8, .hi_q8 = fw->expo_hi_q8};
    t->floor_dark = !dark_corrected(fw, excess_q8, &t->lo_q8);
    if (t->floor_dark)
        t->lo_q8 = fw->expo_lo_q8 - DARK_MAX_DROP_Q8; /* the floor is dark current at this tick */
    if (!dark_corrected(fw, excess_q8, &t->hi_q8))
        t->hi_q8 = fw->expo_hi_q8 - DARK_MAX_DROP_Q8;
    t->top_q8 = t->hi_q8;
    for (uint32_t i = 0; i < WDR_FW_EXPO_HIST; i++) {
        uint32_t n = fw->expo_hist[i];
        if (n == 0)
            continue;
        /* the code the pixel would have read at the calibrated hold: the droop of the extra hold back */
        int32_t code_q8 = (int32_t)((i << (8u + hs)) + half_q8);
        code_q8 += (int32_t)(((int64_t)ex->droop_q8[(i << hs) >> ex->code_shift < ex->bins ? (i << hs) >> ex->code_shift
                                                                                           : ex->bins - 1u] *
                              excess_q8) >>
                             8);
        /* censored by the nearest whole code: a droop shift of a fraction of a code must not move a
         * whole histogram entry across a limit (with one entry per code, every entry sits exactly on one) */
        int32_t nearest_q8 = (int32_t)(((uint32_t)(code_q8 > 0 ? code_q8 : 0) + 128u) & ~255u);
        if (nearest_q8 >= lo_q8) {
            t->below += n;
            t->past += n;
            t->past_code_q8 += (int64_t)n * code_q8;
            continue;
        }
        if (nearest_q8 < hi_q8) {
            t->above += n;
            continue;
        }
        int32_t x = table_q8_fine(ex, code_q8);
        if (!dark_corrected(fw, excess_q8, &x)) {
            t->below += n;
            continue;
        }
        t->top_q8 = t->seen ? t->top_q8 : x; /* codes fall as light rises: the first seen is the top */
        t->sum_q8 += (int64_t)n * x;
        t->seen += n;
        t->near_lo_q8 += (uint64_t)n * band_weight_q8(x - t->lo_q8);
        t->near_hi_q8 += (uint64_t)n * band_weight_q8(t->hi_q8 - x);
    }
}

/* How far past its limit a censored tail of `count` pixels spans, from the weighted count near_q8
 * (1/256 pixel) of its density band (band_weight_q8: EXPO_BAND_Q8 wide), at most `cap`. */
static int32_t tail_span(uint32_t count, uint64_t near_q8, int32_t cap)
{
    if (count == 0)
        return 0;
    int64_t span = near_q8 ? (int64_t)((uint64_t)EXPO_BAND_Q8 * 256u * count / near_q8) : cap;
    return span < cap ? (int32_t)span : cap;
}

/* (1 - e^-s) / s in Q16 for s = k / 4 ln, k = 0..32: the mean current, against the floor's, of a
 * tail uniform in ln I over s below the floor. */
static const uint16_t uniform_tail_mean_q16[33] = {
    65535, 57986, 51573, 46105, 41427, 37408, 33942, 30941, 28333, 26057, 24063, 22308, 20758, 19383, 18159, 17065, 16084,
    15200, 14402, 13678, 13019, 12418, 11867, 11361, 10896, 10466, 10067, 9698,  9354,  9033,  8733,  8453,  8189};

/* The span (1/256 ln) of a uniform tail whose mean current is r_q16 of the floor's, at most cap. */
static int32_t span_of_mean(int64_t r_q16, int32_t cap)
{
    if (r_q16 >= 65535)
        return 0;
    for (uint32_t k = 1; k < 33u; k++) {
        int32_t hi = uniform_tail_mean_q16[k - 1u], lo = uniform_tail_mean_q16[k];
        if (r_q16 >= lo) {
            int32_t s = (int32_t)(k - 1u) * 64 + (int32_t)((hi - r_q16) * 64 / (hi - lo));
            return s < cap ? s : cap;
        }
    }
    return cap;
}

/* The dark tail's mean ln(I / key) * 256 from what its codes say. Past the floor a code spans more
 * than 1/4 ln (ramp_exposure.c cuts the table there) and a code's noise moves it by up to 2 ln, so
 * no code is read at face value; but every operator's response starts linear in the current
 * (y ~ L), so the codes' mean says the tail's mean current whatever the noise, and the tail's span
 * is the one whose currents, uniform in ln I, have that mean. The line is the table's from the
 * floor's bin to the floor's flat run. Schlick's dark scene on sim-qvga has 39-44 % of its
 * pixels past the floor, and the density band just inside it read that tail short (key +9.2 %,
 * SPEC.md's exposure section).
 * False when the table has no sloped bin past the floor's or dark current explains the floor. */
static bool dark_tail_from_codes(const wdr_fw *fw, const expo_tally *t, int32_t cap, int32_t *mean_q8, int32_t *tail_q8)
{
    const wdr_lut_exposure *ex = &fw->expo;
    const uint32_t sh = ex->code_shift;
    const int32_t excess_q8 = hold_excess_q8(fw);
    int64_t floor_code_q8 = ((int64_t)fw->expo_lo_index << (8u + fw->expo_hist_shift)) - 128; /* as expo_limits */
    uint32_t b0 = (uint32_t)(floor_code_q8 > 0 ? floor_code_q8 : 0) >> (8u + sh), b1 = fw->expo_floor_bin;
    if (!(ex->flags & WDR_LUT_EXPO_LINEAR_DARK) || !t->past || t->floor_dark || b1 <= b0 || b1 >= ex->bins)
        return false;
    const int32_t l0 = ex->ln_q8[b0];
    int64_t d_q16 = 0; /* the dark current the longer hold adds, against e^l0 */
    if ((ex->flags & WDR_LUT_EXPO_DARK) && excess_q8) {
        if (ex->dark_ln_q8 >= l0)
            return false;
        d_q16 = (int64_t)exp_neg_q16(ex->dark_ln_q8 - l0) * excess_q8 / 256;
    }
    /* the current at code c against e^l0: 1 - (c - c0) * drop / span, in Q16 */
    const int64_t drop_q16 = 65536 - exp_neg_q16(ex->ln_q8[b1] - l0), codes_q8 = (int64_t)((b1 - b0) << sh) << 8;
    const int64_t c0_q8 = (int64_t)(b0 << sh) << 8, mean_code_q8 = t->past_code_q8 / t->past;
    int64_t floor_q16 = 65536 - (floor_code_q8 - c0_q8) * drop_q16 / codes_q8 - d_q16;
    int64_t mean_q16 = 65536 - (mean_code_q8 - c0_q8) * drop_q16 / codes_q8 - d_q16;
    if (floor_q16 < 256 || floor_q16 > 0x7fffffff)
        return false;
    int64_t r_q16 = mean_q16 > 0 ? mean_q16 * 65536 / floor_q16 : 0;
    *tail_q8 = span_of_mean(r_q16, cap);
    *mean_q8 = l0 + ln_q8_of_q16((uint32_t)floor_q16) - *tail_q8 / 2;
    return true;
}

#ifndef EXPO_CODES_UP_TO_Q8
#define EXPO_CODES_UP_TO_Q8 704
#endif
#ifndef EXPO_CODES_WIDTH_Q8
#define EXPO_CODES_WIDTH_Q8 128
#endif
/* The codes' mean pins a short tail; a long one it barely moves. Its currents then all sit within
 * a code or two of the zero-light code, and the span grows as 1 / the mean current: at 7 ln, 0.15
 * code of curvature in the response moved it 0.5 ln (Schlick's HDR wedge, key -5 %). So the tail
 * is the codes' up to EXPO_CODES_UP_TO_Q8, the density band's past that plus EXPO_CODES_WIDTH_Q8,
 * and a blend of the two between. */
static int32_t blend_tails(int32_t from_codes, int32_t from_band, int32_t span)
{
    int32_t over = span - EXPO_CODES_UP_TO_Q8;
    if (over <= 0)
        return from_codes;
    if (over >= EXPO_CODES_WIDTH_Q8)
        return from_band;
    return from_codes + (int32_t)((int64_t)(from_band - from_codes) * over / EXPO_CODES_WIDTH_Q8);
}

/* ln(L_avg / key) * 256 of the frame at the tick in force. */
static int32_t frame_log_average(const wdr_fw *fw)
{
    expo_tally t;
    tally(fw, &t);
    uint32_t all = t.seen + t.below + t.above;
    if (all == 0)
        return 0;
    int32_t hi_span = tail_span(t.above, t.near_hi_q8, WDR_FW_EXPO_TAIL_MAX_Q8);
    int32_t top = t.above ? t.hi_q8 + hi_span : t.top_q8;
    int32_t guard = t.lo_q8 - (top - EXPO_GUARD_Q8); /* room above the tone map's guard */
    int32_t lo_cap = guard < WDR_FW_EXPO_TAIL_MAX_Q8 ? (guard > 0 ? guard : 0) : WDR_FW_EXPO_TAIL_MAX_Q8;
    int32_t lo_mean = t.lo_q8 - tail_span(t.below, t.near_lo_q8, lo_cap) / 2, from_codes, span;
    if (t.below == t.past && dark_tail_from_codes(fw, &t, lo_cap, &from_codes, &span))
        lo_mean = blend_tails(from_codes, lo_mean, span);
    int64_t sum = t.sum_q8 + (int64_t)t.below * lo_mean + (int64_t)t.above * (t.hi_q8 + hi_span / 2);
    return (int32_t)(sum / (int64_t)all);
}

/* The gain whose tick is the tick in force (the tick's 1/65536 ps and tick_for_gain's table
 * interpolation may part it from the gain's own): tick_for_gain falls as the gain rises, so bisect. */
static int32_t gain_of_tick(uint32_t own_ps, uint64_t tick_q16, int32_t near_q8)
{
    int32_t lo = near_q8 - 1024, hi = near_q8 + 1024;
    while (hi - lo > 1) {
        int32_t mid = lo + (hi - lo) / 2;
        if (tick_for_gain(own_ps, mid) >= tick_q16)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* Half the gap (WDR_FW_EXPO_DAMP_SHIFT), truncated; past EXPO_FAST_Q8 all of the excess at once
 * (the dark scene starts 1.5 ln off: 2 frames fewer to settle). A gap of one halves to no step,
 * and the key stalled 1/256 on the side it came from (the dark scene 5 frames at +2.60 %, its
 * settling point +2.20 %): a step of one is taken after two such frames alike. Taken at every
 * one, the HDR wedge's estimate flipping by 1/256 made a limit cycle (late frames 0.4 % apart). */
int32_t wdr_fw_expo_step(int32_t gap, int8_t *last_nudge)
{
    const int32_t fast = EXPO_FAST_Q8, damped = EXPO_FAST_Q8 / (1 << WDR_FW_EXPO_DAMP_SHIFT);
    int8_t nudge = gap == 1 ? 1 : gap == -1 ? -1 : 0, prev = *last_nudge;
    *last_nudge = nudge && nudge != prev ? nudge : 0;
    if (gap > fast)
        return gap - fast + damped;
    if (gap < -fast)
        return gap + fast - damped;
    return nudge && nudge == prev ? nudge : gap / (1 << WDR_FW_EXPO_DAMP_SHIFT);
}

/* After a whole frame: the scene's key is the gain of the tick played plus the error measured
 * under it; the gain moves by wdr_fw_expo_step toward it, within the limits. */
void wdr_fw_expo_frame_end(wdr_fw *fw, bool complete)
{
    if (!fw->expo_auto || !complete)
        return;
    int32_t error = frame_log_average(fw); /* ln(L_avg / key) at the tick in force */
    fw->expo_last_q8 = error;
    int32_t played = gain_of_tick(fw->lut.h.tick_ps, fw->expo_tick_q16, fw->expo_gain_q8);
    int32_t step = wdr_fw_expo_step(played + error - fw->expo_gain_q8, &fw->expo_last_nudge);
    /* Near the DAC's rate or the longest integration, halve the step until it fits: the tick
     * then stops within 1/256 of the limit, and STATUS says which limit holds the key short of
     * the scene (a LUT with short steps cannot play fast enough for a bright scene). */
    const bool longer = step < 0; /* a darker scene: a longer tick */
    fw->expo_held = step ? tick_breaks(fw, tick_for_gain(fw->lut.h.tick_ps, fw->expo_gain_q8 + step), longer) : 0u;
    for (; step; step /= 2) { /* at most 32 halvings; the gap to a limit halves every frame */
        uint64_t tick = tick_for_gain(fw->lut.h.tick_ps, fw->expo_gain_q8 + step);
        if (!tick_breaks(fw, tick, longer)) {
            fw->expo_gain_q8 += step;
            fw->expo_tick_q16 = tick;
            return;
        }
    }
}
