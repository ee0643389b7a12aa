/* A condition estimate from the LU factors of lu.c: pasted after lu.c in the scenes that solve
 * for q'' by LU (a general Lagrangian, constraints), where a nearly singular system must be
 * caught before its solution is trusted.
 */

/* Solve A^T x = b with the factors of P A = L U (A^T = U^T L^T P); x overwrites b. */
static void lag_lu_solve_transposed(int n, const real *lu, const int *piv, real *b)
{
    int i, k;
    for (i = 0; i < n; ++i) {
        real s = b[i];
        for (k = 0; k < i; ++k)
            s -= lu[k * n + i] * b[k];
        b[i] = s / lu[i * n + i];
    }
    for (i = n - 2; i >= 0; --i) {
        real s = b[i];
        for (k = i + 1; k < n; ++k)
            s -= lu[k * n + i] * b[k];
        b[i] = s;
    }
    for (k = n - 1; k >= 0; --k)
        if (piv[k] != k) {
            real tmp = b[k];
            b[k] = b[piv[k]];
            b[piv[k]] = tmp;
        }
}

/* ||A||_1, the largest column sum of |a_ij|; taken before lag_lu_factor overwrites A. */
static real lag_norm1(int n, const real *a)
{
    real largest = 0;
    int i, j;
    for (j = 0; j < n; ++j) {
        real sum = 0;
        for (i = 0; i < n; ++i)
            sum += r_fabs(a[i * n + j]);
        largest = r_fmax(largest, sum);
    }
    return largest;
}

/* Reciprocal condition estimate 1 / (||A||_1 ||A^-1||_1) from the LU factors, ||A^-1||_1 by
 * Hager's method as refined by Higham (N. J. Higham, Accuracy and Stability of Numerical
 * Algorithms, 2nd ed., algorithm 15.4, LAPACK's xLACON): a few solves with A and A^T instead of
 * the inverse.  The estimate of ||A^-1||_1 is a lower bound (almost always within a factor 3),
 * so a well-conditioned A is never reported as ill-conditioned.  A with entries that are not
 * finite is not estimated (1 is returned): its solution is caught as non-finite instead.
 * work holds 2n reals. */
static real lag_lu_rcond(int n, const real *lu, const int *piv, real norm, real *work)
{
    real *x = work, *z = work + n, estimate = 0, alternative = 0;
    int i, j = 0, iteration;
    if (!r_isfinite(norm))
        return 1;
    for (i = 0; i < n; ++i)
        x[i] = LAG_LIT(1.0) / n;
    for (iteration = 0; iteration < 5; ++iteration) {
        real sum = 0, largest = -1, inner = 0;
        int next = 0;
        lag_lu_solve(n, lu, piv, x);                              /* x = A^-1 x */
        for (i = 0; i < n; ++i) {
            sum += r_fabs(x[i]);
            z[i] = x[i] >= 0 ? 1 : -1;
        }
        if (iteration > 0 && sum <= estimate)
            break;
        estimate = sum;
        lag_lu_solve_transposed(n, lu, piv, z);                   /* z = A^-T sign(x) */
        for (i = 0; i < n; ++i)
            if (r_fabs(z[i]) > largest) {
                largest = r_fabs(z[i]);
                next = i;
            }
        inner = z[j];
        if (iteration > 0 && largest <= inner)
            break;
        j = next;
        for (i = 0; i < n; ++i)
            x[i] = i == j ? 1 : 0;
    }
    /* Higham's safeguard against the estimator's blind spots: x_i = (-1)^i (1 + i/(n-1)). */
    for (i = 0; i < n; ++i)
        x[i] = (i % 2 ? -1 : 1) * (1 + (n > 1 ? (real)i / (n - 1) : 0));
    lag_lu_solve(n, lu, piv, x);
    for (i = 0; i < n; ++i)
        alternative += r_fabs(x[i]);
    estimate = r_fmax(estimate, 2 * alternative / (3 * n));
    return r_isfinite(estimate) && estimate > 0 ? 1 / (norm * estimate) : 0;
}
