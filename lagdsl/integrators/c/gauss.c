/* GAUSS: s-stage Gauss-Legendre collocation (s = 1..6, order 2s) with a fixed step, applied to
 * Hamilton's equations z' = F(t, z) in the canonical variables z = (q, p), p = dL/dq'.
 *
 * Method: Hairer, Lubich, Wanner, Geometric Numerical Integration, 2nd ed. (GNI).
 *  - Collocation at the zeros c_1 < ... < c_s of the shifted Legendre polynomial P_s(2x - 1)
 *    is the implicit Runge-Kutta method with a_ij = int_0^{c_i} l_j, b_j = int_0^1 l_j, where
 *    l_j is the Lagrange basis of the nodes (GNI II.1.3, Theorem 1.4); its order is 2s.
 *  - It satisfies b_i a_ij + b_j a_ji = b_i b_j, so it is symplectic (GNI VI.4) and symmetric:
 *    energy errors stay bounded without drift over long times.  This holds in canonical
 *    variables only, which is why the stepper integrates z and not (q, q').
 *  - The coefficients are computed at init in working precision (so long double and __float128
 *    get coefficients to their own precision): nodes by Newton's method on P_s, weights
 *    b_j = 1 / ((1 - x_j^2) P_s'(x_j)^2) on [0, 1], and int_0^theta l_j by the s-point Gauss rule
 *    on [0, theta], which is exact for the degree s-1 polynomial l_j.
 *  - Stage equations in the increments Z_i = z(t0 + c_i h) - z0 (GNI VIII.6), written with
 *    mu_ij = a_ij / b_j and dz_j = h b_j F(t0 + c_j h, z0 + Z_j):
 *        Z_i = sum_j mu_ij dz_j,    z1 = z0 + sum_j dz_j.
 *    In this form the symplecticity condition reads mu_ij + mu_ji = 1, which the floating-point
 *    mu satisfy exactly (see gauss_tableau).
 *  - Fixed-point iteration, started from the collocation polynomial of the previous step
 *    extrapolated to the new stage times (GNI VIII.6.1), until the increment Delta of the stages
 *    is 0 or stops decreasing, Delta >= Delta_old (GNI VIII.6): i.e. until round-off, at most
 *    LAG_GAUSS_MAX_ITERATIONS sweeps.  Stopping earlier, at Delta <= eps, would save 12-15% of
 *    the sweeps but leaves a biased iteration error that drifts the energy linearly.
 *  - z is accumulated with compensated summation (GNI VIII.5).  Measured on a pendulum,
 *    s = 6, h = 0.05 (h omega = 0.19), 10^6 steps: the relative energy error stays below 2e-14
 *    without growing; with rounded a_ij instead of mu, or with the earlier stop, it grows
 *    linearly to 1e-12 ... 7e-12.
 * Steps end at t0 + n*step; the last one is shortened to end exactly at t_end.
 * Dense output: the collocation polynomial of the last step,
 * u(t_old + theta h) = z_old + sum_j (int_0^theta l_j / b_j) dz_j, of degree s (error O(h^(s+1))
 * inside the step, the method's own at its ends), converted to (q, q').
 * Stats: rhs_evals counts lag_hamilton_rhs calls, newton_iters the fixed-point sweeps.
 */

#define LAG_INTEGRATOR_NAME "gauss"
#define LAG_GAUSS_MAX_STAGES 6
#define LAG_GAUSS_MAX_ITERATIONS 100
/* A sweep that no longer decreases the increment has reached the round-off of F if the increment
 * is below this many ulp (the scaled increment's noise is about cond(M) h|F|/|z| ulp for a mass
 * matrix M); above, it is not trusted as converged and the iteration goes on. */
#define LAG_GAUSS_NOISE 65536

/* Work counters, printed by the run summary (a fixed step has no rejections to count). */
typedef struct lag_stats {
    long accepted, rhs_evals, newton_iters;
} lag_stats;

