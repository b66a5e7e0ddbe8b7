/*
 * sample.h - the random geometry of the walker: uniform directions, birth
 * points, and the exact (killing-free) return of a walker that left the
 * birth circle/sphere, by the exterior harmonic measure.
 *
 * Return laws (r = |p| > R = R_birth):
 *   2D: the walker always returns; the angle between p and the return point is
 *       theta = 2 atan(((r - R)/(r + R)) tan(pi (u - 1/2))), u ~ U(0,1)
 *       (a wrapped Cauchy law with concentration R/r); sample_return_cs2
 *       gives its cos and sin without trig (sample.c).
 *   3D: it returns with probability R/r, else it escapes to infinity (a new
 *       walker starts uniformly on the sphere). Given return, the distance rho
 *       from p to the return point has 1/rho uniform on [1/(r+R), 1/(r-R)], and
 *       cos(theta) = (r^2 + R^2 - rho^2) / (2 r R); the azimuth is uniform.
 * All functions are finite for r/R anywhere in (1, 1e300) and beyond, and
 * return values clamped to their exact ranges. A walker sent with r <= R
 * (which callers should not do) returns where it is: theta = 0, cos = 1.
 * Precision: cos(theta) is passed as a double, so a 3D angle below ~1.5e-8
 * (1 - cos under an ulp of 1) reads as 0, a displacement of at most
 * 1.5e-8 R; typical angles are that small only when r - R < ~1e-8 R.
 */
#ifndef PDLA_SRC_SAMPLE_H
#define PDLA_SRC_SAMPLE_H
#include <math.h>

#include "rng.h"

/* Uniform in [-1, 1) on the grid of 2^-52: k * 2^-52 is exact for k < 2^53
 * and subtracting 1 is exact for every such value, so no bias creeps in. */
static inline double sample_uniform_pm1(pdla_rng *rng)
{
    return (double)(rng_next(rng) >> 11) * 0x1.0p-52 - 1.0;
}

/* Uniform unit vector, by rejection from the square (no trig, and in 3D one
 * sqrt): the walker's hot path, once per jump, so inline. Coordinates carry
 * 52 random bits. */
static inline void sample_dir2(pdla_rng *rng, double v[2])
{
    for (;;) {
        const double x = sample_uniform_pm1(rng);
        const double y = sample_uniform_pm1(rng);
        const double s = x * x + y * y;
        /* s < 1e-300 is only s == 0 on this grid; it would give 0/0. */
        if (s >= 1.0 || s < 1e-300) continue;
        /* (x, y) has a uniform angle phi; the double angle 2 phi is uniform
         * too, and (cos 2phi, sin 2phi) needs no square root. */
        const double inv_s = 1.0 / s;
        v[0] = (x * x - y * y) * inv_s;
        v[1] = 2.0 * x * y * inv_s;
        return;
    }
}

/* The 2D walker's jump: len times a uniform unit vector, in d. One 64-bit
 * draw per try (sample_dir2 takes two): its halves, read as signed 32-bit
 * integers, are a point (x, y) of the integer lattice in [-2^31, 2^31)^2,
 * kept when 0 < x^2 + y^2 < 2^62 (exact in 64-bit integers; the one
 * unsigned compare also rejects 0). The kept set is symmetric under the
 * square's eight symmetries, and the CDF of its angle is the uniform one up
 * to an absolute error of order 2^-31 (~5e-10, the lattice points along a
 * sector's edges): a jump of 1e6 units lands within ~1e-3 units of where
 * its law puts it, against the half unit of the grid rounding that follows. Doubling the
 * angle, as in sample_dir2, needs no square root: the direction is
 * (x^2 - y^2, 2xy) / (x^2 + y^2), integers below 2^62 in magnitude,
 * converted to double with a relative rounding of 2^-53; the one division
 * also applies len. */
/* One 64-bit draw as a point (x, y) of the integer lattice in
 * [-2^31, 2^31)^2 (its halves as signed 32-bit integers): x^2 + y^2, exact
 * in 64 bits (below 2^63). The jump samplers keep it inside the disk. */
static inline uint64_t sample_lattice_point(pdla_rng *rng, int64_t *x, int64_t *y)
{
    const uint64_t z = rng_next(rng);
    *x = (int32_t)(uint32_t)(z >> 32);
    *y = (int32_t)(uint32_t)z;
    return (uint64_t)(*x * *x) + (uint64_t)(*y * *y);
}

