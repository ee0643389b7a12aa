/* auto: dop853 while the problem is not stiff, radau5 while it is, switching both ways during
 * the run, in the spirit of Petzold's LSODA (which switches between Adams and BDF methods).
 *
 * Pasted after dop853.c and radau5.c, whose interfaces are renamed dop853_stepper... and
 * radau5_stepper... (lagdsl.integrators.integrator_source), so that both live in one file.
 *
 * To radau5: when the stiffness test of dop853 (stiffness_test.c) gives the verdict stiff: a fast
 * mode holds its steps at the stability boundary, and it is damped or not excited, so that an
 * L-stable method may step over it.  A fast oscillation excited above the tolerance (the other
 * verdict) must be resolved by either method, and dop853 resolves it with fewer right-hand
 * sides: auto stays with dop853 there.  radau5 starts from dop853's last step size, which
 * stability had limited, and soon enlarges it.
 * Back to dop853, either of:
 * - measured work: after LAG_STIFF_STEPS trials of radau5, its mean step is not LAG_AUTO_GAIN
 *   times dop853's mean step over the steps that made the verdict: radau5 does not pay;
 * - the stiffness has faded: radau5's accepted steps lie well inside dop853's stability region,
 *   h rho <= LAG_AUTO_CALM (half its boundary) with rho the spectral radius of J = df/dy, on
 *   LAG_STIFF_STEPS accepted steps in a row: dop853 could then take radau5's steps without being
 *   limited by stability, at less cost per step.  rho is estimated by power iteration on J^2
 *   (lag_power_step, one step per accepted step of radau5, continued from the previous v; two
 *   evaluations of f).
 * Hysteresis: after each return to dop853, its stiffness verdict is heeded only after twice as
 * many accepted steps as the time before (30, 60, ...), so that a problem at the border between
 * the two switches O(log(steps)) times, not once per verdict.
 *
 * Each switch restarts the other method at the current (t, y), as if a new integration began
 * there.  The dense output stays that of the method that took the last step, so output rows
 * inside the step of a switch are interpolated as usual.  The statistics are the sums over
 * both methods; `switches` records how many switches, the times of the first LAG_AUTO_LOGGED,
 * and the span of t each method covered.
 */

#define LAG_INTEGRATOR_NAME "auto"

enum lag_auto_method { LAG_AUTO_EXPLICIT, LAG_AUTO_IMPLICIT };

/* The counters of both methods together. */
typedef struct lag_stats {
    long accepted, rejected, rhs_evals, jac_evals, lu_decomps, newton_iters;
} lag_stats;

typedef struct lag_switches {
    long count;
    real at[LAG_AUTO_LOGGED];      /* times of the first switches; even entries are to radau5 */
    real span[2];                  /* t covered by dop853 and by radau5 */
} lag_switches;

typedef struct lag_stepper {
    LAG_STEPPER_PUBLIC(lag_stats)  /* t, t_old, y, h and stats, which the driver reads (runtime.h) */
    lag_switches switches;
    const lag_system *sys;
    real t_end;
    lag_options options;
    int method;                    /* the method that takes the next step */
    int last;                      /* the method that took the last step (its dense output) */
    lag_stats finished;            /* counters of the methods' earlier runs */
    int calm_steps;                /* radau5 steps in a row with h rho <= LAG_AUTO_CALM */
    int measured;                  /* radau5's work since the last switch was judged */
    real switched_at;              /* t of the last switch to radau5 ... */
    real explicit_step;            /* ... and dop853's mean step over the steps of its verdict */
    long patience;                 /* dop853 steps before its stiffness verdict is heeded */
    real v[LAG_NY];                /* power iteration vector for rho(J)^2 */
    real jv[LAG_NY];
    dop853_stepper explicit_method;
    radau5_stepper implicit_method;
} lag_stepper;

