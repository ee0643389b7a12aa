/* TAYLOR: Taylor's method of variable order and step, with the order and step control of
 * A. Jorba and M. Zou, "A software package for the numerical integration of ODEs by means of
 * high-order Taylor methods", Experimental Mathematics 14 (2005) 99-117, section 3.3.
 *
 * Each step expands the solution at (t, y) in its Taylor series to order p, from the
 * recurrences of the equations' elementary operations that the model part generated
 * (lag_taylor_series, codegen/c_taylor.py): no right-hand side is evaluated, and no step is
 * rejected: the step is chosen from the series itself, a fraction of its radius of convergence.
 *
 * Tolerances as for the other adaptive methods: component i is measured against
 * w_i = atol_i + rtol |y_i| (HNW I, II.4, (4.11)), so that x̂ = x / w is the series in units of
 * the tolerance. With M = max(max_i |y_i| / w_i, 1 / (min_i atol_i + rtol)), the size of the state in
 * those units (1/rtol for a state that rtol governs, that of a unit state where atol does):
 *   order  p = ceil(ln(M) / 2 + 1), Jorba and Zou's -ln(eps)/2 + 1 for eps = 1/M;
 *   radius rho = min over j = p-1, p of (M / max_i |x̂_{j,i}|)^(1/j), the convergence radius
 *          estimated from the last two coefficients (its absolute and relative forms at once);
 *   step   h = rho / e^2 * exp(-0.7 / (p - 1)), so that the last terms are about exp(-0.7) w:
 *          for coefficients that decay like M rho^-j, the truncation error is below the
 *          tolerance (Jorba and Zou, (3.9)-(3.12)), and the order minimises the work per unit time.
 * h is at most max_step and lands exactly on t_end, as in lag_control_trial.
 *
 * The norm (option norm, integrators/registry.py): with `component` (the default) each component
 * has its own w_i as above, which states that mix units (a length and an angle) need. With `state`,
 * Jorba and Zou's own control, one tolerance for the whole state,
 *   w_i = w = atol + rtol max_k |y_k|   (atol: the smallest atol_i),
 * so that the sizes above are infinity norms of the whole state and of its coefficients,
 * ||x_j|| / w: a state whose components are all on one scale (the positions and velocities of a
 * many-body problem) is held to the same accuracy with fewer steps, as no small component's
 * own tolerance holds the step.
 *
 * Dense output: the step's own polynomial, evaluated at t - t_old (Horner); the series stays in
 * the stepper until the next step. When the driver projects the end state onto the constraints,
 * the output adds (t - t_old)/h times the move, so that it ends where the next step starts.
 */

#define LAG_INTEGRATOR_NAME "taylor"

/* Work counters: steps (none is rejected) and the orders of their series, summed (the work of a
 * step is about its order times one evaluation of the equations in Taylor arithmetic). */
typedef struct lag_stats {
    long accepted, orders;
} lag_stats;

typedef struct lag_stepper {
    LAG_STEPPER_PUBLIC(lag_stats)     /* t, t_old (the series below is about t_old), y, h, stats (runtime.h) */
    const lag_system *sys;
    real t_end, span, hmax, rtol;
    int state_norm;                   /* the norm: 1 state (one w for all), 0 component */
    real atol[LAG_NY], atol_least;    /* per component of y, and the smallest */
    long max_steps;
    int order;                        /* the last step's order */
    real order_low, order_high;       /* the sizes M that give that order: low < M <= high */
    int safety_order;                 /* the order `safety` was computed for */
    real safety;                      /* h / rho = e^-2 exp(-0.7 / (p - 1)) */
    real y_end[LAG_NY];               /* the polynomial at t, before the driver may move y */
    real shift[LAG_NY];               /* y - y_end: the move, spread over the dense output */
    real s[LAG_TAYLOR_NODES][LAG_TAYLOR_ORDERS];    /* the last step's series (lag_taylor_series) */
} lag_stepper;

