/* Shared by the fixed-step methods (rk4, gauss): how many steps of a given size cover [t0, t_end].
 * Pasted before the integrator file. */

/* The number of steps: (t_end - t0) / step rounded up, except that an excess below the rounding
 * error of the times themselves is not a step (10 / 0.01 gives 1000 steps, not 1001). */
static long lag_step_count(real t0, real t_end, real step)
{
    real ratio = (t_end - t0) / step;
    real slack = 8 * REAL_EPSILON * (r_fabs(t0) + r_fabs(t_end)) / step;
    real whole = r_floor(ratio);
    if (!(ratio > 0))
        return 0;
    return (long)whole + (ratio - whole > slack);
}