static inline void sample_step2(pdla_rng *rng, double len, double d[2])
{
    for (;;) {
        int64_t x, y;
        const uint64_t s = sample_lattice_point(rng, &x, &y);
        if (s - 1 >= (UINT64_C(1) << 62) - 1) continue;
        const double f = len / (double)(int64_t)s;
        d[0] = (double)(x * x - y * y) * f;
        d[1] = (double)(2 * x * y) * f;
        return;
    }
}

static inline void sample_dir3(pdla_rng *rng, double v[3])
{
    /* Marsaglia (1972): with (x, y) uniform in the unit disk and s = x^2 + y^2,
     * 1 - 2s is uniform on [-1, 1] (Archimedes) and the azimuth is that of
     * (x, y); the factor 2 sqrt(1 - s) puts the point on the unit sphere. */
    for (;;) {
        const double x = sample_uniform_pm1(rng);
        const double y = sample_uniform_pm1(rng);
        const double s = x * x + y * y;
        if (s >= 1.0) continue;
        const double scale = 2.0 * sqrt(1.0 - s);
        v[0] = x * scale;
        v[1] = y * scale;
        v[2] = 1.0 - 2.0 * s;
        return;
    }
}


/* The 3D walker's jump: len times a uniform unit vector, in d. Marsaglia's
 * method (as sample_dir3) from one 64-bit draw per try instead of two: the
 * halves, as signed 32-bit integers, are a lattice point (x, y) kept when
 * x^2 + y^2 = s < 2^62 (exact in 64-bit integers; accepted in pi/4 of tries,
 * so 1.27 draws a jump instead of 2.55). With q = 2^62 - s, the point is
 *     (x, y) sqrt(q) 2^-61,  z = (q - s) 2^-62,
 * that is, for (x, y) 2^-31 uniform in the unit disk with S = s 2^-62, the
 * Marsaglia point (2x sqrt(1 - S), 2y sqrt(1 - S), 1 - 2S). q and q - s are
 * exact integers, so each coordinate is rounded once or twice (relative
 * 2^-53), with no cancellation at either pole. The kept set is symmetric
 * under the square's eight symmetries; the CDFs of z and of the azimuth are
 * the uniform ones up to an absolute error of order 2^-31 (the lattice
 * points near the disk's and the sectors' edges), as for sample_step2.
 * (0, 0) is kept: it is the pole (0, 0, 1), one point of weight ~2^-64. */
static inline void sample_step3(pdla_rng *rng, double len, double d[3])
{
    for (;;) {
        int64_t x, y;
        const uint64_t s = sample_lattice_point(rng, &x, &y);
        if (s >= (UINT64_C(1) << 62)) continue;
        const int64_t q = (int64_t)((UINT64_C(1) << 62) - s);
        const double f = len * 0x1.0p-61 * sqrt((double)q);
        d[0] = (double)x * f;
        d[1] = (double)y * f;
        d[2] = len * 0x1.0p-62 * (double)(q - (int64_t)s);
        return;
    }
}

/* 2D: cos and sin of the return angle theta for a walker at radius r, in
 * cs[0], cs[1]; no trig (the walker's return). */
void sample_return_cs2(pdla_rng *rng, double r, double R, double cs[2]);

/* 2D: signed return angle theta in (-pi, pi] for a walker at radius r: the
 * angle of sample_return_cs2 (for tests and tools). */
double sample_return_angle2(pdla_rng *rng, double r, double R);

/* 3D: 1 and *cos_theta if the walker returns (probability R/r), 0 if it is
 * lost to infinity. */
int sample_return3(pdla_rng *rng, double r, double R, double *cos_theta);

/* Point at radius R whose direction makes angle acos(cos_theta) with the unit
 * vector u (not renormalised here), azimuth uniform around u. */
void sample_cone_point3(pdla_rng *rng, const double u[3], double R, double cos_theta,
                        double out[3]);

/* 2D: rotate the point (x, y), whose norm is r, by the angle whose cos and
 * sin are cs, and scale it to radius R. */
void sample_rotate_cs2(double x, double y, double r, const double cs[2], double R,
                       double out[2]);

/* 2D: rotate the point (x, y) by theta and scale it to radius R. */
void sample_rotate_to2(double x, double y, double theta, double R, double out[2]);
#endif
