/*
 * sample.h - the random geometry of the walker: uniform directions, birth
 * points, and the exact (killing-free) return of a walker that left the
 * birth circle/sphere, by the exterior harmonic measure.
 *
 * Return laws (r = |p| > R = R_birth):
 *   2D: the walker always returns; the angle between p and the return point is
 *       theta = 2 atan(((r - R)/(r + R)) tan(pi (u - 1/2))), u ~ U(0,1)
 *       (a wrapped Cauchy law with concentration R/r).
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
#include "rng.h"

/* Uniform unit vector, by rejection from the square (no trig, and in 3D one
 * sqrt): the walker's hot path, once per jump. Coordinates carry 52 random
 * bits. */
void sample_dir2(pdla_rng *r, double v[2]);
void sample_dir3(pdla_rng *r, double v[3]);

/* 2D: signed return angle theta in (-pi, pi] for a walker at radius r. */
double sample_return_angle2(pdla_rng *rng, double r, double R);

/* 3D: 1 and *cos_theta if the walker returns (probability R/r), 0 if it is
 * lost to infinity. */
int sample_return3(pdla_rng *rng, double r, double R, double *cos_theta);

/* Point at radius R whose direction makes angle acos(cos_theta) with the unit
 * vector u (not renormalised here), azimuth uniform around u. */
void sample_cone_point3(pdla_rng *rng, const double u[3], double R, double cos_theta,
                        double out[3]);

/* 2D: rotate the point (x, y) by theta and scale it to radius R. */
void sample_rotate_to2(double x, double y, double theta, double R, double out[2]);
#endif
