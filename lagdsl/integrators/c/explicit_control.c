/* Step-size control shared by the embedded explicit pairs dopri5.c, dop853.c and rkn8.c.
 *
 * Pasted once, after the model and before dopri5.c, dop853.c or rkn8.c (rk4.c does not use it).
 *
 * - Error norm: the root mean square of e_i / (atol + rtol max(|y0_i|, |y1_i|)),
 *   Hairer-Norsett-Wanner I (HNW I), Section II.4, (4.11); a step is accepted when err <= 1.
 * - New step size: h_new = h * min(10, max(0.2, 0.9 err^(-1/p))), HNW I, II.4, (4.13), p being
 *   the order of the error estimate's leading term (5 for DOPRI5, 8 for DOP853, 7 for RKN8).
 *   After a rejection the step size may not grow until a step is accepted.  These are the
 *   constants of scipy's RK45 and DOP853, so that both take the same steps on a smooth
 *   problem; Hairer's codes limit the factor to [1/3, 6] (DOP853) and add a PI factor
 *   err_old^0.04 (DOPRI5), whose smaller average error per step costs about 6% more steps at
 *   tight tolerances.
 * - Starting step size: the algorithm of HNW I, II.4 ("Starting Step Size"), which costs one
 *   right-hand side evaluation.
 * Integration runs forward only (t_end > t0), as the driver does.
 */

/* Work counters of the explicit pairs, printed by the run summary; and the verdict of the
 * stiffness test of dopri5 and dop853 (lag_stiffness_record in stiffness_test.c): stiff is 0, or
 * the kind of fast mode it found (LAG_VERDICT_STIFF, LAG_VERDICT_OSCILLATION) at stiff_time,
 * with its spectral radius stiff_rate, its amplitude in tolerances, the pair's mean step over
 * the steps that made the verdict, and the counters then. */
typedef struct lag_stats {
    long accepted, rejected, rhs_evals;
    int stiff;
    real stiff_time, stiff_rate, stiff_amplitude, stiff_step;
    long stiff_accepted, stiff_rejected, stiff_rhs_evals;
} lag_stats;

typedef struct lag_control {
    real rtol, atol;
    real t_end;      /* no step goes past it; the last one lands on it exactly */
    real span;       /* t_end - t0, the scale of the smallest step (LAG_MIN_STEP) */
    real hmax;
    long max_steps;  /* accepted + rejected trials allowed, 0 = no limit */
    real exponent;   /* 1/p: err^-exponent is the step-size factor that would make err = 1 */
    int rejected;    /* the last trial was rejected */
} lag_control;

/* The members of a Dormand-Prince pair's lag_stepper (dopri5.c, dop853.c) after
 * LAG_STEPPER_PUBLIC that the code they share reads (dormand_prince.c, with the stiffness test of
 * stiffness_test.c); `terms` is the number of terms r1, r2, ... of its continuous extension. */
#define LAG_DORMAND_PRINCE_STATE(terms)                                                          \
    const lag_system *sys;                                                                       \
    lag_control control;                                                                         \
    lag_stiffness_test stiffness;                                                                \
    real h_done;                  /* size of the last accepted step */                           \
    real k1[LAG_NY];              /* f(t, y), the first stage of the next step */                \
    real k1_done[LAG_NY];         /* the first stage of the last accepted step */                \
    real dense[terms][LAG_NY];    /* r1, r2, ... of the continuous extension on [t_old, t] */    \
    int dense_built;              /* its terms past r2 are those of the last accepted step */

static const real lag_control_safety = LAG_LIT(0.9),
                  lag_control_facmin = LAG_LIT(0.2),   /* the largest decrease of h, 5x */
                  lag_control_facmax = 10;             /* the largest increase */

/* `order` is p, the power of h in the local error estimate (5 DOPRI5, 8 DOP853, 7 RKN8). */
static void lag_control_init(lag_control *c, const lag_options *opt, real t0, real t_end, int order)
{
    c->rtol = opt->rtol;
    c->atol = opt->atol;
    c->t_end = t_end;
    c->span = t_end - t0;
    c->hmax = opt->max_step > 0 ? opt->max_step : t_end - t0;
    c->max_steps = opt->max_steps;
    c->exponent = (real)1 / order;
    c->rejected = 0;
}

/* Every right-hand side evaluation goes through here, so that rhs_evals is exact. */
static int lag_control_rhs(const lag_system *sys, lag_stats *stats, real t, const real *y, real *f)
{
    ++stats->rhs_evals;
    return lag_rhs(sys, t, y, f);
}

/* The scale of component i in the error norm (4.11). max(|y0|, |y1|) is written out rather
 * than called (fmax is a libm call that GCC keeps, and the error loops would not vectorise); it
 * takes |y0| when y1 is NaN, as fmax does. */
static real lag_control_scale(const lag_control *c, real y0, real y1)
{
    real a0 = r_fabs(y0), a1 = r_fabs(y1);
    return c->atol + c->rtol * (a1 > a0 ? a1 : a0);
}

