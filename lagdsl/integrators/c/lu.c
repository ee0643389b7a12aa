/* LU factorisation with partial pivoting, row-major, in place: for a general Lagrangian's
 * mass matrix, the saddle-point matrix [[M, -A^T], [A, 0]] of a constrained system, the
 * projection onto the constraints and the Newton matrices of implicit integrators.
 * Golub & Van Loan, Matrix Computations, 4th ed., algorithm 3.4.1.
 */

/* P A = L U with partial pivoting; L (unit diagonal) and U overwrite a, piv[k] is the row
 * swapped with row k.  Returns 0, or k+1 when column k has no nonzero pivot. */
static int lag_lu_factor(int n, real *a, int *piv)
{
    int i, j, k;
    for (k = 0; k < n; ++k) {
        int p = k;
        real big = r_fabs(a[k * n + k]);
        for (i = k + 1; i < n; ++i)
            if (r_fabs(a[i * n + k]) > big) {
                big = r_fabs(a[i * n + k]);
                p = i;
            }
        piv[k] = p;
        if (!(big > 0))
            return k + 1;
        if (p != k)
            for (j = 0; j < n; ++j) {
                real tmp = a[k * n + j];
                a[k * n + j] = a[p * n + j];
                a[p * n + j] = tmp;
            }
        for (i = k + 1; i < n; ++i) {
            real m = a[i * n + k] / a[k * n + k];
            a[i * n + k] = m;
            if (m != 0)
                for (j = k + 1; j < n; ++j)
                    a[i * n + j] -= m * a[k * n + j];
        }
    }
    return 0;
}

/* Solve A x = b with the factors from lag_lu_factor; x overwrites b. */
static void lag_lu_solve(int n, const real *lu, const int *piv, real *b)
{
    int i, k;
    for (k = 0; k < n; ++k)
        if (piv[k] != k) {
            real tmp = b[k];
            b[k] = b[piv[k]];
            b[piv[k]] = tmp;
        }
    for (i = 1; i < n; ++i) {
        real s = b[i];
        for (k = 0; k < i; ++k)
            s -= lu[i * n + k] * b[k];
        b[i] = s;
    }
    for (i = n - 1; i >= 0; --i) {
        real s = b[i];
        for (k = i + 1; k < n; ++k)
            s -= lu[i * n + k] * b[k];
        b[i] = s / lu[i * n + i];
    }
}