static void auto_add_explicit(lag_stats *sum, const dop853_stats *part)
{
    sum->accepted += part->accepted;
    sum->rejected += part->rejected;
    sum->rhs_evals += part->rhs_evals;
}

static void auto_add_implicit(lag_stats *sum, const radau5_stats *part)
{
    sum->accepted += part->accepted;
    sum->rejected += part->rejected;
    sum->rhs_evals += part->rhs_evals;
    sum->jac_evals += part->jac_evals;
    sum->lu_decomps += part->lu_decomps;
    sum->newton_iters += part->newton_iters;
}

/* The public fields from the method that took the last step, the counters of both. */
static void auto_sync(lag_stepper *s)
{
    if (s->last == LAG_AUTO_EXPLICIT) {
        s->t = s->explicit_method.t;
        s->t_old = s->explicit_method.t_old;
        memcpy(s->y, s->explicit_method.y, sizeof s->y);
    } else {
        s->t = s->implicit_method.t;
        s->t_old = s->implicit_method.t_old;
        memcpy(s->y, s->implicit_method.y, sizeof s->y);
    }
    s->h = s->method == LAG_AUTO_EXPLICIT ? s->explicit_method.h : s->implicit_method.h;
    s->stats = s->finished;
    auto_add_explicit(&s->stats, &s->explicit_method.stats);
    auto_add_implicit(&s->stats, &s->implicit_method.stats);
}

/* Start `method` at (s->t, s->y) with the first step h0, within what is left of max_steps. */
static int auto_start(lag_stepper *s, int method, real h0)
{
    lag_options options = s->options;
    long used = s->stats.accepted + s->stats.rejected;
    options.step = h0;
    if (options.max_steps > 0)
        options.max_steps = options.max_steps > used ? options.max_steps - used : 1;
    s->method = method;
    if (method == LAG_AUTO_EXPLICIT) {
        auto_add_explicit(&s->finished, &s->explicit_method.stats);
        return dop853_stepper_init(&s->explicit_method, s->sys, s->t, s->y, s->t_end, &options);
    }
    auto_add_implicit(&s->finished, &s->implicit_method.stats);
    s->calm_steps = 0;
    return radau5_stepper_init(&s->implicit_method, s->sys, s->t, s->y, s->t_end, &options);
}

static int auto_switch(lag_stepper *s, int method, real h0)
{
    int status;
    if (s->switches.count < LAG_AUTO_LOGGED)
        s->switches.at[s->switches.count] = s->t;
    s->switches.count += 1;
    status = auto_start(s, method, h0);
    auto_sync(s);
    return status;
}

/* rho(J)^2 at radau5's (t, y) from one step of power iteration on J^2 (lag_power_step); f(t, y)
 * is left to radau5 as the start of its next step.  0 when nothing was learnt, and the iteration
 * starts afresh. */
static real auto_spectral_radius_squared(lag_stepper *s)
{
    radau5_stepper *r = &s->implicit_method;
    real rho2;
    int i;
    if (!r->have_f0) {
        if (lag_rhs(s->sys, r->t, r->y, r->f0) != LAG_OK)
            return 0;
        r->stats.rhs_evals += 1;
        r->have_f0 = 1;
    }
    rho2 = lag_power_step(s->sys, &r->stats.rhs_evals, r->t, r->y, r->f0, s->v, s->jv, r->tmp);
    if (!(rho2 > 0))
        for (i = 0; i < LAG_NY; ++i)
            s->v[i] = 1;
    return rho2;
}

/* radau5 has had LAG_STIFF_STEPS trials since the switch (judged once) and its mean step is not
 * LAG_AUTO_GAIN times dop853's: it does not pay. */
static int auto_radau5_does_not_pay(lag_stepper *s)
{
    const radau5_stats *stats = &s->implicit_method.stats;
    long trials = stats->accepted + stats->rejected;
    if (s->measured || trials < LAG_STIFF_STEPS)
        return 0;
    s->measured = 1;
    return s->t - s->switched_at < LAG_AUTO_GAIN * s->explicit_step * trials;
}