typedef struct lag_stepper {
    LAG_STEPPER_PUBLIC(lag_stats)  /* t, t_old, y, h and stats, which the driver reads (runtime.h) */
    const lag_system *sys;
    int stages;
    real c[LAG_GAUSS_MAX_STAGES], b[LAG_GAUSS_MAX_STAGES];
    real mu[LAG_GAUSS_MAX_STAGES][LAG_GAUSS_MAX_STAGES];   /* a_ij / b_j, mu_ij + mu_ji = 1 exactly */
    real t0, t_end, step;
    long steps;        /* number of steps from t0 to t_end, the last one possibly shorter */
    real z[LAG_NY];                  /* canonical state at t */
    real z_error[LAG_NY];            /* compensated summation: the part of z lost to rounding */
    real z_old[LAG_NY];              /* canonical state at t_old */
    real h_done;                     /* length of the last step */
    real dz[LAG_GAUSS_MAX_STAGES][LAG_NY];      /* h b_j F_j of the last step: its polynomial */
    real dz_new[LAG_GAUSS_MAX_STAGES][LAG_NY];  /* ... of the step being solved */
    real stage[LAG_GAUSS_MAX_STAGES][LAG_NY];   /* the increments Z_i being iterated */
    /* Z_i^0 = sum_j predict[i][j] dz_j for a step predict_ratio times as long as the last */
    real predict[LAG_GAUSS_MAX_STAGES][LAG_GAUSS_MAX_STAGES];
    real predict_ratio;
} lag_stepper;

/* P_s(x) and P_s'(x) by the three-term recurrence (k+1) P_{k+1} = (2k+1) x P_k - k P_{k-1}. */
static void gauss_legendre(int s, real x, real *p, real *dp)
{
    real p_prev = 1, p_cur = x;
    int k;
    for (k = 1; k < s; ++k) {
        real p_next = ((2 * k + 1) * x * p_cur - k * p_prev) / (k + 1);
        p_prev = p_cur;
        p_cur = p_next;
    }
    *p = p_cur;
    *dp = s * (x * p_cur - p_prev) / ((x - 1) * (x + 1));
}

/* Nodes and weights of the Gauss rule on [0, 1].  Only the roots x > 0 of P_s are computed, the
 * others by symmetry, so the nodes are symmetric about 1/2 to the last bit; 1 - x is exact for
 * x in [1/2, 1], which keeps the small nodes accurate. */
static void gauss_nodes(lag_stepper *s)
{
    const real pi = 4 * r_atan(1);
    int n = s->stages, i;
    for (i = 0; i < n / 2; ++i) {
        real x = r_cos(pi * (i + LAG_LIT(0.75)) / (n + LAG_LIT(0.5))), p, dp, dx;
        int iteration;
        for (iteration = 0; iteration < LAG_GAUSS_MAX_ITERATIONS; ++iteration) {
            gauss_legendre(n, x, &p, &dp);
            dx = p / dp;
            x -= dx;
            if (r_fabs(dx) <= REAL_EPSILON)
                break;      /* quadratic convergence: this last correction left x exact to round-off */
        }
        gauss_legendre(n, x, &p, &dp);
        s->c[i] = (1 - x) / 2;
        s->c[n - 1 - i] = (1 + x) / 2;
        s->b[i] = s->b[n - 1 - i] = 1 / ((1 - x) * (1 + x) * dp * dp);
    }
    if (n % 2 == 1) {
        real p, dp;
        gauss_legendre(n, 0, &p, &dp);
        s->c[n / 2] = LAG_LIT(0.5);
        s->b[n / 2] = 1 / (dp * dp);
    }
}

/* l_j(x) = prod_{m != j} (x - c_m) / (c_j - c_m), in product form: accurate at every x. */
static real gauss_lagrange(const lag_stepper *s, int j, real x)
{
    real l = 1;
    int m;
    for (m = 0; m < s->stages; ++m)
        if (m != j)
            l *= (x - s->c[m]) / (s->c[j] - s->c[m]);
    return l;
}

/* int_0^theta l_j(sigma) d sigma, by the Gauss rule on [0, theta] (exact for this polynomial). */
static real gauss_integrated_basis(const lag_stepper *s, int j, real theta)
{
    real sum = 0;
    int m;
    for (m = 0; m < s->stages; ++m)
        sum += s->b[m] * gauss_lagrange(s, j, theta * s->c[m]);
    return theta * sum;
}

/* The starting values of a step `ratio` times as long as the last one: the last collocation
 * polynomial z_old + sum_j (int_0^theta l_j / b_j) dz_j at the new stage times,
 * theta = 1 + ratio c_i, minus its value at theta = 1. */
static void gauss_predictor(lag_stepper *s, real ratio)
{
    int i, j;
    for (i = 0; i < s->stages; ++i)
        for (j = 0; j < s->stages; ++j)
            s->predict[i][j] = gauss_integrated_basis(s, j, 1 + ratio * s->c[i]) / s->b[j] - 1;
    s->predict_ratio = ratio;
}

