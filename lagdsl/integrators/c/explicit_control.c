/* Step-size control shared by the embedded explicit Runge-Kutta pairs dopri5.c and dop853.c.
 *
 * Pasted once, after the model and before dopri5.c or dop853.c (rk4.c does not use it).
 *
 * - Error norm: the root mean square of e_i / (atol + rtol max(|y0_i|, |y1_i|)),
 *   Hairer-Norsett-Wanner I (HNW I), Section II.4, (4.11); a step is accepted when err <= 1.
 * - New step size: h_new = h * min(facmax, max(facmin, safety err^-alpha err_old^beta)),
 *   HNW I, II.4, (4.13), with the PI ("Lund-stabilised") factor err_old^beta of Gustafsson
 *   (Hairer-Wanner II, Section IV.2) as in Hairer's DOPRI5 code; beta = 0 is the classical
 *   controller.  After a rejection the step size may not grow until a step is accepted.
 * - Starting step size: the algorithm of HNW I, II.4 ("Starting Step Size"), which costs one
 *   right-hand side evaluation.
 * Integration runs forward only (t_end > t0), as the driver does.
 */

/* Work counters of dopri5 and dop853, printed by the run summary. */
typedef struct lag_stats {
    long accepted, rejected, rhs_evals;
} lag_stats;

typedef struct lag_control {
    real rtol, atol;
    real t_end;      /* no step goes past it; the last one lands on it exactly */
    real span;       /* t_end - t0, the scale of the smallest step (LAG_MIN_STEP) */
    real hmax;
    long max_steps;  /* accepted + rejected trials allowed, 0 = no limit */
    real alpha, beta, facmin, facmax;  /* the method's controller constants */
    real err_old;    /* error of the last accepted step, for the PI factor */
    int rejected;    /* the last trial was rejected */
} lag_control;

static const real lag_control_safety = LAG_LIT(0.9);

static void lag_control_init(lag_control *c, const lag_options *opt, real t0, real t_end,
                             real alpha, real beta, real facmin, real facmax)
{
    c->rtol = opt->rtol;
    c->atol = opt->atol;
    c->t_end = t_end;
    c->span = t_end - t0;
    c->hmax = opt->max_step > 0 ? opt->max_step : t_end - t0;
    c->max_steps = opt->max_steps;
    c->alpha = alpha;
    c->beta = beta;
    c->facmin = facmin;
    c->facmax = facmax;
    c->err_old = LAG_LIT(1e-4);
    c->rejected = 0;
}

/* Every right-hand side evaluation goes through here, so that rhs_evals is exact. */
static int lag_control_rhs(const lag_system *sys, lag_stats *stats, real t, const real *y, real *f)
{
    ++stats->rhs_evals;
    return lag_rhs(sys, t, y, f);
}

/* The scale of component i in the error norm (4.11). */
static real lag_control_scale(const lag_control *c, real y0, real y1)
{
    return c->atol + c->rtol * r_fmax(r_fabs(y0), r_fabs(y1));
}

/* The first step: opt->step if given, else HNW I, II.4, steps (a)-(f).  `order` is the exponent
 * of h in the local error estimate (5 for DOPRI5, 8 for DOP853).  f = f(t, y). */
static real lag_control_first_step(const lag_control *c, const lag_options *opt, const lag_system *sys,
                                   lag_stats *stats, real t, const real *y, const real *f, int order)
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
                                : r_pow(LAG_LIT(0.01) / dmax, (real)1 / order);
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
    fac = lag_control_safety * r_pow(err, -c->alpha);
    if (err > 1) {
        ++stats->rejected;
        c->rejected = 1;
        *h_next = h * r_fmax(c->facmin, fac);
        return 0;
    }
    fac = r_fmin(c->facmax, r_fmax(c->facmin, fac * r_pow(c->err_old, c->beta)));
    if (c->rejected)
        fac = r_fmin(fac, 1);
    *h_next = r_fmin(h * fac, c->hmax);
    c->err_old = r_fmax(err, LAG_LIT(1e-4));
    c->rejected = 0;
    ++stats->accepted;
    return 1;
}
