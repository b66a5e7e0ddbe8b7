/*
 * rng.h - xoshiro256** (Blackman & Vigna 2018), the engine's random source.
 * Fast, 256-bit state, passes BigCrush; rng_jump() advances 2^128 steps so
 * each thread can own a non-overlapping stream cut from one seed.
 * Header-only because rng_next sits on the walker's hot path.
 */
#ifndef PDLA_SRC_RNG_H
#define PDLA_SRC_RNG_H
#include <stdint.h>

typedef struct pdla_rng {
    uint64_t s[4];
} pdla_rng;

static inline uint64_t rng_rotl_(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

static inline uint64_t rng_next(pdla_rng *r)
{
    uint64_t *s = r->s;
    const uint64_t result = rng_rotl_(s[1] * 5, 7) * 9;
    const uint64_t t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rng_rotl_(s[3], 45);
    return result;
}

/* Uniform in [0, 1) with 53 random bits. */
static inline double rng_uniform(pdla_rng *r) { return (double)(rng_next(r) >> 11) * 0x1.0p-53; }

/* Uniform in (0, 1): never 0, never 1 (safe for log, tan(pi(u-1/2)), 1/u). */
static inline double rng_uniform_open(pdla_rng *r)
{
    return ((double)(rng_next(r) >> 12) + 0.5) * 0x1.0p-52;
}

/* Seed the state from one 64-bit value with splitmix64, as the authors advise. */
static inline void rng_seed(pdla_rng *r, uint64_t seed)
{
    uint64_t z = seed;
    for (int i = 0; i < 4; i++) {
        z += UINT64_C(0x9e3779b97f4a7c15);
        uint64_t x = z;
        x = (x ^ (x >> 30)) * UINT64_C(0xbf58476d1ce4e5b9);
        x = (x ^ (x >> 27)) * UINT64_C(0x94d049bb133111eb);
        r->s[i] = x ^ (x >> 31);
    }
}

/* Advance by 2^128 calls: the start of the next independent stream. */
static inline void rng_jump(pdla_rng *r)
{
    static const uint64_t jump[] = {0x180ec6d33cfd0aba, 0xd5a61266f0c9392c,
                                    0xa9582618e03fc9aa, 0x39abdc4529b1661c};
    uint64_t t[4] = {0, 0, 0, 0};
    for (int i = 0; i < 4; i++)
        for (int b = 0; b < 64; b++) {
            if (jump[i] & (UINT64_C(1) << b))
                for (int k = 0; k < 4; k++) t[k] ^= r->s[k];
            rng_next(r);
        }
    for (int k = 0; k < 4; k++) r->s[k] = t[k];
}
#endif
