/* The work forecast: an adaptive run stops as soon as its pace says it cannot reach its stop
 * time within its step limit, rather than when it has used the limit up. Pasted into every
 * generated C file just before the driver (driver.c), which calls lag_forecast_step after each
 * accepted step. The same rule as the NumPy backend's (lagdsl/integrators/forecast.py, which
 * says why), with the same constants (LAG_FORECAST_*, from lagdsl/settings.py).
 */

/* The forecast of an adaptive run: after n accepted steps from `start` to t, the run will take
 *     n + min(left n / |t - start|, left / h_recent)       (left = |stop - t|)
 * steps, h_recent the largest step of the last one or two windows of LAG_FORECAST_WINDOW steps.
 * Judged once a window from LAG_FORECAST_JUDGED_AFTER steps on; over `budget` (the step limit),
 * the run stops with LAG_ERR_HOPELESS long before it would use the limit up. budget 0: never. */
typedef struct lag_forecast {
    real start, stop;
    long budget, taken;
    real window_largest, previous_largest;
    real steps;                    /* the forecast when it last judged the run (0 before) */
} lag_forecast;

/* After an accepted step of size h that reached t: LAG_ERR_HOPELESS if the run can no longer
 * reach its stop within its budget, else LAG_OK. */
static int lag_forecast_step(lag_forecast *forecast, real h, real t)
{
    real recent, left, covered, by_average, by_recent;
    if (forecast->budget <= 0)
        return LAG_OK;
    forecast->taken += 1;
    forecast->window_largest = r_fmax(forecast->window_largest, r_fabs(h));
    if (forecast->taken % LAG_FORECAST_WINDOW != 0)
        return LAG_OK;
    recent = r_fmax(forecast->window_largest, forecast->previous_largest);
    forecast->previous_largest = forecast->window_largest;
    forecast->window_largest = 0;
    if (forecast->taken < LAG_FORECAST_JUDGED_AFTER)
        return LAG_OK;
    left = r_fabs(forecast->stop - t);
    covered = r_fabs(t - forecast->start);
    by_average = covered > 0 ? left * (real)forecast->taken / covered : (real)INFINITY;
    by_recent = recent > 0 ? left / recent : (real)INFINITY;
    forecast->steps = (real)forecast->taken + (by_recent < by_average ? by_recent : by_average);
    return forecast->steps > (real)forecast->budget ? LAG_ERR_HOPELESS : LAG_OK;
}