static int lag_stepper_init(lag_stepper *s, const lag_system *sys, real t0, const real *y0,
                            real t_end, const lag_options *opt)
{
    int i;
    (void)lag_rhs;                    /* the series take the place of the right-hand side */
    memset(&s->stats, 0, sizeof s->stats);
    s->sys = sys;
    s->t = s->t_old = t0;
    s->t_end = t_end;
    s->span = t_end - t0;
    s->hmax = opt->max_step > 0 ? opt->max_step : t_end - t0;
    s->rtol = opt->rtol;
    s->state_norm = opt->norm;
    s->atol_least = REAL_MAX;
    for (i = 0; i < LAG_NY; ++i) {
        s->atol[i] = LAG_ATOL(opt, i);
        s->atol_least = r_fmin(s->atol_least, s->atol[i]);
    }
    for (i = 0; s->state_norm && i < LAG_NY; ++i)
        s->atol[i] = s->atol_least;   /* the state norm: one atol, the smallest */
    s->max_steps = opt->max_steps;
    s->h = 0;
    s->order = 0;                     /* until the first step, the dense output is y0 */
    s->order_low = s->order_high = 0; /* no size: the first step takes the logarithm */
    s->safety_order = 0;
    memcpy(s->y, y0, sizeof s->y);
    memcpy(s->y_end, y0, sizeof s->y_end);
    memset(s->shift, 0, sizeof s->shift);
    for (i = 0; i < LAG_NY; ++i)
        s->s[i][0] = y0[i];
    return LAG_OK;
}

/* The larger of x and largest, x when it is NaN (a select, which a loop over the lanes vectorises). */
static real taylor_larger(real x, real largest)
{
    return x <= largest ? largest : x;
}

/* max_i |x_i| / w_i over the state's coefficients x = s[.][j]; NaN when one of them is. */
static real taylor_norm(const lag_stepper *s, const real *weight, int j)
{
    real largest = 0;
    int i;
    for (i = 0; i < LAG_NY; ++i)
        largest = taylor_larger(r_fabs(s->s[i][j]) * weight[i], largest);
    return largest;
}

/* The order for the state y, from its size M in units of the tolerance: order p holds for
 * e^(2p - 4) < M <= e^(2p - 2), a range the order keeps from step to step, so the logarithm is
 * taken only when M leaves it (the clamped orders 2 and the highest extend it). The sweep's lanes
 * take M in a loop over the lanes (taylor_lanes.c) and the order from it here. */
static int taylor_order_of(lag_stepper *s, real size)
{
    real wanted;
    int order;
    if (size > s->order_low && size <= s->order_high)
        return s->order;
    wanted = r_log(size) / 2 + 1;
    if (!(wanted < LAG_TAYLOR_MAX_ORDER)) {
        order = LAG_TAYLOR_MAX_ORDER;
    } else {
        order = (int)wanted;
        order += order < wanted;      /* the ceiling */
        order = order < 2 ? 2 : order;
    }
    s->order_low = order == 2 ? 0 : r_exp((real)(2 * order - 4));
    s->order_high = order == LAG_TAYLOR_MAX_ORDER ? REAL_MAX : r_exp((real)(2 * order - 2));
    return order;
}

/* The state's size M = max(max_i |y_i| / w_i, 1 / (min_i atol_i + rtol)) (1/w = weight). */
static real taylor_size(const lag_stepper *s, const real *weight)
{
    real largest = 1 / (s->atol_least + s->rtol);
    int i;
    for (i = 0; i < LAG_NY; ++i) {
        real x = r_fabs(s->y[i]) * weight[i];
        largest = x > largest ? x : largest;     /* not r_fmax: a libm call in this loop */
    }
    return largest;
}

/* x^n for n >= 1, by squaring. */
static real taylor_power(real x, int n)
{
    real result = 1;
    for (; n > 0; n >>= 1, x *= x)
        if (n & 1)
            result *= x;
    return result;
}

#if !defined(LAG_FLOAT128) && !defined(LAG_LONG_DOUBLE)
/* taylor_radius without libm: in logarithms, log2 rho = min over j of (log2 size - log2 norm_j) / j,
 * so that one power of 2 follows the three logarithms (taylor_functions.c), which do not wait on one
 * another (size's is taken while the series is computed), and the reciprocals of the orders wait on
 * nothing: the radius was a quarter of a double pendulum's step while its two roots ran one after
 * the other, and the longest chain of this one is a logarithm and the power. The sweep's lanes take
 * it in a loop over the lanes (inline: gcc, left to itself, called it from that loop, which then did
 * not vectorise, a fifth of the sweep's time). inf or NaN where it does not hold (a norm of 0 or
 * beyond the normal numbers, order 2): taylor_radius then takes its own way. */