/* The sum of x_i^2 over n entries, in four interleaved partial sums: the additions of one
 * partial sum wait for each other, the four do not, so the loop runs at the adder's throughput
 * instead of its latency (one long chain of additions is what vectorising compilers may not
 * reorder). A NaN stays a NaN. */
static real lag_sum_of_squares(int n, const real *x)
{
    real partial[4] = {0, 0, 0, 0};
    int i, j;
    for (i = 0; i + 4 <= n; i += 4)
        for (j = 0; j < 4; ++j)
            partial[j] += x[i + j] * x[i + j];
    for (; i < n; ++i)
        partial[0] += x[i] * x[i];
    return (partial[0] + partial[1]) + (partial[2] + partial[3]);
}

/* The first step: opt->step if given, else HNW I, II.4, steps (a)-(f).  f = f(t, y). */
static real lag_control_first_step(const lag_control *c, const lag_options *opt, const lag_system *sys,
                                   lag_stats *stats, real t, const real *y, const real *f)
{
    real y1[LAG_NY], f1[LAG_NY];
    real d0 = 0, d1 = 0, d2 = 0, h0, h1, dmax, w;
    int i;
    if (opt->step > 0)
        return r_fmin(opt->step, c->hmax);
    for (i = 0; i < LAG_NY; ++i) {
        w = lag_control_scale(c, y[i], y[i]);
        d0 += (y[i] / w) * (y[i] / w);
        d1 += (f[i] / w) * (f[i] / w);
    }
    d0 = r_sqrt(d0 / LAG_NY);
    d1 = r_sqrt(d1 / LAG_NY);
    /* (b) the step that changes y by about 1% of its size, to probe f' by a difference */
    h0 = d0 < LAG_LIT(1e-5) || d1 < LAG_LIT(1e-5) ? LAG_LIT(1e-6) : LAG_LIT(0.01) * d0 / d1;
    h0 = r_fmin(h0, c->hmax);
    for (i = 0; i < LAG_NY; ++i)
        y1[i] = y[i] + h0 * f[i];
    if (lag_control_rhs(sys, stats, t + h0, y1, f1) != LAG_OK)
        return h0;  /* a probe outside the model's domain only loses the refinement */
    for (i = 0; i < LAG_NY; ++i) {
        w = (f1[i] - f[i]) / lag_control_scale(c, y[i], y[i]);
        d2 += w * w;
    }
    d2 = r_sqrt(d2 / LAG_NY) / h0;
    if (!r_isfinite(d2))
        return h0;
    /* (e) the step whose local error, about max(d1, d2) h^order, is 0.01 */
    dmax = r_fmax(d1, d2);
    h1 = dmax <= LAG_LIT(1e-15) ? r_fmax(LAG_LIT(1e-6), h0 * LAG_LIT(1e-3))
                                : r_pow(LAG_LIT(0.01) / dmax, c->exponent);
    return r_fmin(r_fmin(100 * h0, h1), c->hmax);
}

/* The size h of the next trial from t, given the proposal h_proposed, and its end t_new: at most
 * hmax, and stretched by up to 1% to land exactly on t_end rather than leave a sliver for later. */
static int lag_control_trial(const lag_control *c, const lag_stats *stats, real t, real h_proposed,
                             real *h, real *t_new)
{
    real hh = r_fmin(h_proposed, c->hmax);
    if (c->max_steps > 0 && stats->accepted + stats->rejected >= c->max_steps)
        return LAG_ERR_MAX_STEPS;
    if (!(hh >= LAG_MIN_STEP(t, c->span)))
        return LAG_ERR_STEP_TOO_SMALL;
    if (t + LAG_LIT(1.01) * hh >= c->t_end) {
        *h = c->t_end - t;
        *t_new = c->t_end;
    } else {
        *h = hh;
        *t_new = t + hh;
    }
    return LAG_OK;
}

/* Judge a trial of size h: status is LAG_OK unless a stage's right-hand side failed, err is the
 * scaled error.  Sets the next step size; returns 1 when the step is accepted. */
static int lag_control_update(lag_control *c, lag_stats *stats, int status, real h, real err, real *h_next)
{
    real fac;
    if (status != LAG_OK || !r_isfinite(err)) {
        /* The trial left the model's domain (singular mass matrix, overflow): its error estimate
         * says nothing about a good step size, so back off decisively. */
        ++stats->rejected;
        c->rejected = 1;
        *h_next = h / 10;
        return 0;
    }
    fac = lag_control_safety * r_pow(err, -c->exponent);
    if (err > 1) {
        ++stats->rejected;
        c->rejected = 1;
        *h_next = h * r_fmax(lag_control_facmin, fac);
        return 0;
    }
    fac = r_fmin(lag_control_facmax, r_fmax(lag_control_facmin, fac));
    if (c->rejected)
        fac = r_fmin(fac, 1);
    *h_next = r_fmin(h * fac, c->hmax);
    c->rejected = 0;
    ++stats->accepted;
    return 1;
}
