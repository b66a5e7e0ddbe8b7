/*
 * test_rng.c - xoshiro256** (src/core/rng.h) against the reference generator:
 * known outputs from a known state, the exact ends of the two uniform
 * mappings, a chi-square of uniformity, and rng_jump checked against an
 * independent computation of 2^128 steps (the state transition is linear over
 * GF(2), so its 2^128-th power is 128 squarings of a 256 x 256 bit matrix).
 */
#include <inttypes.h>
#include <string.h>

#include "rng.h"
#include "stats.h"
#include "check.h"

static void test_reference_outputs(void)
{
    /* Outputs of Blackman & Vigna's xoshiro256starstar.c from s = {1,2,3,4}. */
    pdla_rng r = {{1, 2, 3, 4}};
    const uint64_t expected[] = {UINT64_C(11520), UINT64_C(0), UINT64_C(1509978240),
                                 UINT64_C(1215971899390074240)};
    for (int i = 0; i < 4; i++) {
        const uint64_t got = rng_next(&r);
        CHECK(got == expected[i], "output %d: %" PRIu64 ", reference %" PRIu64, i, got,
              expected[i]);
    }
}

/* Multiplicative inverse of an odd number modulo 2^64 (Newton: each step
 * doubles the correct low bits, starting from 3 bits since x*x = 1 mod 8). */
static uint64_t inverse_mod_2_64(uint64_t x)
{
    uint64_t y = x;
    for (int i = 0; i < 5; i++) y *= 2 - x * y;
    return y;
}

static uint64_t rotr64(uint64_t x, int k) { return (x >> k) | (x << (64 - k)); }

/* A state whose next output is `out`: the output depends on s[1] alone. */
static pdla_rng state_giving(uint64_t out)
{
    const uint64_t s1 = inverse_mod_2_64(5) * rotr64(out * inverse_mod_2_64(9), 7);
    const pdla_rng r = {{0, s1, 0, 0}};
    return r;
}

static void test_uniform_ends(void)
{
    /* The extreme outputs 0 and 2^64 - 1 must map inside the promised ranges. */
    pdla_rng r = state_giving(0);
    CHECK(rng_uniform(&r) == 0.0, "rng_uniform of output 0 is not 0");
    r = state_giving(0);
    const double open_lo = rng_uniform_open(&r);
    CHECK(open_lo > 0.0 && open_lo == 0x1.0p-53, "rng_uniform_open of 0 gives %a", open_lo);

    r = state_giving(UINT64_MAX);
    const double closed_hi = rng_uniform(&r);
    CHECK(closed_hi < 1.0 && closed_hi == 1.0 - 0x1.0p-53, "rng_uniform of max gives %a",
          closed_hi);
    r = state_giving(UINT64_MAX);
    const double open_hi = rng_uniform_open(&r);
    CHECK(open_hi < 1.0 && open_hi == 1.0 - 0x1.0p-53, "rng_uniform_open of max gives %a",
          open_hi);

    /* The constructed states really do give those outputs. */
    r = state_giving(UINT64_C(0x0123456789abcdef));
    CHECK(rng_next(&r) == UINT64_C(0x0123456789abcdef), "state inversion is wrong");
}

static void test_uniform_distribution(void)
{
    /* 1e6 draws of each mapping, 64 equal bins: chi-square against 103.442
     * (63 dof, p = 0.001); mean within 5 standard errors of 1/2. */
    enum { bins = 64, draws = 1000000 };
    pdla_rng r;
    rng_seed(&r, 20240601);
    for (int open = 0; open <= 1; open++) {
        uint64_t counts[bins] = {0};
        double sum = 0.0;
        int out_of_range = 0;
        for (int i = 0; i < draws; i++) {
            const double u = open ? rng_uniform_open(&r) : rng_uniform(&r);
            if (open ? !(u > 0.0 && u < 1.0) : !(u >= 0.0 && u < 1.0)) out_of_range++;
            sum += u;
            counts[pit_bin(u, bins)]++;
        }
        const double chi2 = chi_square_flat(counts, bins, draws);
        const double z = (sum / draws - 0.5) / sqrt(1.0 / 12.0 / draws);
        fprintf(stderr, "rng_uniform%s: chi2 = %.2f (63 dof, crit 103.44), mean z = %.2f\n",
                open ? "_open" : "", chi2, z);
        CHECK(out_of_range == 0, "%d draws out of range", out_of_range);
        CHECK(chi2 < CHI2_CRIT_63, "chi2 %.2f", chi2);
        CHECK(fabs(z) < 5.0, "mean z %.2f", z);
    }
}

/* ---- jump ------------------------------------------------------------- */

typedef struct {
    uint64_t w[4];
} bits256;

/* M applied to x, M given by its columns (the images of the unit vectors). */
static bits256 apply(const bits256 *columns, bits256 x)
{
    bits256 y = {{0, 0, 0, 0}};
    for (int j = 0; j < 256; j++)
        if (x.w[j / 64] >> (j % 64) & 1)
            for (int k = 0; k < 4; k++) y.w[k] ^= columns[j].w[k];
    return y;
}

static void test_jump_is_2_pow_128_steps(void)
{
    static bits256 m[256], sq[256];
    for (int i = 0; i < 256; i++) {
        pdla_rng e = {{0, 0, 0, 0}};
        e.s[i / 64] = UINT64_C(1) << (i % 64);
        rng_next(&e); /* the state update, whose output is ignored */
        memcpy(m[i].w, e.s, sizeof e.s);
    }
    for (int step = 0; step < 128; step++) {
        for (int i = 0; i < 256; i++) sq[i] = apply(m, m[i]);
        memcpy(m, sq, sizeof m);
    }
    pdla_rng r;
    rng_seed(&r, 42);
    bits256 start;
    memcpy(start.w, r.s, sizeof r.s);
    const bits256 expected = apply(m, start);
    rng_jump(&r);
    CHECK(memcmp(expected.w, r.s, sizeof r.s) == 0,
          "rng_jump is not T^(2^128): got %016" PRIx64 "..., expected %016" PRIx64 "...",
          r.s[0], expected.w[0]);
}

static void test_jump_streams_differ(void)
{
    /* Three streams cut from one seed: no output of one equals the output of
     * another at the same index over 10^4 draws (a coincidence has odds
     * ~1e-15), and the jump is deterministic. */
    pdla_rng a, b, c, b2;
    rng_seed(&a, 7);
    b = a;
    rng_jump(&b);
    c = b;
    rng_jump(&c);
    b2 = a;
    rng_jump(&b2);
    CHECK(memcmp(&b, &b2, sizeof b) == 0, "rng_jump is not deterministic");
    int same = 0;
    for (int i = 0; i < 10000; i++) {
        const uint64_t x = rng_next(&a), y = rng_next(&b), z = rng_next(&c);
        same += (x == y) + (y == z) + (x == z);
    }
    CHECK(same == 0, "%d equal outputs across jumped streams", same);
}

int main(void)
{
    test_reference_outputs();
    test_uniform_ends();
    test_uniform_distribution();
    test_jump_is_2_pow_128_steps();
    test_jump_streams_differ();
    return check_finish();
}
