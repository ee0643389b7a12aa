/* Shared by the fixed-step methods (rk4, gauss): how many steps of a given size cover [t0, t_end].
 * Pasted before the integrator file. */

/* The number of steps: (t_end - t0) / step rounded up, except that an excess below the rounding
 * error of the times themselves is not a step (10 / 0.01 gives 1000 steps, not 1001); -1 when
 * that is more than max_steps (0: no limit but what a long holds), so a tiny step fails at once
 * instead of running for hours. */
static long lag_step_count(real t0, real t_end, real step, long max_steps)
{
    real ratio = (t_end - t0) / step;
    real slack = 8 * REAL_EPSILON * (r_fabs(t0) + r_fabs(t_end)) / step;
    real whole = r_floor(ratio), limit = max_steps > 0 ? (real)max_steps : LAG_LIT(1e18);
    long count;
    if (!(ratio > 0))
        return 0;
    if (!(whole <= limit))
        return -1;
    count = (long)whole + (ratio - whole > slack);
    return count <= limit ? count : -1;
}
