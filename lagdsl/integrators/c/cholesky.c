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
