/* taylor's own elementary functions: sin and cos at order 0 of the series (lag_sin, lag_cos), and
 * the root of the step size (taylor_root, taylor.c).
 *
 * lag_sin and lag_cos: one function in simulate()'s series
 * and in the sweep's lanes (taylor_lanes.c), where a loop over the lanes vectorises it. libm's sin
 * and cos are calls that no loop vectorises, and a vector libm (glibc's libmvec) rounds otherwise
 * than the scalar one, which would part a member from its simulate(); these are plain arithmetic,
 * the same operations in a lane as in the scalar series, so the two stay equal bit for bit.
 *
 * Method (J.-M. Muller, "Elementary Functions", 3rd ed., 2016: 11.2, Cody and Waite's reduction;
 * 3.8-3.9, polynomial approximations): x = n pi/2 + r, n the integer nearest x 2/pi (the sum with
 * 1.5 2^52 rounds to it), r = ((x - n P1) - n P2) - n P3 with pi/2 = P1 + P2 + P3, P1 and P2 of 32
 * significant bits, so that n P1 and n P2 are exact for |n| < 2^21; then on |r| <= pi/4
 *     sin r = r + r^3 S(r^2),    cos r = 1 - r^2/2 + r^4 C(r^2)   (1 - r^2/2 compensated),
 * S of degree 6 and C of degree 5 the Chebyshev fits (mpmath.chebyfit, 50 digits) of
 * (sin r - r)/r^3 and (cos r - 1 + r^2/2)/r^4 on r^2 in [0, (1.0001 pi/4)^2] (relative errors below
 * 1e-19), and n mod 4 picks sin or cos and the sign. Beyond |x| = 2^20 (the reduction loses digits),
 * and in long double and __float128 builds, libm's sin and cos. Accuracy:
 * tests/run/test_taylor_functions.py (against libm: within 1 ulp, most results equal).
 */

#if defined(LAG_FLOAT128) || defined(LAG_LONG_DOUBLE)
#define lag_sin r_sin
#define lag_cos r_cos
#define taylor_root(x, n) r_pow(x, (real)1 / (n))
#else
#define LAG_TRIG_LARGEST 0x1p20           /* |x| up to which the reduction holds */

/* The integer nearest x (|x| < 2^51), as a double: 1.5 2^52 + x has no bits below the unit. */
static inline double lag_nearest(double x)
{
    const double shifter = 0x1.8p52;
    return (x + shifter) - shifter;
}

/* sin r = r + r^3 S(r^2) and cos r on |r| <= pi/4 (1.0001 pi/4), z = r^2. */
static inline double lag_sin_reduced(double r, double z)
{
    const double s = -0x1.5555555555555p-3 + z * (0x1.1111111111110p-7 + z * (-0x1.a01a01a019936p-13
                     + z * (0x1.71de3a54605eep-19 + z * (-0x1.ae64541266378p-26 + z * (0x1.61217ec01749dp-33
                     + z * -0x1.ab17a79237a19p-41)))));
    return r + r * z * s;
}

static inline double lag_cos_reduced(double z)
{
    const double c = 0x1.5555555555555p-5 + z * (-0x1.6c16c16c16966p-10 + z * (0x1.a01a019f4e867p-16
                     + z * (-0x1.27e4fa17a41b4p-22 + z * (0x1.1eeb68b109173p-29 + z * -0x1.907d7aebd5e3dp-37))));
    const double half = 0.5 * z, w = 1 - half;
    return w + (((1 - w) - half) + z * z * c);   /* (1 - w) - half: the rounding error of w */
}

/* sin x (cosine: 1) for |x| <= LAG_TRIG_LARGEST, NaN beyond: n mod 4 (+1 for the cosine) as an
 * integer 0 .. 3 picks sin r, cos r, -sin r, -cos r. Its two bits, not comparisons of q with each
 * value (seven compares and their combining, a third of the two pairs' instructions at order 0);
 * q is converted only where it is n mod 4 (beyond the range, 0: no conversion out of int's range). */
static inline double lag_trig_near(double x, int cosine)
{
    const double n = lag_nearest(x * 0x1.45f306dc9c883p-1);
    const double r = ((x - n * 0x1.921fb544p0) - n * 0x1.0b4611a6p-34) - n * 0x1.3198a2e037073p-69;
    const double z = r * r, q = n - 4 * lag_nearest(0.25 * n);
    const int within = r_fabs(x) <= LAG_TRIG_LARGEST, quadrant = ((int)(within ? q : 0) + cosine) & 3;
    const double value = quadrant & 1 ? lag_cos_reduced(z) : lag_sin_reduced(r, z);
    return within ? (quadrant & 2 ? -value : value) : NAN;
}