static inline real taylor_radius_near(real size, real before, real last, int p)
{
    const real whole = taylor_log2_near(size);
    const real first = (whole - taylor_log2_near(before)) * (1 / (real)(p - 1));
    const real other = (whole - taylor_log2_near(last)) * (1 / (real)p);
    const real least = other < first ? other : first;
    const real invalid = taylor_normal(size) & taylor_normal(before) & taylor_normal(last) & (p >= 3)
                         & (r_fabs(least) <= 1000) ? 1 : (real)INFINITY;
    return taylor_exp2_near(least) * invalid;   /* a product, not a division or a branch */
}
#endif

/* The radius of convergence from the norms of the last two coefficients (Jorba and Zou (3.11)):
 * min over j = p-1, p of (size / norm_j)^(1/j), REAL_MAX when both norms are 0. In a double build,
 * taylor_radius_near where its roots hold, as in the sweep's lanes (taylor_lanes.c). */
static real taylor_radius(real size, real before, real last, int p)
{
    real rho;
#if !defined(LAG_FLOAT128) && !defined(LAG_LONG_DOUBLE)
    if ((rho = taylor_radius_near(size, before, last, p)) <= REAL_MAX)
        return rho;               /* the common case: both norms positive, order 3 or more */
#endif
    rho = REAL_MAX;
    if (before > 0)
        rho = taylor_root(size / before, p - 1);
    /* the radius from the last is the smaller one iff size / last < rho^p: the second power only
     * then (rho^p overflows to inf for a huge rho, and then the power is taken) */
    if (last > 0 && (rho == REAL_MAX || size / last < taylor_power(rho, p))) {
        real other = taylor_root(size / last, p);
        rho = other < rho ? other : rho;
    }
    return rho;
}

/* The norms of the last two coefficients, before (order p-1) and last (order p), or
 * LAG_ERR_NONFINITE. */
static int taylor_norms(const lag_stepper *s, const real *weight, real *before, real *last)
{
    *last = taylor_norm(s, weight, s->order);
    *before = taylor_norm(s, weight, s->order - 1);
    return r_isfinite(*last) && r_isfinite(*before) ? LAG_OK : LAG_ERR_NONFINITE;
}

/* The step from the radius rho: a fraction of it (at most hmax, landing exactly on t_end:
 * *landing), or LAG_ERR_STEP_TOO_SMALL. */
static int taylor_step_from(lag_stepper *s, real rho, real *h, int *landing)
{
    const int p = s->order;
    if (p != s->safety_order) {       /* the order rarely changes: exp once per change */
        s->safety = r_exp(-2 - LAG_LIT(0.7) / (p - 1));
        s->safety_order = p;
    }
    *h = rho * s->safety;
    *h = *h < s->hmax ? *h : s->hmax;
    if (!(*h >= LAG_MIN_STEP(s->t, s->span)))
        return LAG_ERR_STEP_TOO_SMALL;
    if ((*landing = s->t + LAG_LIT(1.01) * *h >= s->t_end))
        *h = s->t_end - s->t;
    return LAG_OK;
}

/* y at t_old + tau from the series (Horner), without the projection's shift; the components
 * innermost, so that their chains of multiplications and additions overlap. */
static void taylor_evaluate(const lag_stepper *s, real tau, real *y)
{
    int i, j;
    for (i = 0; i < LAG_NY; ++i)
        y[i] = s->s[i][s->order];
    for (j = s->order - 1; j >= 0; --j)
        for (i = 0; i < LAG_NY; ++i)
            y[i] = y[i] * tau + s->s[i][j];
}

/* Whether a step is to be taken: *taking is 0 when the run is at its end (no step to take,
 * LAG_OK); LAG_ERR_MAX_STEPS at the step limit. */
static int taylor_may_step(const lag_stepper *s, int *taking)
{
    *taking = s->t < s->t_end;
    if (*taking && s->max_steps > 0 && s->stats.accepted >= s->max_steps)
        return LAG_ERR_MAX_STEPS;
    return LAG_OK;
}