/* mu_ij = a_ij / b_j with a_ij = int_0^{c_i} l_j.  The method is symplectic because
 * b_i a_ij + b_j a_ji = b_i b_j, i.e. mu_ij + mu_ji = 1 (so mu_ii = 1/2): the floating-point mu
 * keep that exactly (mu_ij lies in [1/2, 2] for i > j, so 1 - mu_ij is exact), and so does the
 * method the program actually runs.  Rounded a_ij would not, and their defect shows as a linear
 * drift of the energy, ~ eps per step, over 10^5 steps and more (Hairer, McLachlan, Razakarivony,
 * BIT 48 (2008); Antonana, Makazaga, Murua, arXiv:1702.03354, use the same mu). */
static void gauss_tableau(lag_stepper *s)
{
    int i, j;
    gauss_nodes(s);
    for (i = 0; i < s->stages; ++i) {
        for (j = 0; j < i; ++j) {
            s->mu[i][j] = gauss_integrated_basis(s, j, s->c[i]) / s->b[j];
            s->mu[j][i] = 1 - s->mu[i][j];
        }
        s->mu[i][i] = LAG_LIT(0.5);
    }
    gauss_predictor(s, 1);
}

/* dz = weight F(t, z).  A non-finite derivative inside the iteration means it diverged. */
static int gauss_rhs(lag_stepper *s, real t, const real *z, real weight, real *dz)
{
    real dzdt[LAG_NY];
    int i, status = lag_hamilton_rhs(s->sys, t, z, dzdt);
    ++s->stats.rhs_evals;
    if (status != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i) {
        if (!r_isfinite(dzdt[i]))
            return LAG_ERR_NO_CONVERGENCE;
        dz[i] = weight * dzdt[i];
    }
    return LAG_OK;
}

/* One fixed-point sweep dz_j = h b_j F(t + c_j h, z + Z_j), Z_i <- sum_j mu_ij dz_j.  *delta is
 * the largest change of a Z_i relative to the size |z| + max_j(|dz_j|, |Z_j|) of its component:
 * the scale of its rounding errors, so that delta reaches about one ulp at convergence. */
static int gauss_sweep(lag_stepper *s, real h, real *delta)
{
    real point[LAG_NY], scale[LAG_NY];
    int i, j, n = s->stages, status;
    for (i = 0; i < n; ++i) {
        for (j = 0; j < LAG_NY; ++j)
            point[j] = s->z[j] + s->stage[i][j];
        if ((status = gauss_rhs(s, s->t + s->c[i] * h, point, h * s->b[i], s->dz_new[i])) != LAG_OK)
            return status;
    }
    for (j = 0; j < LAG_NY; ++j) {
        scale[j] = 0;
        for (i = 0; i < n; ++i)
            scale[j] = r_fmax(scale[j], r_fmax(r_fabs(s->dz_new[i][j]), r_fabs(s->stage[i][j])));
        scale[j] += r_fabs(s->z[j]);
    }
    *delta = 0;
    for (i = 0; i < n; ++i)
        for (j = 0; j < LAG_NY; ++j) {
            real next = 0, change;
            int m;
            for (m = 0; m < n; ++m)
                next += s->mu[i][m] * s->dz_new[m][j];
            change = r_fabs(next - s->stage[i][j]);
            if (change > 0)
                *delta = r_fmax(*delta, change / scale[j]);
            s->stage[i][j] = next;
        }
    return LAG_OK;
}

/* Starting values of the increments Z_i for a step of length h: the extrapolated collocation
 * polynomial of the last step, or zero for the first (whose first sweep then gives Z_i = c_i h F). */
static void gauss_start(lag_stepper *s, real h)
{
    int i, j, m;
    if (s->stats.accepted == 0) {
        memset(s->stage, 0, sizeof s->stage);
        return;
    }
    if (h != s->predict_ratio * s->h_done)
        gauss_predictor(s, h / s->h_done);
    for (i = 0; i < s->stages; ++i)
        for (j = 0; j < LAG_NY; ++j) {
            real start = 0;
            for (m = 0; m < s->stages; ++m)
                start += s->predict[i][m] * s->dz[m][j];
            s->stage[i][j] = start;
        }
}

/* Solve the stage equations of a step of length h from (t, z) into dz_new. */
static int gauss_solve_stages(lag_stepper *s, real h)
{
    real delta, delta_old = REAL_MAX;
    int iteration, status;
    gauss_start(s, h);
    for (iteration = 1; iteration <= LAG_GAUSS_MAX_ITERATIONS; ++iteration) {
        ++s->stats.newton_iters;
        if ((status = gauss_sweep(s, h, &delta)) != LAG_OK)
            return status;
        if (!(delta <= REAL_MAX))
            return LAG_ERR_NO_CONVERGENCE;
        if (delta == 0 || (delta >= delta_old && delta_old <= LAG_GAUSS_NOISE * REAL_EPSILON))
            return LAG_OK;
        delta_old = delta;
    }
    return LAG_ERR_NO_CONVERGENCE;
}