/* What the lanes compute (NaN for a large |x|: the lane then takes the scalar series, lag_sin). */
static inline double lag_sin_near(double x) { return lag_trig_near(x, 0); }
static inline double lag_cos_near(double x) { return lag_trig_near(x, 1); }

static inline double lag_sin(double x) { return r_fabs(x) <= LAG_TRIG_LARGEST ? lag_trig_near(x, 0) : r_sin(x); }
static inline double lag_cos(double x) { return r_fabs(x) <= LAG_TRIG_LARGEST ? lag_trig_near(x, 1) : r_cos(x); }

/* x^(1/n) for the step size (Jorba and Zou's radius, taylor_radius in taylor.c), without libm's pow,
 * a call that no loop over the sweep's lanes vectorises: 2^(log2(x) / n), with x = 2^e m, m in
 * [sqrt(1/2), sqrt(2)), log2 m = 2 atanh(u) / ln 2 for u = (m - 1) / (m + 1) (|u| < 0.172, its
 * series to u^11), and 2^f for |f| <= 1/2 from its Taylor series to f^10; relative error below
 * 1e-10, ample for a step that is a fraction of the radius. The polynomials in Estrin's scheme: their
 * pairs of terms and powers do not wait on one another, where each of Horner's steps waits on the
 * last (the step waits on its radius: 0.3 of Horner's latency). taylor_log2_near for a normal x
 * (any other: what it returns is not used), taylor_exp2_near for |y| <= 1000 (both: arithmetic, no
 * branch, so that a loop over the lanes vectorises). log2's reduction to [sqrt(1/2), sqrt(2)) compares
 * and selects the bits as integers: a select on a comparison of doubles is not if-converted by gcc
 * (ISO C's -ftrapping-math: a comparison with NaN may trap), "control flow in loop", and the lanes'
 * radius loop did not vectorise. */
static inline double taylor_log2_near(double x)
{
    unsigned long long bits, mantissa;
    double m, u, w, w2;
    int e, above;
    memcpy(&bits, &x, sizeof bits);
    mantissa = bits & 0x000fffffffffffffULL;
    above = mantissa > 0x6a09e667f3bcdULL;    /* 1.mantissa > sqrt(2): m = 1.mantissa / 2, e + 1 */
    e = (int)(bits >> 52) - 1023 + above;
    bits = mantissa | (above ? 0x3fe0000000000000ULL : 0x3ff0000000000000ULL);
    memcpy(&m, &bits, sizeof m);
    u = (m - 1) / (m + 1);
    w = u * u;
    w2 = w * w;
    return e + u * ((0x1.71547652b82fep+1 + w * 0x1.ec709dc3a03fdp-1) + w2 * ((0x1.2776c50ef9bfep-1
           + w * 0x1.a61762a7aded9p-2) + w2 * (0x1.484b13d7c02a9p-2 + w * 0x1.0c9a84994022dp-2)));
}

static inline double taylor_exp2_near(double y)
{
    unsigned long long bits;
    double two, whole = lag_nearest(y), f = y - whole;
    const double f2 = f * f, f4 = f2 * f2, f8 = f4 * f4;
    const double power = ((1 + f * 0x1.62e42fefa39efp-1) + f2 * (0x1.ebfbdff82c58fp-3 + f * 0x1.c6b08d704a0c0p-5))
            + f4 * ((0x1.3b2ab6fba4e77p-7 + f * 0x1.5d87fe78a6731p-10) + f2 * (0x1.430912f86c787p-13
            + f * 0x1.ffcbfc588b0c7p-17)) + f8 * ((0x1.62c0223a5c824p-20 + f * 0x1.b5253d395e7c4p-24)
            + f2 * 0x1.e4cf5158b8ecap-28);
    bits = (unsigned long long)(((int)whole + 1023) & 2047) << 52;   /* 2^whole, |whole| <= 1000 */
    memcpy(&two, &bits, sizeof two);
    return power * two;
}

/* Whether x is a normal number (NaN: not). */
static inline int taylor_normal(double x)
{
    return (x >= DBL_MIN) & (x <= DBL_MAX);
}

/* x^(1/n) for n >= 2 and a normal x; inf or NaN otherwise (taylor_root takes those). */
static inline double taylor_root_near(double x, int n)
{
    return taylor_exp2_near(taylor_log2_near(x) / n) / (taylor_normal(x) & (n >= 2));
}

/* x^(1/n), n >= 1: taylor_root_near, x itself for n = 1, libm's pow for x outside the normal numbers. */
static inline double taylor_root(double x, int n)
{
    if (n == 1)
        return x;
    return x >= DBL_MIN && x <= DBL_MAX ? taylor_root_near(x, n) : r_pow(x, 1.0 / n);
}
#endif
