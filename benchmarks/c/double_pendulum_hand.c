/* The plane double pendulum's right-hand side written by hand, for benchmarks/double_pendulum_speed.py.
 *
 * The textbook equations of the plane double pendulum, with d = theta1 - theta2:
 *   (m1 + m2) l1^2 th1'' + m2 l1 l2 cos(d) th2'' = -m2 l1 l2 sin(d) th2'^2 - (m1 + m2) g l1 sin(th1)
 *   m2 l1 l2 cos(d) th1'' + m2 l2^2 th2''         =  m2 l1 l2 sin(d) th1'^2 - m2 g l2 sin(th2)
 * solved by Cramer's rule. Same calling convention as the generated model: par = (m1, m2, l1,
 * l2, g) as in models/double_pendulum.lag, y = (theta1, theta2, theta1', theta2'), dydt = y'.
 * Appended after the generated C file, so `real` and the r_* functions are those of runtime.h
 * (plain double and libm in the default build). */
static int hand_rhs(const real *par, real t, const real *y, real *dydt)
{
    const real m1 = par[0], m2 = par[1], l1 = par[2], l2 = par[3], g = par[4];
    const real d = y[0] - y[1];
    const real c = r_cos(d), s = r_sin(d);
    const real a11 = (m1 + m2) * l1 * l1;
    const real a12 = m2 * l1 * l2 * c;
    const real a22 = m2 * l2 * l2;
    const real b1 = -m2 * l1 * l2 * s * y[3] * y[3] - (m1 + m2) * g * l1 * r_sin(y[0]);
    const real b2 = m2 * l1 * l2 * s * y[2] * y[2] - m2 * g * l2 * r_sin(y[1]);
    const real det = a11 * a22 - a12 * a12;
    (void)t;
    dydt[0] = y[2];
    dydt[1] = y[3];
    dydt[2] = (b1 * a22 - a12 * b2) / det;
    dydt[3] = (a11 * b2 - a12 * b1) / det;
    return LAG_OK;
}