static int lag_stepper_init(lag_stepper *s, const lag_system *sys, real t0, const real *y0,
                            real t_end, const lag_options *opt)
{
    memset(s, 0, sizeof *s);
    s->sys = sys;
    s->t = s->t_old = s->t0 = t0;
    s->t_end = t_end;
    s->h = s->step = opt->step;
    s->stages = opt->stages;
    memcpy(s->y, y0, sizeof s->y);
    if (!(opt->step >= LAG_MIN_STEP_EPS * REAL_EPSILON * r_fmax(r_fabs(t0), r_fabs(t_end))) || !(opt->step > 0))
        return LAG_ERR_STEP_TOO_SMALL;     /* below the resolution of t, steps would not advance it */
    if (s->stages < 1 || s->stages > LAG_GAUSS_MAX_STAGES)
        return LAG_ERR_NO_CONVERGENCE;   /* no status fits better; the front end checks 1..6 */
    gauss_tableau(s);
    if ((s->steps = lag_step_count(t0, t_end, opt->step, opt->max_steps)) < 0)
        return LAG_ERR_MAX_STEPS;      /* known before the first step: the step is too small */
    if (s->steps == 1)
        s->h = t_end - t0;
    return lag_to_canonical(sys, t0, s->y, s->z);
}

/* z_new = z + sum_j dz_j with compensated summation (GNI VIII.5, Kahan): the increment plus the
 * rounding error carried from the last step is added, and what this addition loses is kept. */
static void gauss_update(const lag_stepper *s, real *z_new, real *z_error)
{
    int i, j;
    for (j = 0; j < LAG_NY; ++j) {
        real increment = s->z_error[j];
        for (i = 0; i < s->stages; ++i)
            increment += s->dz_new[i][j];
        z_new[j] = s->z[j] + increment;
        z_error[j] = (s->z[j] - z_new[j]) + increment;
    }
}

static int lag_stepper_step(lag_stepper *s)
{
    real z_new[LAG_NY], z_error[LAG_NY], y_new[LAG_NY], t_new, h;
    long n = s->stats.accepted + 1;
    int i, status;
    if (n > s->steps)
        return LAG_OK;
    /* times from t0 rather than by accumulation, so the grid does not drift; the nominal step
     * (not t_new - t, which varies in the last bit) keeps the starting values' ratio at 1 */
    t_new = n == s->steps ? s->t_end : s->t0 + n * s->step;
    h = n == s->steps ? s->t_end - s->t : s->step;
    if ((status = gauss_solve_stages(s, h)) != LAG_OK)
        return status;
    gauss_update(s, z_new, z_error);
    for (i = 0; i < LAG_NY; ++i)
        if (!r_isfinite(z_new[i]))
            return LAG_ERR_NONFINITE;
    if ((status = lag_from_canonical(s->sys, t_new, z_new, y_new)) != LAG_OK)
        return status;
    memcpy(s->z_old, s->z, sizeof s->z_old);
    memcpy(s->z, z_new, sizeof s->z);
    memcpy(s->z_error, z_error, sizeof s->z_error);
    memcpy(s->dz, s->dz_new, sizeof s->dz);
    memcpy(s->y, y_new, sizeof s->y);
    s->t_old = s->t;
    s->t = t_new;
    s->h_done = h;
    s->h = n + 1 == s->steps ? s->t_end - t_new : s->step;
    ++s->stats.accepted;
    return LAG_OK;
}

/* Valid on [t_old, t] once a step has been taken.  The interface gives dense output no status:
 * a mass matrix singular inside the step would already have stopped its stage evaluations. */
static int lag_stepper_dense(lag_stepper *s, real t, real *yout)
{
    real theta = (t - s->t_old) / s->h_done, weight[LAG_GAUSS_MAX_STAGES], z[LAG_NY];
    int i, j;
    for (i = 0; i < s->stages; ++i)
        weight[i] = gauss_integrated_basis(s, i, theta) / s->b[i];
    for (j = 0; j < LAG_NY; ++j) {
        z[j] = s->z_old[j];
        for (i = 0; i < s->stages; ++i)
            z[j] += weight[i] * s->dz[i][j];
    }
    return lag_from_canonical(s->sys, t, z, yout);
}

/* The driver moved y (projection onto the constraints): the canonical state restarts from it,
 * without the rounding error carried for the old one.  The starting values of the next step
 * (increments, not states) stay valid. */
static int lag_stepper_restart(lag_stepper *s)
{
    memset(s->z_error, 0, sizeof s->z_error);
    return lag_to_canonical(s->sys, s->t, s->y, s->z);
}
