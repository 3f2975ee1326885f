/* Counter-based random numbers: every draw is a pure function of (seed, stream, pixel index),
 * so a frame is the same bits whatever the thread count or the order rows are read in. */
#ifndef WDR_SIM_RNG_H
#define WDR_SIM_RNG_H
#include <stdint.h>

/* One stream per random quantity: adding an effect never shifts another effect's draws. */
enum sim_stream {
    SIM_RNG_VT1 = 1, SIM_RNG_VT2, SIM_RNG_VT3, SIM_RNG_BETA3, SIM_RNG_CPD, SIM_RNG_DARK,
    SIM_RNG_KTC = 16, SIM_RNG_SHOT, SIM_RNG_READ,
    SIM_RNG_DEFECT_POS = 32, SIM_RNG_DEFECT_V
};

/* splitmix64's finaliser: a bijective 64-bit mixer with full avalanche. */
static inline uint64_t sim_mix64(uint64_t x)
{
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ull;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

/* A stream's key depends on the seed and the stream only: pixel loops take it once. */
static inline uint64_t sim_rng_key(uint64_t seed, uint32_t stream)
{
    return sim_mix64(seed + 0x9e3779b97f4a7c15ull * ((uint64_t)stream + 1));
}

static inline uint64_t sim_rng_at(uint64_t key, uint64_t index) { return sim_mix64(key ^ (index * 0xd1b54a32d192ed03ull)); }

static inline uint64_t sim_rng_u64(uint64_t seed, uint32_t stream, uint64_t index)
{
    return sim_rng_at(sim_rng_key(seed, stream), index);
}

#define SIM_NORM_TABLE_BITS 12
extern float sim_norm_table[(1 << SIM_NORM_TABLE_BITS) + 1];

/* Exact standard-normal quantile (Acklam's rational approximation, |rel err| < 1.2e-9). */
double sim_norm_quantile(double u);

/* Fill sim_norm_table; idempotent and thread-safe (call before any sim_normal). */
void sim_rng_init(void);

/* Standard normal from 32 random bits: table interpolation in the body, the exact quantile
 * in the outer 1/4096 of each tail (so tails are right, and |z| <= 6.3). */
static inline double sim_normal(uint32_t bits)
{
    const int shift = 32 - SIM_NORM_TABLE_BITS;
    uint32_t cell = bits >> shift;
    if (cell == 0 || cell == (1u << SIM_NORM_TABLE_BITS) - 1)
        return sim_norm_quantile(((double)bits + 0.5) * (1.0 / 4294967296.0));
    float frac = (float)(bits & ((1u << shift) - 1)) * (1.0f / (float)(1u << shift));
    float a = sim_norm_table[cell], b = sim_norm_table[cell + 1];
    return a + (b - a) * frac;
}

/* Largest |z| sim_normal can return: the worst case of a noise draw. */
#define SIM_NORMAL_MAX 6.3

#endif
