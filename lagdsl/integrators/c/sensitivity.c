/* The forward sensitivities' entry point: the augmented system of templates/c/sensitivity.c.j2
 * integrated by the scene's integrator (its lag_aug_ copy) over given output times.
 *
 * Pasted last, after the augmented integrator, in a program generated for sensitivities
 * (lagdsl/codegen/c_sensitivity.py); from driver.c it reads lag_step_limit and lag_interrupt, from
 * the template lag_sensitivity_options.
 * The state is not projected onto the constraints during the run (a projection would need its
 * derivative applied to S at every step): the index-1 equations keep to them up to the
 * integration's error, as on the NumPy backend, and the caller reports the residual.
 */

long lag_sensitivity_workspace(void);
int lag_sensitivity_run(const double *parameters, const double *directions, const double *initial,
                        const double *settings, const double *times, long rows, double *values, double *summary,
                        void *workspace);

/* The bytes of the workspace lag_sensitivity_run needs: its stepper, large (radau5's matrices of
 * the augmented system), which the caller allocates, zeroed and aligned as a real. */
long lag_sensitivity_workspace(void)
{
    return (long)sizeof(lag_aug_stepper);
}

/* The atol of each component of the augmented state: the state's own from the settings (after
 * their LAG_SETTINGS entries, the LAG_NY of y = (q, q')), `atol` for every sensitivity, as on the
 * NumPy backend (a sensitivity has the state's unit over the direction's, not the state's). */
static void lag_sensitivity_atol(const double *settings, real atol, double *atol_each)
{
    int i;
    for (i = 0; i < LAG_AUG_NQ; ++i) {
        atol_each[i] = i < LAG_NQ ? settings[LAG_SETTINGS + i] : (double)atol;
        atol_each[LAG_AUG_NQ + i] = i < LAG_NQ ? settings[LAG_SETTINGS + LAG_NQ + i] : (double)atol;
    }
}

/* Integrate from Y(t0) = `initial` (LAG_AUG_NY: Q then Q') with `parameters` (LAG_NP) and
 * J = `directions` (LAG_NP x LAG_NS, row-major), on the options of `settings` (lagdsl.abi.SETTINGS,
 * then the atol of each component of y; its grid is ignored), to the `rows` increasing times `times` (times[0] >= t0 = the settings'
 * start); Y at each goes to values[k * LAG_AUG_NY ...]. The summary (LAG_SENSITIVITY_SUMMARY
 * doubles) receives the status, the rows delivered, the time reached, the work counters and, on
 * failure, Y there. Returns the status. */
int lag_sensitivity_run(const double *parameters, const double *directions, const double *initial,
                        const double *settings, const double *times, long rows, double *values, double *summary,
                        void *workspace)
{
    lag_aug_system aug;
    lag_options options;
    lag_aug_stepper *stepper = workspace;
    real Y[LAG_AUG_NY], t0 = settings[LAG_SET_T_START];
    double atol_each[LAG_AUG_NY];
    long k = 0;
    int i, status;
    memset(&aug, 0, sizeof aug);
    memset(&options, 0, sizeof options);
    memset(summary, 0, sizeof(double) * LAG_SENSITIVITY_SUMMARY);
    for (i = 0; i < LAG_NP; ++i)
        aug.model.par[i] = parameters[i];
    for (i = 0; i < LAG_NP * LAG_NS; ++i)
        aug.J[i] = directions[i];
    for (i = 0; i < LAG_AUG_NY; ++i)
        Y[i] = initial[i];
    lag_system_prepare(&aug.model);
    lag_sensitivity_options(settings, &options);
    lag_sensitivity_atol(settings, options.atol, atol_each);
    options.atol_each = atol_each;
    options.max_steps = lag_step_limit(&options, t0, times[rows - 1], rows - 1);
    (void)lag_aug_stepper_restart;     /* the state is not projected, so never restarted */
    status = lag_aug_stepper_init(stepper, &aug, t0, Y, times[rows - 1], &options);
    for (k = 0; k < rows && status == LAG_OK; ++k) {
        while (stepper->t < times[k] && status == LAG_OK) {
            status = lag_aug_stepper_step(stepper);
            if (status == LAG_OK && lag_interrupt)
                status = LAG_ERR_INTERRUPTED;
        }
        if (status != LAG_OK)
            break;
        if (times[k] == stepper->t)
            memcpy(Y, stepper->y, sizeof Y);
        else if ((status = lag_aug_stepper_dense(stepper, times[k], Y)) != LAG_OK)
            break;
        for (i = 0; i < LAG_AUG_NY; ++i)
            values[k * LAG_AUG_NY + i] = (double)Y[i];
    }
    summary[LAG_SENSITIVITY_STATUS] = status;
    summary[LAG_SENSITIVITY_ROWS] = (double)k;
    summary[LAG_SENSITIVITY_T_REACHED] = (double)stepper->t;
    summary[LAG_SENSITIVITY_ACCEPTED] = (double)stepper->stats.accepted;
    summary[LAG_SENSITIVITY_REJECTED] = (double)stepper->stats.rejected;
    summary[LAG_SENSITIVITY_RHS_EVALS] = (double)stepper->stats.rhs_evals;
    for (i = 0; i < LAG_AUG_NY; ++i)
        summary[LAG_SENSITIVITY_Y_REACHED + i] = (double)stepper->y[i];
    return status;
}
