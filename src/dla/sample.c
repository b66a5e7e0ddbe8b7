/*
 * sample.c - the walker's random geometry (see sample.h for the laws).
 *
 * sample_step2 and sample_step3 (inline in sample.h) run once per walker
 * jump, so they use rejection from the square and no libm call but one sqrt
 * in 3D; the 2D return (sample_return_cs2) needs no libm call either. The return
 * samplers run only when a walker leaves the birth circle/sphere; there the
 * concern is precision, not speed: r/R may be 1 + 1e-12 (a walker just
 * outside) or 1e300, so every formula below is arranged to avoid
 * cancellation and overflow, and results are clamped to their exact ranges.
 */
#include "sample.h"

#include <math.h>

void sample_return_cs2(pdla_rng *rng, double r, double R, double cs[2])
{
    /* k = (r - R) / (r + R). r - R is exact when r and R are close (Sterbenz),
     * which is where k matters most; halving both terms keeps r + R finite
     * for r near DBL_MAX. k rounds to 1 for r/R > ~1e16, where the law is
     * uniform to double precision anyway. A walker at or inside R (which the
     * caller should not send) returns where it is. */
    const double gap = r - R;
    if (!(gap > 0.0)) {
        cs[0] = 1.0;
        cs[1] = 0.0;
        return;
    }
    double k = (0.5 * gap) / (0.5 * r + 0.5 * R);
    if (k > 1.0) k = 1.0;
    /* tan(pi (u - 1/2)) with u uniform is a standard Cauchy variable, and so
     * is b/a for (a, b) uniform in the unit disk (its angle is uniform). With
     * w = k b/a, theta = 2 atan(w) has cos = (1 - w^2)/(1 + w^2) and sin =
     * 2w/(1 + w^2); times a^2/a^2 that is (a^2 - (kb)^2, 2a(kb)) / (a^2 +
     * (kb)^2): no trig, no division by a (a = 0, probability 2^-53, is
     * theta = pi). The disk point comes from two 52-bit uniforms (as
     * sample_dir2), so the angle is as fine as the old tan/atan form's. */
    for (;;) {
        const double a = sample_uniform_pm1(rng);
        const double b = sample_uniform_pm1(rng);
        const double s = a * a + b * b;
        if (s >= 1.0 || s < 1e-300) continue;
        const double kb = k * b, a2 = a * a, kb2 = kb * kb;
        const double inv = 1.0 / (a2 + kb2);
        cs[0] = (a2 - kb2) * inv;
        cs[1] = 2.0 * a * kb * inv;
        return;
    }
}

double sample_return_angle2(pdla_rng *rng, double r, double R)
{
    double cs[2];
    sample_return_cs2(rng, r, R, cs);
    const double theta = atan2(cs[1], cs[0]);
    /* atan2(-0, -1) is -pi: the same point as pi. */
    return theta <= -M_PI ? M_PI : theta;
}

int sample_return3(pdla_rng *rng, double r, double R, double *cos_theta)
{
    /* Return with probability R/r: the test u < R/r, with u in [0, 1), is
     * always true for r <= R and never true when R/r underflows. */
    if (!(rng_uniform(rng) < R / r)) return 0;

    const double a = r - R; /* near distance; exact when r ~ R */
    if (!(a > 0.0)) {
        *cos_theta = 1.0;
        return 1;
    }
    /* With w = 1/rho = 1/(r+R) + u (1/(r-R) - 1/(r+R)), the law cos(theta) =
     * (r^2 + R^2 - rho^2) / (2 r R) rearranges, with no subtraction of nearly
     * equal terms, into
     *     1 - cos(theta) = 2 (1 - u) (1 + u R/r) t^2,   t = a / (a + 2 u R),
     * where a = r - R. Each factor lies in [0, 2] and is computed to a few
     * ulps for any r/R: as r -> R+, t -> 0 and cos -> 1; as r/R -> inf,
     * t -> 1 and cos -> 2u - 1, uniform. u = 0 is rho = r + R, the far pole.
     * Writing t as 1 / (1 + 2u (R/a)) keeps it finite for r near DBL_MAX;
     * R/a is at most ~2^53 since a is at least one ulp of R. */
    const double u = rng_uniform_open(rng);
    const double t = 1.0 / (1.0 + 2.0 * u * (R / a));
    const double one_minus_cos = 2.0 * (1.0 - u) * (1.0 + u * (R / r)) * t * t;
    double c = 1.0 - one_minus_cos;
    if (c < -1.0) c = -1.0;
    if (c > 1.0) c = 1.0;
    *cos_theta = c;
    return 1;
}

void sample_cone_point3(pdla_rng *rng, const double u[3], double R, double cos_theta,
                        double out[3])
{
    /* Orthonormal e1, e2 perpendicular to the unit vector u, accurate for
     * every direction, including u = (0, 0, -1) where Frisvad's original
     * divides by zero: Duff et al., "Building an orthonormal basis,
     * revisited", JCGT 6(1), 2017. */
    const double sign = copysign(1.0, u[2]);
    const double a = -1.0 / (sign + u[2]);
    const double b = u[0] * u[1] * a;
    const double e1[3] = {1.0 + sign * u[0] * u[0] * a, sign * b, -sign * u[0]};
    const double e2[3] = {b, sign + u[1] * u[1] * a, -u[1]};

    double c = cos_theta;
    if (c > 1.0) c = 1.0;
    if (c < -1.0) c = -1.0;
    /* (1 - c)(1 + c) rather than 1 - c^2: keeps the relative precision of a
     * small sine when the caller's c is close to +-1. */
    const double sin_theta = sqrt((1.0 - c) * (1.0 + c));
    double az[2];
    sample_dir2(rng, az);
    const double s1 = sin_theta * az[0];
    const double s2 = sin_theta * az[1];
    for (int i = 0; i < 3; i++) out[i] = R * (c * u[i] + s1 * e1[i] + s2 * e2[i]);
}

void sample_rotate_cs2(double x, double y, double r, const double cs[2], double R,
                       double out[2])
{
    const double scale = R / r;
    out[0] = scale * (cs[0] * x - cs[1] * y);
    out[1] = scale * (cs[1] * x + cs[0] * y);
}

void sample_rotate_to2(double x, double y, double theta, double R, double out[2])
{
    /* hypot avoids overflow and underflow of x^2 + y^2 for any finite point. */
    const double cs[2] = {cos(theta), sin(theta)};
    sample_rotate_cs2(x, y, hypot(x, y), cs, R, out);
}