/* radau5 returns to dop853 after measuring that it does not pay, or on LAG_STIFF_STEPS steps in
 * a row that dop853 could take as well. */
static int auto_back_to_dop853(lag_stepper *s)
{
    real h_rho;
    if (auto_radau5_does_not_pay(s))
        return 1;
    h_rho = s->implicit_method.h_old * r_sqrt(auto_spectral_radius_squared(s));
    s->calm_steps = h_rho <= LAG_AUTO_CALM ? s->calm_steps + 1 : 0;
    return s->calm_steps >= LAG_STIFF_STEPS;
}

static int lag_stepper_init(lag_stepper *s, const lag_system *sys, real t0, const real *y0,
                            real t_end, const lag_options *opt)
{
    int i, status;
    memset(s, 0, sizeof *s);
    s->sys = sys;
    s->t = s->t_old = t0;
    s->t_end = t_end;
    s->options = *opt;
    memcpy(s->y, y0, sizeof s->y);
    for (i = 0; i < LAG_NY; ++i)
        s->v[i] = 1;
    s->last = LAG_AUTO_EXPLICIT;
    status = auto_start(s, LAG_AUTO_EXPLICIT, opt->step);
    auto_sync(s);
    return status;
}

static int lag_stepper_step(lag_stepper *s)
{
    const dop853_stats *verdict = &s->explicit_method.stats;
    real t = s->t;
    int status;
    if (s->method == LAG_AUTO_EXPLICIT) {
        status = dop853_stepper_step(&s->explicit_method);
        s->last = LAG_AUTO_EXPLICIT;
        auto_sync(s);
        s->switches.span[LAG_AUTO_EXPLICIT] += s->t - t;
        if (status == LAG_OK && verdict->stiff == LAG_VERDICT_STIFF && verdict->accepted >= s->patience
            && s->t < s->t_end) {
            s->measured = 0;
            s->switched_at = s->t;
            s->explicit_step = verdict->stiff_step;
            status = auto_switch(s, LAG_AUTO_IMPLICIT, s->explicit_method.h);
        }
        return status;
    }
    status = radau5_stepper_step(&s->implicit_method);
    s->last = LAG_AUTO_IMPLICIT;
    auto_sync(s);
    s->switches.span[LAG_AUTO_IMPLICIT] += s->t - t;
    if (status != LAG_OK || !(s->t < s->t_end))
        return status;
    if (auto_back_to_dop853(s)) {
        s->patience = s->patience > 0 ? 2 * s->patience : 2 * LAG_STIFF_STEPS;
        status = auto_switch(s, LAG_AUTO_EXPLICIT, s->implicit_method.h_old);
    }
    return status;
}

static int lag_stepper_dense(lag_stepper *s, real t, real *yout)
{
    int status;
    if (s->last == LAG_AUTO_IMPLICIT)
        return radau5_stepper_dense(&s->implicit_method, t, yout);
    /* dop853 may spend its dense-output stages now: count them */
    status = dop853_stepper_dense(&s->explicit_method, t, yout);
    auto_sync(s);
    return status;
}

/* The driver moved y: hand it to the method that continues and, after a switch, to the one
 * whose dense output covers the last step. */
static int lag_stepper_restart(lag_stepper *s)
{
    int status = LAG_OK;
    if (s->method == LAG_AUTO_EXPLICIT || s->last == LAG_AUTO_EXPLICIT) {
        memcpy(s->explicit_method.y, s->y, sizeof s->y);
        status = dop853_stepper_restart(&s->explicit_method);
    }
    if (status == LAG_OK && (s->method == LAG_AUTO_IMPLICIT || s->last == LAG_AUTO_IMPLICIT)) {
        memcpy(s->implicit_method.y, s->y, sizeof s->y);
        status = radau5_stepper_restart(&s->implicit_method);
    }
    auto_sync(s);
    return status;
}
