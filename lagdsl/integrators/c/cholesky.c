/* Cholesky factorisation for the symmetric positive definite mass matrix of a natural
 * system, row-major, in place. Golub & Van Loan, Matrix Computations, 4th ed., algorithm 4.2.1.
 */

/* A = L L^T; L overwrites the lower triangle of a.  Returns 0, or k+1 when the k-th pivot is
 * not positive (A is not positive definite to working precision). */
static int lag_cholesky_factor(int n, real *a)
{
    int i, j, k;
    for (j = 0; j < n; ++j) {
        real d = a[j * n + j];
        for (k = 0; k < j; ++k)
            d -= a[j * n + k] * a[j * n + k];
        if (!(d > 0))
            return j + 1;
        d = r_sqrt(d);
        a[j * n + j] = d;
        for (i = j + 1; i < n; ++i) {
            real s = a[i * n + j];
            for (k = 0; k < j; ++k)
                s -= a[i * n + k] * a[j * n + k];
            a[i * n + j] = s / d;
        }
    }
    return 0;
}

/* Solve L L^T x = b with the factor from lag_cholesky_factor; x overwrites b. */
static void lag_cholesky_solve(int n, const real *l, real *b)
{
    int i, k;
    for (i = 0; i < n; ++i) {
        real s = b[i];
        for (k = 0; k < i; ++k)
            s -= l[i * n + k] * b[k];
        b[i] = s / l[i * n + i];
    }
    for (i = n - 1; i >= 0; --i) {
        real s = b[i];
        for (k = i + 1; k < n; ++k)
            s -= l[k * n + i] * b[k];
        b[i] = s / l[i * n + i];
    }
}

/* Reciprocal condition estimate of A = L L^T from its factor: (min_j l_jj / max_j l_jj)^2.
 * Since cond_2(A) = cond_2(L)^2 >= (max_j l_jj / min_j l_jj)^2, the estimate is never below the
 * true 1/cond_2(A): a well-conditioned A is never reported as ill-conditioned.  For A with unit
 * diagonal, l_jj^2 is the part of column j that the columns before it do not explain, so nearly
 * dependent coordinates show up as a vanishing pivot. */
static real lag_cholesky_rcond(int n, const real *l)
{
    real smallest = l[0], largest = l[0];
    int j;
    for (j = 1; j < n; ++j) {
        smallest = r_fmin(smallest, l[j * n + j]);
        largest = r_fmax(largest, l[j * n + j]);
    }
    return (smallest / largest) * (smallest / largest);
}