/* The magnitude each component's tolerance is relative to: |y_i|, or with the state norm the
 * largest max_k |y_k| for every one (`state_norm` 0 or 1: arithmetic, so that a loop over the
 * sweep's lanes around it vectorises and does the same arithmetic, taylor_lanes.c). */
static real taylor_scale(real magnitude, real largest, int state_norm)
{
    return state_norm ? largest : magnitude;
}

/* The first half of a step, before the series: the step limit, the weights 1/w of the state's
 * components and the order for them (size: the state's size in units of the tolerance). */
static int taylor_begin_step(lag_stepper *s, real *weight, real *size, int *taking)
{
    real largest = 0;
    int i, status = taylor_may_step(s, taking);
    if (status != LAG_OK || !*taking)
        return status;
    for (i = 0; s->state_norm && i < LAG_NY; ++i)
        largest = taylor_larger(r_fabs(s->y[i]), largest);
    for (i = 0; i < LAG_NY; ++i)
        weight[i] = 1 / (s->atol[i] + s->rtol * taylor_scale(r_fabs(s->y[i]), largest, s->state_norm));
    *size = taylor_size(s, weight);
    s->order = taylor_order_of(s, *size);
    return LAG_OK;
}

/* The step of the second half, from the series in s->s: its size h (at most hmax, landing
 * exactly on t_end: *landing), or LAG_ERR_NONFINITE, LAG_ERR_STEP_TOO_SMALL. */
static int taylor_step_to_take(lag_stepper *s, const real *weight, real size, real *h, int *landing)
{
    real before, last;
    int status;
    s->stats.orders += s->order;
    if ((status = taylor_norms(s, weight, &before, &last)) != LAG_OK)
        return status;
    return taylor_step_from(s, taylor_radius(size, before, last, s->order), h, landing);
}

/* The step h taken, once s->y_end holds the series at t + h: the state moves there, or
 * LAG_ERR_NONFINITE. */
static int taylor_take_step(lag_stepper *s, real h, int landing)
{
    int i, finite = 1;
    for (i = 0; i < LAG_NY; ++i)      /* no early exit: the loop vectorises */
        finite &= r_isfinite(s->y_end[i]);
    if (!finite)
        return LAG_ERR_NONFINITE;
    memcpy(s->y, s->y_end, sizeof s->y);
    memset(s->shift, 0, sizeof s->shift);
    s->t_old = s->t;
    s->t = landing ? s->t_end : s->t + h;
    s->h = h;
    ++s->stats.accepted;
    return LAG_OK;
}

/* The second half, once s->s holds the series of the state to s->order: the step from the series
 * and the state at its end. The sweep's lanes (taylor_lanes.c) compute the series of several
 * members at once between the two halves, and the state at the step's end (Horner) too. */
static int taylor_end_step(lag_stepper *s, const real *weight, real size)
{
    real h;
    int landing, status = taylor_step_to_take(s, weight, size, &h, &landing);
    if (status != LAG_OK)
        return status;
    taylor_evaluate(s, h, s->y_end);
    return taylor_take_step(s, h, landing);
}

static int lag_stepper_step(lag_stepper *s)
{
    real weight[LAG_NY] = { 0 }, size = 0;    /* set by taylor_begin_step (gcc -O2 and -O3 cannot tell) */
    int taking, status = taylor_begin_step(s, weight, &size, &taking);
    if (status != LAG_OK || !taking)
        return status;
    if ((status = lag_taylor_series(s->sys, s->t, s->y, s->order, s->s)) != LAG_OK)
        return status;
    return taylor_end_step(s, weight, size);
}

/* Valid on [t_old, t]: the step's polynomial, plus the projection's move in proportion. */
static int lag_stepper_dense(lag_stepper *s, real t, real *yout)
{
    real tau = t - s->t_old, share = s->h > 0 ? tau / s->h : 0;
    int i;
    taylor_evaluate(s, tau, yout);
    for (i = 0; i < LAG_NY; ++i)
        yout[i] += share * s->shift[i];
    return LAG_OK;
}

/* The driver moved y (projection): the next step starts from the moved y; the dense output of
 * the last one is shifted to end there. */
static int lag_stepper_restart(lag_stepper *s)
{
    int i;
    for (i = 0; i < LAG_NY; ++i)
        s->shift[i] = s->y[i] - s->y_end[i];
    return LAG_OK;
}
