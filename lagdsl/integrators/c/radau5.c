/* radau5: the Radau IIA method with 3 stages, order 5, L-stable, for stiff problems.
 *
 * Reference: E. Hairer, G. Wanner, Solving Ordinary Differential Equations II, 2nd ed.,
 * Springer 1996, section IV.8 "Implementation of Implicit Runge-Kutta Methods"; the control
 * parameters are those of the authors' code RADAU5 described there.
 *
 * Method.  Collocation at c = ((4 - sqrt6)/10, (4 + sqrt6)/10, 1).  The stage increments
 * z_i = Y_i - y0 solve Z = h (A x I) F(Z) and y1 = y0 + z_3 (the method is stiffly accurate).
 *
 * Nonlinear system ("Simplified Newton Iterations", "The Linear System").  Simplified Newton
 * with J = df/dy at the start of a step.  A^-1 has one real eigenvalue gamma and a complex pair
 * alpha +- i beta; in W = (T^-1 x I) Z the 3n x 3n iteration matrix falls apart into the real
 * n x n matrix gamma/h I - J and the complex (alpha + i beta)/h I - J, factored once per step
 * size (the complex one in real arithmetic on (re, im) pairs).  J is kept across steps while
 * the iteration contracts fast (Theta <= 0.001), and the factors too when h hardly changes.
 * The starting values extrapolate the collocation polynomial of the previous step.  The
 * iteration stops when eta_k ||dW_k|| <= kappa Tol (8.10-8.11), eta_k = Theta_k / (1 - Theta_k)
 * from the observed contraction Theta_k (eta_0 from the previous step, damped), in the norm
 * weighted by atol' + rtol' |y0|, with kappa = max(10 eps / rtol', min(0.03, rtol'^1/2)).
 * An iteration that diverges (Theta >= 0.99) or is still running after 7 iterations halves h;
 * one predicted not to converge within 7 is stopped early and h reduced so that it would.
 * Both count as rejected steps.  A singular iteration matrix halves h as well; five in a row
 * end the integration with LAG_ERR_NO_CONVERGENCE.
 *
 * The iteration matrices of a mechanical system (as RADAU5 does for "second order" problems,
 * HNW II, IV.8, and for a mass matrix, the implicit form of the equations).  The state is
 * y = (q, v), LAG_NQ entries q with q' = the first LAG_NQ entries of v (a first-order system
 * has none), and v' = a, where z = (a, lambda) solves R(q, v, z) = 0; for a model
 * R = [f - M q'' + A^T lambda; gamma - A q''] and a = q''.  The model's lag_jacobian gives Dq,
 * Dv, Dz, the partial derivatives of R at the start of the step, in LAG_NK = dim z rows.  Then
 * J = [[0, [I 0]], [P, Q]] with the a rows of -Dz^-1 [Dq Dv], and (g I - J)(x, y) = (r1, r2)
 * is equivalent to
 *     E(g) (y, mu) = Dz_a r2 - Dq r1 / g,    E(g) = [g Dz_a + Dv + Dq / g | Dz_lambda],
 *     x = (r1 + y_q) / g,
 * (Dz_a, Dz_lambda: the columns of Dz for a and lambda; Dq fills the first LAG_NQ columns; y_q
 * the first LAG_NQ entries of y; mu is a by-product), a system of the order of K
 * (n + constraints) instead of 2n, with no factorisation of K at all, and banded
 * when M and the forces couple near coordinates only (a chain): lag_jacobian stores Dq, Dv and
 * Dz in the band of half-widths LAG_JAC_LOWER, LAG_JAC_UPPER (a dense model: the whole matrix),
 * and E is factored by band Gaussian elimination with partial pivoting, whose work is
 * n (lower + upper) lower instead of n^3 / 3.  For g = (alpha + i beta)/h the same with complex
 * g, in real arithmetic.
 *
 * Error estimate (8.19-8.20).  err = (I - h gamma0 J)^-1 (gamma0 h f(t0, y0) + sum e_i z_i),
 * gamma0 = 1/gamma, e = gamma0 (-13 - 7 sqrt6, -13 + 7 sqrt6, -1) / 3: the filter keeps the
 * estimate bounded for stiff components.  When the first step, or a step after a rejection,
 * fails the test, f(t0, y0) is replaced by f(t0, y0 + err) and the filter applied once more.
 * The norm is the interface's (HNW I, II.4, (4.11)) with max(|y0|, |y1|).
 *
 * Step size ("Step Size Selection").  h_new = h / max(1/8, min(5, err^1/4 / fac)) with
 * fac = 0.9 (1 + 2 nit) / (newt + 2 nit) (fewer Newton iterations, bolder steps); after an
 * accepted step also at most the prediction of Gustafsson's controller (8.25),
 * 0.9 h_n (h_n / h_{n-1}) (err_{n-1} / err_n^2)^1/4, limited to the same range.
 * A rejected first step is retried with h/10; a right-hand side that fails in a stage (the
 * trial left the domain of the model) or gives non-finite values, with h/10 as well (interface
 * README).  The first step is opt->step, or 1e-6 of the span (RADAU5's 1e-6, which
 * assumes t of order 1), at least LAG_START_STEP_FLOOR (it adapts within a few steps).
 * When h falls below LAG_MIN_STEP = 10 eps max(|t|, t_end - t0) the reason of the last failure
 * is returned: the right-hand side's status, LAG_ERR_NO_CONVERGENCE for Newton,
 * LAG_ERR_STEP_TOO_SMALL for the error test.
 *
 * Tolerances.  The estimate is O(h^4) while the method has order 5, so, as RADAU5 does, the
 * user's tolerances are transformed to rtol' = 0.1 rtol^(2/3), atol' = rtol' atol / rtol
 * (LAG_RADAU5_TOLERANCE_SCALE and _POWER, from the integrator's record), which makes the
 * global error roughly proportional to rtol (rtol is raised to at least 10 eps first).
 *
 * Dense output.  The collocation polynomial of the last step, the cubic through (t_old, y_old)
 * and (t_old + c_i h, y_old + z_i), kept in Newton form about t; it has order 3 inside the
 * step and reproduces y1 at t.
 *
 * Work counters: one LU per factorisation of both iteration matrices (RADAU5's NDEC); every
 * unsuccessful trial counts as rejected, so accepted + rejected is the number of attempts that
 * max_steps limits.
 */

#define LAG_INTEGRATOR_NAME "radau5"

#define RADAU_NIT 7                  /* Newton iterations per step */
#define RADAU_THET LAG_LIT(0.001)    /* keep J while the contraction Theta stays below this */
#define RADAU_SAFE LAG_LIT(0.9)
#define RADAU_FACL LAG_LIT(5.0)      /* h_new >= h / 5 */
#define RADAU_FACR LAG_LIT(0.125)    /* h_new <= 8 h */
#define RADAU_QUOT2 LAG_LIT(1.2)     /* keep h and the LU factors when 1 <= h_new/h <= 1.2 */
#define RADAU_MAX_SINGULAR 5         /* singular iteration matrices in a row before giving up */
#define RADAU_NV (LAG_NY - LAG_NQ)   /* the entries v of y = (q, v) */

/* The band LU of E: row i holds columns i - LAG_JAC_LOWER .. i + LAG_JAC_UPPER + LAG_JAC_LOWER,
 * the LAG_JAC_LOWER extra superdiagonals take the fill of the row interchanges. */
#define RADAU_LU_WIDTH (2 * LAG_JAC_LOWER + LAG_JAC_UPPER + 1)
#define RADAU_LU_SIZE (LAG_NK * RADAU_LU_WIDTH)
#define RADAU_LU(a, i, j) (a)[(i) * RADAU_LU_WIDTH + (j) - (i) + LAG_JAC_LOWER]

/* Work counters, printed by the run summary (see "Work counters" above). */
typedef struct lag_stats {
    long accepted, rejected, rhs_evals, jac_evals, lu_decomps, newton_iters;
} lag_stats;

typedef struct lag_stepper {
    LAG_STEPPER_PUBLIC(lag_stats)  /* t, t_old, y, h and stats, which the driver reads (runtime.h) */
    /* the problem */
    const lag_system *sys;
    real t_end, span, h_max, rtol, atol[LAG_NY], fnewt;   /* atol' per component of y */
    long max_steps;
    /* the method: nodes, eigenvalues of A^-1, the eigenbasis T with
     * T^-1 A^-1 T = [[gamma, 0, 0], [0, alpha, -beta], [0, beta, alpha]], error weights dd = e/gamma0 */
    real c1, c2, gamma, alpha, beta;
    real T[3][3], TI[3][3], dd[3];
    /* iteration matrices: Dq, Dv, Dz (lag_jacobian), the band LU of E(gamma/h) and the complex
     * band LU of E((alpha + i beta)/h) */
    real jac[3 * LAG_JAC_SIZE];
    real e1[RADAU_LU_SIZE];
    real e2re[RADAU_LU_SIZE], e2im[RADAU_LU_SIZE];
    int piv1[LAG_NK], piv2[LAG_NK];
    real rhs_re[LAG_NK], rhs_im[LAG_NK];    /* right-hand sides of E */
    real h_lu;                 /* the h the factors belong to, 0 = none */
    /* the step */
    real f0[LAG_NY];           /* f(t, y) */
    real scal[LAG_NY];         /* Newton weights atol' + rtol' |y| */
    real z[3][LAG_NY];         /* stage increments */
    real w[3][LAG_NY];         /* the same in the eigenbasis, W = (T^-1 x I) Z */
    real r[3][LAG_NY];         /* stage derivatives, then Newton corrections */
    real tmp[LAG_NY];
    real cont[3][LAG_NY];      /* divided differences of the collocation polynomial */
    /* the controllers */
    real h_old;                /* last accepted step, for dense output and extrapolation */
    real h_acc, err_acc;       /* previous accepted step and its error, for Gustafsson */
    real theta, faccon;        /* contraction of the last Newton iteration, its eta */
    int newt;                  /* Newton iterations of the last step */
    int first, reject, last;
    int fresh_jac;             /* J was evaluated at the current (t, y) */
    int need_jac, have_f0;
} lag_stepper;

/* ---- band LU with partial pivoting (Golub & Van Loan, Matrix Computations, 4th ed., 4.3.5) ----
 * The multipliers stay in the row where they were formed (as in LAPACK's gbtrf), so the solve
 * applies each interchange just before its elimination step.  The diagonal of U is stored
 * inverted, so that the solves multiply instead of divide. */

static int radau_min(int a, int b)
{
    return a < b ? a : b;
}

/* The row p >= k of the largest |ar_pk| + |ai_pk| in column k, rows k..last (ai NULL: a real
 * matrix), or -1 when the column is zero there. */
static int radau_pivot_row(const real *ar, const real *ai, int k, int last)
{
    int i, p = -1;
    real big = 0;
    for (i = k; i <= last; ++i) {
        real size = r_fabs(RADAU_LU(ar, i, k)) + (ai != NULL ? r_fabs(RADAU_LU(ai, i, k)) : 0);
        if (size > big) {
            big = size;
            p = i;
        }
    }
    return p;
}

/* Rows k and p of a exchanged in columns k..right. */
static void radau_swap_rows(real *a, int k, int p, int right)
{
    int j;
    for (j = k; j <= right; ++j) {
        real t = RADAU_LU(a, k, j);
        RADAU_LU(a, k, j) = RADAU_LU(a, p, j);
        RADAU_LU(a, p, j) = t;
    }
}

/* P a = L U in place.  Returns 0, or k+1 when column k has no nonzero pivot. */
static int radau_band_factor(real *a, int *piv)
{
    int i, j, k;
    for (k = 0; k < LAG_NK; ++k) {
        int last = radau_min(LAG_NK - 1, k + LAG_JAC_LOWER);
        int right = radau_min(LAG_NK - 1, k + LAG_JAC_LOWER + LAG_JAC_UPPER);
        int p = radau_pivot_row(a, NULL, k, last);
        real d;
        if (p < 0)
            return k + 1;
        piv[k] = p;
        if (p != k)
            radau_swap_rows(a, k, p, right);
        d = 1 / RADAU_LU(a, k, k);
        RADAU_LU(a, k, k) = d;
        for (i = k + 1; i <= last; ++i) {
            real m = RADAU_LU(a, i, k) * d;
            RADAU_LU(a, i, k) = m;
            if (m != 0)
                for (j = k + 1; j <= right; ++j)
                    RADAU_LU(a, i, j) -= m * RADAU_LU(a, k, j);
        }
    }
    return 0;
}

/* Solve a x = b with the factors of radau_band_factor; x overwrites b. */
static void radau_band_solve(const real *a, const int *piv, real *b)
{
    int i, j, k;
    for (k = 0; k < LAG_NK; ++k) {
        int last = radau_min(LAG_NK - 1, k + LAG_JAC_LOWER);
        real bk = b[piv[k]];
        b[piv[k]] = b[k];
        b[k] = bk;
        for (i = k + 1; i <= last; ++i)
            b[i] -= RADAU_LU(a, i, k) * bk;
    }
    for (i = LAG_NK - 1; i >= 0; --i) {
        int right = radau_min(LAG_NK - 1, i + LAG_JAC_LOWER + LAG_JAC_UPPER);
        real sum = b[i];
        for (j = i + 1; j <= right; ++j)
            sum -= RADAU_LU(a, i, j) * b[j];
        b[i] = sum * RADAU_LU(a, i, i);
    }
}

/* 1/(a + ib) without overflow in the intermediate a^2 + b^2 (Smith's algorithm). */
static void radau_reciprocal(real a, real b, real *re, real *im)
{
    real q, d;
    if (r_fabs(a) >= r_fabs(b)) {
        q = b / a;
        d = a + b * q;
        *re = 1 / d;
        *im = -q / d;
    } else {
        q = a / b;
        d = a * q + b;
        *re = q / d;
        *im = -1 / d;
    }
}

/* The same for the complex matrix ar + i ai, pivoting on |re| + |im| (a modulus without a
 * square root). */
static int radau_complex_band_factor(real *ar, real *ai, int *piv)
{
    int i, j, k;
    for (k = 0; k < LAG_NK; ++k) {
        int last = radau_min(LAG_NK - 1, k + LAG_JAC_LOWER);
        int right = radau_min(LAG_NK - 1, k + LAG_JAC_LOWER + LAG_JAC_UPPER);
        int p = radau_pivot_row(ar, ai, k, last);
        real dr, di;
        if (p < 0)
            return k + 1;
        piv[k] = p;
        if (p != k) {
            radau_swap_rows(ar, k, p, right);
            radau_swap_rows(ai, k, p, right);
        }
        radau_reciprocal(RADAU_LU(ar, k, k), RADAU_LU(ai, k, k), &dr, &di);
        RADAU_LU(ar, k, k) = dr;
        RADAU_LU(ai, k, k) = di;
        for (i = k + 1; i <= last; ++i) {
            real mr = RADAU_LU(ar, i, k) * dr - RADAU_LU(ai, i, k) * di;
            real mi = RADAU_LU(ar, i, k) * di + RADAU_LU(ai, i, k) * dr;
            RADAU_LU(ar, i, k) = mr;
            RADAU_LU(ai, i, k) = mi;
            if (mr != 0 || mi != 0)
                for (j = k + 1; j <= right; ++j) {
                    RADAU_LU(ar, i, j) -= mr * RADAU_LU(ar, k, j) - mi * RADAU_LU(ai, k, j);
                    RADAU_LU(ai, i, j) -= mr * RADAU_LU(ai, k, j) + mi * RADAU_LU(ar, k, j);
                }
        }
    }
    return 0;
}

/* Solve (ar + i ai) x = br + i bi with the factors of radau_complex_band_factor; x overwrites b. */
static void radau_complex_band_solve(const real *ar, const real *ai, const int *piv, real *br, real *bi)
{
    int i, j, k;
    for (k = 0; k < LAG_NK; ++k) {
        int last = radau_min(LAG_NK - 1, k + LAG_JAC_LOWER);
        real sr = br[piv[k]], si = bi[piv[k]];
        br[piv[k]] = br[k];
        bi[piv[k]] = bi[k];
        br[k] = sr;
        bi[k] = si;
        for (i = k + 1; i <= last; ++i) {
            br[i] -= RADAU_LU(ar, i, k) * sr - RADAU_LU(ai, i, k) * si;
            bi[i] -= RADAU_LU(ar, i, k) * si + RADAU_LU(ai, i, k) * sr;
        }
    }
    for (i = LAG_NK - 1; i >= 0; --i) {
        int right = radau_min(LAG_NK - 1, i + LAG_JAC_LOWER + LAG_JAC_UPPER);
        real sr = br[i], si = bi[i];
        for (j = i + 1; j <= right; ++j) {
            sr -= RADAU_LU(ar, i, j) * br[j] - RADAU_LU(ai, i, j) * bi[j];
            si -= RADAU_LU(ar, i, j) * bi[j] + RADAU_LU(ai, i, j) * br[j];
        }
        br[i] = sr * RADAU_LU(ar, i, i) - si * RADAU_LU(ai, i, i);
        bi[i] = sr * RADAU_LU(ai, i, i) + si * RADAU_LU(ar, i, i);
    }
}

/* ---- the coefficients ---- */

/* Solve (A - mu I) v = 0 with v_3 = 1 for a complex eigenvalue mu = mr + i mi of the 3 x 3
 * matrix a, by Cramer's rule on the first two rows. */
static void radau_eigenvector(real a[3][3], real mr, real mi, real vr[3], real vi[3])
{
    /* M = [[a00 - mu, a01], [a10, a11 - mu]], M v12 = -(a02, a12) */
    real m00r = a[0][0] - mr, m11r = a[1][1] - mr;
    real detr = m00r * m11r - mi * mi - a[0][1] * a[1][0];
    real deti = -mi * (m00r + m11r);
    real n0r = -a[0][2] * m11r + a[0][1] * a[1][2], n0i = a[0][2] * mi;
    real n1r = -a[1][2] * m00r + a[1][0] * a[0][2], n1i = a[1][2] * mi;
    real qr, qi;
    radau_reciprocal(detr, deti, &qr, &qi);
    vr[0] = n0r * qr - n0i * qi;
    vi[0] = n0r * qi + n0i * qr;
    vr[1] = n1r * qr - n1i * qi;
    vi[1] = n1r * qi + n1i * qr;
    vr[2] = 1;
    vi[2] = 0;
}

/* Nodes, eigenvalues of A^-1, and T from the exact Radau IIA matrix A, so that every precision
 * gets constants accurate to its own rounding unit.  T is normalised as in RADAU5 (its first column,
 * the real eigenvector, has unit length; the complex eigenvector has third component 1), which
 * fixes the scale of the Newton norm. */
static void radau_coefficients(lag_stepper *s)
{
    real s6 = r_sqrt(LAG_LIT(6.0)), c3 = r_pow(LAG_LIT(3.0), 1 / LAG_LIT(3.0));
    real a[3][3], vr[3], vi[3], ur[3], ui[3], norm, det, mod2;
    int i, j;
    s->c1 = (4 - s6) / 10;
    s->c2 = (4 + s6) / 10;
    a[0][0] = (88 - 7 * s6) / 360;
    a[0][1] = (296 - 169 * s6) / 1800;
    a[0][2] = (-2 + 3 * s6) / 225;
    a[1][0] = (296 + 169 * s6) / 1800;
    a[1][1] = (88 + 7 * s6) / 360;
    a[1][2] = (-2 - 3 * s6) / 225;
    a[2][0] = (16 - s6) / 36;
    a[2][1] = (16 + s6) / 36;
    a[2][2] = LAG_LIT(1.0) / 9;
    /* the eigenvalues of A^-1 are the poles of the stability function, the roots of
     * z^3 - 9 z^2 + 36 z - 60 (Cardano): 3 + 3^(2/3) - 3^(1/3) and
     * 3 + (3^(1/3) - 3^(2/3))/2 +- i sqrt3 (3^(1/3) + 3^(2/3))/2 */
    s->gamma = 3 + c3 * c3 - c3;
    s->alpha = 3 + (c3 - c3 * c3) / 2;
    s->beta = r_sqrt(LAG_LIT(3.0)) * (c3 + c3 * c3) / 2;
    radau_eigenvector(a, 1 / s->gamma, 0, vr, vi);
    norm = r_sqrt(vr[0] * vr[0] + vr[1] * vr[1] + vr[2] * vr[2]);
    /* t2 + i t3 belongs to the eigenvalue alpha - i beta of A^-1, i.e. (alpha + i beta)/|.|^2 of A */
    mod2 = s->alpha * s->alpha + s->beta * s->beta;
    radau_eigenvector(a, s->alpha / mod2, s->beta / mod2, ur, ui);
    for (i = 0; i < 3; ++i) {
        s->T[i][0] = vr[i] / norm;
        s->T[i][1] = ur[i];
        s->T[i][2] = ui[i];
    }
    det = 0;
    for (j = 0; j < 3; ++j)
        det += s->T[0][j] * (s->T[1][(j + 1) % 3] * s->T[2][(j + 2) % 3]
                             - s->T[1][(j + 2) % 3] * s->T[2][(j + 1) % 3]);
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 3; ++j)
            s->TI[j][i] = (s->T[(i + 1) % 3][(j + 1) % 3] * s->T[(i + 2) % 3][(j + 2) % 3]
                           - s->T[(i + 1) % 3][(j + 2) % 3] * s->T[(i + 2) % 3][(j + 1) % 3]) / det;
    s->dd[0] = -(13 + 7 * s6) / 3;
    s->dd[1] = (-13 + 7 * s6) / 3;
    s->dd[2] = -LAG_LIT(1.0) / 3;
}

/* ---- the step ---- */

/* Take the rest of the interval when the proposed step reaches (or all but reaches) t_end,
 * so that no sliver of a step is left over. */
static void radau_clip(lag_stepper *s)
{
    s->last = s->t + LAG_LIT(1.0001) * s->h >= s->t_end;
    if (s->last)
        s->h = s->t_end - s->t;
}

/* A failed trial: retry from the same (t, y) with h_new, and with J evaluated there (once). */
static void radau_retry(lag_stepper *s, real h_new)
{
    s->h = h_new;
    s->reject = 1;
    s->stats.rejected += 1;
    if (!s->fresh_jac)
        s->need_jac = 1;
    radau_clip(s);
}

/* E(g) = [g Dz_a + Dv + Dq / g | Dz_lambda] in band LU storage, g = gr + i gi: the real part
 * into er, the imaginary part into ei (NULL for real g). */
static void radau_iteration_matrix(const lag_stepper *s, real gr, real gi, real *er, real *ei)
{
    const real *dq = s->jac, *dv = s->jac + LAG_JAC_SIZE, *dz = s->jac + 2 * LAG_JAC_SIZE;
    real inv_r, inv_i;
    int r, j;
    radau_reciprocal(gr, gi, &inv_r, &inv_i);
    memset(er, 0, sizeof(real) * RADAU_LU_SIZE);
    if (ei != NULL)
        memset(ei, 0, sizeof(real) * RADAU_LU_SIZE);
    for (r = 0; r < LAG_NK; ++r)
        for (j = LAG_JAC_FIRST(r); j <= LAG_JAC_LAST(r); ++j) {
            int at = LAG_JAC_AT(r, j);
            if (j >= RADAU_NV) {
                RADAU_LU(er, r, j) = dz[at];
                continue;
            }
            RADAU_LU(er, r, j) = gr * dz[at] + dv[at] + inv_r * dq[at];
            if (ei != NULL)
                RADAU_LU(ei, r, j) = gi * dz[at] + inv_i * dq[at];
        }
}

/* Factor E(gamma/h) and E((alpha + i beta)/h).  Returns 0, or nonzero when singular. */
static int radau_factor(lag_stepper *s)
{
    s->stats.lu_decomps += 1;
    s->h_lu = 0;
    radau_iteration_matrix(s, s->gamma / s->h, 0, s->e1, NULL);
    radau_iteration_matrix(s, s->alpha / s->h, s->beta / s->h, s->e2re, s->e2im);
    if (radau_band_factor(s->e1, s->piv1) != 0 || radau_complex_band_factor(s->e2re, s->e2im, s->piv2) != 0)
        return 1;
    s->h_lu = s->h;
    return 0;
}

/* rhs = Dz_a r2 - Dq r1g, the right-hand side of E (r1g = r1 / g, one of its real parts). */
static void radau_reduce(const lag_stepper *s, const real *r1g, const real *r2, real *rhs)
{
    const real *dq = s->jac, *dz = s->jac + 2 * LAG_JAC_SIZE;
    int r, j;
    for (r = 0; r < LAG_NK; ++r) {
        int first = LAG_JAC_FIRST(r), last = LAG_JAC_LAST(r);
        real sum = 0;
        for (j = first; j <= radau_min(RADAU_NV - 1, last); ++j)
            sum += dz[LAG_JAC_AT(r, j)] * r2[j];
        for (j = first; j <= radau_min(LAG_NQ - 1, last); ++j)
            sum -= dq[LAG_JAC_AT(r, j)] * r1g[j];
        rhs[r] = sum;
    }
}

/* (g I - J)(x, y) = (r1, r2) for g = gamma/h through E(g); (x, y) overwrites r = (r1, r2). */
static void radau_solve_real(lag_stepper *s, real *r)
{
    real g = s->gamma / s->h_lu;
    int j;
    for (j = 0; j < LAG_NQ; ++j)
        r[j] /= g;
    radau_reduce(s, r, r + LAG_NQ, s->rhs_re);
    radau_band_solve(s->e1, s->piv1, s->rhs_re);
    for (j = 0; j < RADAU_NV; ++j)
        r[LAG_NQ + j] = s->rhs_re[j];
    for (j = 0; j < LAG_NQ; ++j)
        r[j] += s->rhs_re[j] / g;          /* x = (r1 + y_q) / g */
}

/* The same for g = (alpha + i beta)/h, with (r1, r2) = re + i im. */
static void radau_solve_complex(lag_stepper *s, real *re, real *im)
{
    real ir, ii;                            /* 1/g */
    int j;
    radau_reciprocal(s->alpha / s->h_lu, s->beta / s->h_lu, &ir, &ii);
    for (j = 0; j < LAG_NQ; ++j) {
        real u = re[j], w = im[j];
        re[j] = u * ir - w * ii;
        im[j] = u * ii + w * ir;
    }
    radau_reduce(s, re, re + LAG_NQ, s->rhs_re);
    radau_reduce(s, im, im + LAG_NQ, s->rhs_im);
    radau_complex_band_solve(s->e2re, s->e2im, s->piv2, s->rhs_re, s->rhs_im);
    for (j = 0; j < RADAU_NV; ++j) {
        re[LAG_NQ + j] = s->rhs_re[j];
        im[LAG_NQ + j] = s->rhs_im[j];
    }
    for (j = 0; j < LAG_NQ; ++j) {
        real yr = s->rhs_re[j], yi = s->rhs_im[j];
        re[j] += yr * ir - yi * ii;
        im[j] += yr * ii + yi * ir;
    }
}

/* Starting values: the previous collocation polynomial continued to the new nodes t + c_i h. */
static void radau_start(lag_stepper *s)
{
    real c[3];
    int i, k;
    if (s->first) {
        for (k = 0; k < 3; ++k)
            for (i = 0; i < LAG_NY; ++i)
                s->z[k][i] = s->w[k][i] = 0;
        return;
    }
    c[0] = s->c1 * s->h / s->h_old;
    c[1] = s->c2 * s->h / s->h_old;
    c[2] = s->h / s->h_old;
    for (i = 0; i < LAG_NY; ++i) {
        for (k = 0; k < 3; ++k)
            s->z[k][i] = c[k] * (s->cont[0][i] + (c[k] - (s->c2 - 1))
                                 * (s->cont[1][i] + (c[k] - (s->c1 - 1)) * s->cont[2][i]));
        for (k = 0; k < 3; ++k)
            s->w[k][i] = s->TI[k][0] * s->z[0][i] + s->TI[k][1] * s->z[1][i] + s->TI[k][2] * s->z[2][i];
    }
}

/* One simplified Newton correction: r = (iteration matrix)^-1 (-(Lambda/h x I) W + (T^-1 x I) F(Z)),
 * in the eigenbasis.  Returns the status of the right-hand side. */
static int radau_correction(lag_stepper *s)
{
    const real c[3] = {s->c1, s->c2, 1};
    real g = s->gamma / s->h, a = s->alpha / s->h, b = s->beta / s->h;
    int i, k, status;
    for (k = 0; k < 3; ++k) {
        for (i = 0; i < LAG_NY; ++i)
            s->tmp[i] = s->y[i] + s->z[k][i];
        status = lag_rhs(s->sys, s->t + c[k] * s->h, s->tmp, s->r[k]);
        if (status != LAG_OK)
            return status;
    }
    s->stats.rhs_evals += 3;
    for (i = 0; i < LAG_NY; ++i) {
        real f1 = s->r[0][i], f2 = s->r[1][i], f3 = s->r[2][i];
        real w1 = s->w[0][i], w2 = s->w[1][i], w3 = s->w[2][i];
        s->r[0][i] = s->TI[0][0] * f1 + s->TI[0][1] * f2 + s->TI[0][2] * f3 - g * w1;
        s->r[1][i] = s->TI[1][0] * f1 + s->TI[1][1] * f2 + s->TI[1][2] * f3 - (a * w2 - b * w3);
        s->r[2][i] = s->TI[2][0] * f1 + s->TI[2][1] * f2 + s->TI[2][2] * f3 - (b * w2 + a * w3);
    }
    radau_solve_real(s, s->r[0]);
    radau_solve_complex(s, s->r[1], s->r[2]);
    return LAG_OK;
}

/* Solve the collocation system for Z by simplified Newton iterations (IV.8, (8.10)-(8.11)).
 * Returns LAG_OK, or a failure status with *shrink the factor to retry with. */
static int radau_newton(lag_stepper *s, real *shrink)
{
    real dyno, dynold = 1, thq, thqold = 1, dyth;
    int i, k, left, status;
    radau_start(s);
    s->faccon = r_pow(r_fmax(s->faccon, REAL_EPSILON), LAG_LIT(0.8));
    s->theta = RADAU_THET;
    s->newt = 0;
    for (;;) {
        if (s->newt >= RADAU_NIT) {
            *shrink = LAG_LIT(0.5);
            return LAG_ERR_NO_CONVERGENCE;
        }
        status = radau_correction(s);
        if (status != LAG_OK) {
            *shrink = LAG_LIT(0.1);
            return status;
        }
        s->newt += 1;
        s->stats.newton_iters += 1;
        dyno = 0;
        for (k = 0; k < 3; ++k)
            for (i = 0; i < LAG_NY; ++i)
                dyno += (s->r[k][i] / s->scal[i]) * (s->r[k][i] / s->scal[i]);
        dyno = r_sqrt(dyno / (3 * LAG_NY));
        if (!r_isfinite(dyno)) {
            /* a stage derivative the model did not flag: treated like a failed right-hand side */
            *shrink = LAG_LIT(0.1);
            return LAG_ERR_NONFINITE;
        }
        if (s->newt > 1 && s->newt < RADAU_NIT) {
            thq = dyno / dynold;
            s->theta = s->newt == 2 ? thq : r_sqrt(thq * thqold);
            thqold = thq;
            if (!(s->theta < LAG_LIT(0.99))) {
                *shrink = LAG_LIT(0.5);
                return LAG_ERR_NO_CONVERGENCE;
            }
            s->faccon = s->theta / (1 - s->theta);
            /* the error left after the remaining iterations: when it will not reach fnewt,
             * retry at once with the step that should converge in time */
            left = RADAU_NIT - 1 - s->newt;
            dyth = s->faccon * dyno * r_pow(s->theta, (real)left) / s->fnewt;
            if (dyth >= 1) {
                real qnewt = r_fmax(LAG_LIT(1e-4), r_fmin(20, dyth));
                *shrink = LAG_LIT(0.8) * r_pow(qnewt, -1 / (4 + (real)left));
                return LAG_ERR_NO_CONVERGENCE;
            }
        }
        dynold = r_fmax(dyno, REAL_EPSILON);
        for (i = 0; i < LAG_NY; ++i) {
            real w1 = s->w[0][i] += s->r[0][i];
            real w2 = s->w[1][i] += s->r[1][i];
            real w3 = s->w[2][i] += s->r[2][i];
            for (k = 0; k < 3; ++k)
                s->z[k][i] = s->T[k][0] * w1 + s->T[k][1] * w2 + s->T[k][2] * w3;
        }
        if (s->faccon * dyno <= s->fnewt)
            return LAG_OK;
    }
}

/* The weighted RMS norm of the interface README, with max(|y0|, |y1|), y1 = y0 + z_3. */
static real radau_norm(const lag_stepper *s, const real *e)
{
    real sum = 0;
    int i;
    for (i = 0; i < LAG_NY; ++i) {
        real y1 = s->y[i] + s->z[2][i];
        real sk = s->atol[i] + s->rtol * r_fmax(r_fabs(s->y[i]), r_fabs(y1));
        sum += (e[i] / sk) * (e[i] / sk);
    }
    return r_sqrt(sum / LAG_NY);
}

/* The filtered error estimate (8.19-8.20), with the second filtering when the first step or a
 * step after a rejection fails.  Returns the status of the extra right-hand side. */
static int radau_error(lag_stepper *s, real *err)
{
    real *e = s->r[0], *g = s->r[1];   /* free after the Newton iteration */
    int i, status;
    for (i = 0; i < LAG_NY; ++i) {
        g[i] = (s->dd[0] * s->z[0][i] + s->dd[1] * s->z[1][i] + s->dd[2] * s->z[2][i]) / s->h;
        e[i] = s->f0[i] + g[i];
    }
    /* (gamma/h I - J)^-1 = h gamma0 (I - h gamma0 J)^-1 */
    radau_solve_real(s, e);
    *err = radau_norm(s, e);
    if (*err >= 1 && (s->first || s->reject)) {
        for (i = 0; i < LAG_NY; ++i)
            s->tmp[i] = s->y[i] + e[i];
        status = lag_rhs(s->sys, s->t, s->tmp, e);
        s->stats.rhs_evals += 1;
        if (status != LAG_OK)
            return status;
        for (i = 0; i < LAG_NY; ++i)
            e[i] += g[i];
        radau_solve_real(s, e);
        *err = radau_norm(s, e);
    }
    *err = r_isfinite(*err) ? r_fmax(*err, LAG_LIT(1e-10)) : REAL_MAX;
    return LAG_OK;
}

/* Accept the step: y1 = y0 + z_3, the collocation polynomial as y1 + s (cont0 + (s - c2 + 1)
 * (cont1 + (s - c1 + 1) cont2)) in s = (t - t1)/h, whose cont are the divided differences of
 * the increments 0, z2 - z3, z1 - z3, -z3 at the nodes s = 0, c2 - 1, c1 - 1, -1; and the next
 * step size. */
static void radau_accept(lag_stepper *s, real err, real quot)
{
    real h = s->h, h_new, h_opt;
    int i;
    s->first = 0;
    s->stats.accepted += 1;
    if (s->stats.accepted > 1) {
        real facgus = (s->h_acc / h) * r_pow(err * err / s->err_acc, LAG_LIT(0.25)) / RADAU_SAFE;
        quot = r_fmax(quot, r_fmax(RADAU_FACR, r_fmin(RADAU_FACL, facgus)));
    }
    s->h_acc = h;
    s->err_acc = r_fmax(LAG_LIT(1e-2), err);
    for (i = 0; i < LAG_NY; ++i) {
        real z1 = s->z[0][i], z2 = s->z[1][i], z3 = s->z[2][i];
        real d12 = (z1 - z2) / (s->c1 - s->c2);        /* nodes c2 - 1, c1 - 1 */
        real d123 = (d12 - z1 / s->c1) / s->c2;        /* nodes c2 - 1, c1 - 1, -1 */
        s->y[i] += z3;
        s->cont[0][i] = (z2 - z3) / (s->c2 - 1);
        s->cont[1][i] = (d12 - s->cont[0][i]) / (s->c1 - 1);
        s->cont[2][i] = s->cont[1][i] - d123;
    }
    s->t_old = s->t;
    s->t = s->last ? s->t_end : s->t + h;
    s->h_old = h;
    s->have_f0 = 0;
    s->fresh_jac = 0;
    h_new = r_fmin(h / quot, s->h_max);
    h_opt = r_fmin(h, h_new);
    if (s->reject)
        h_new = r_fmin(h_new, h);
    s->reject = 0;
    if (s->last) {
        s->h = h_opt;
        return;
    }
    /* fast convergence and a step size that would hardly change: keep J and the factors */
    if (!(s->theta <= RADAU_THET && h_new >= h && h_new <= RADAU_QUOT2 * h))
        s->h = h_new;
    radau_clip(s);
    s->need_jac = s->theta > RADAU_THET;
}

/* ---- the interface ---- */

static int lag_stepper_init(lag_stepper *s, const lag_system *sys, real t0, const real *y0,
                            real t_end, const lag_options *opt)
{
    real rtol = r_fmax(opt->rtol, LAG_RTOL_FLOOR);
    int i, status;
    memset(&s->stats, 0, sizeof s->stats);
    s->sys = sys;
    s->t = s->t_old = t0;
    s->t_end = t_end;
    s->span = t_end - t0;
    for (i = 0; i < LAG_NY; ++i)
        s->y[i] = y0[i];
    radau_coefficients(s);
    s->rtol = LAG_RADAU5_TOLERANCE_SCALE * r_pow(rtol, LAG_RADAU5_TOLERANCE_POWER);
    for (i = 0; i < LAG_NY; ++i)
        s->atol[i] = r_fmax(s->rtol * (LAG_ATOL(opt, i) / rtol), REAL_MIN);
    s->fnewt = r_fmax(10 * REAL_EPSILON / s->rtol, r_fmin(LAG_LIT(0.03), r_sqrt(s->rtol)));
    s->max_steps = opt->max_steps;
    s->h_max = opt->max_step > 0 ? r_fmin(opt->max_step, t_end - t0) : t_end - t0;
    s->h = opt->step > 0 ? opt->step : r_fmax(LAG_START_STEP_FRACTION * s->span, LAG_START_STEP_FLOOR(t0, s->span));
    s->h = r_fmin(s->h, s->h_max);
    s->h_old = s->h_acc = s->h;
    s->err_acc = 1;
    s->h_lu = 0;
    s->theta = RADAU_THET;
    s->faccon = 1;
    s->newt = 0;
    s->first = 1;
    s->reject = 0;
    s->fresh_jac = 0;
    s->need_jac = 1;
    radau_clip(s);
    status = lag_rhs(sys, t0, s->y, s->f0);
    s->stats.rhs_evals += 1;
    s->have_f0 = status == LAG_OK;
    return status;
}

static int lag_stepper_step(lag_stepper *s)
{
    int i, status, singular = 0, failure = LAG_ERR_STEP_TOO_SMALL;
    if (s->t >= s->t_end)
        return LAG_OK;
    if (!s->have_f0) {
        status = lag_rhs(s->sys, s->t, s->y, s->f0);
        s->stats.rhs_evals += 1;
        if (status != LAG_OK)
            return status;
        s->have_f0 = 1;
    }
    for (i = 0; i < LAG_NY; ++i)
        s->scal[i] = s->atol[i] + s->rtol * r_fabs(s->y[i]);
    for (;;) {
        real err, shrink, fac, quot;
        if (s->max_steps > 0 && s->stats.accepted + s->stats.rejected >= s->max_steps)
            return LAG_ERR_MAX_STEPS;
        if (!(s->h >= LAG_MIN_STEP(s->t, s->span)) || s->h <= 0)
            return failure;
        if (s->need_jac) {
            status = lag_jacobian(s->sys, s->t, s->y, s->jac);
            s->stats.jac_evals += 1;
            if (status != LAG_OK)
                return status;
            s->need_jac = 0;
            s->fresh_jac = 1;
            s->h_lu = 0;
        }
        if (s->h != s->h_lu && radau_factor(s) != 0) {
            /* not the model's mass matrix but Newton's: the iteration cannot proceed */
            failure = LAG_ERR_NO_CONVERGENCE;
            if (++singular >= RADAU_MAX_SINGULAR)
                return failure;
            radau_retry(s, s->h / 2);
            continue;
        }
        status = radau_newton(s, &shrink);
        if (status == LAG_OK) {
            shrink = LAG_LIT(0.1);
            status = radau_error(s, &err);
        }
        if (status != LAG_OK) {
            failure = status;
            radau_retry(s, s->h * shrink);
            continue;
        }
        /* the safety factor drops when Newton needed many iterations */
        fac = r_fmin(RADAU_SAFE, RADAU_SAFE * (1 + 2 * RADAU_NIT) / (s->newt + 2 * RADAU_NIT));
        quot = r_fmax(RADAU_FACR, r_fmin(RADAU_FACL, r_pow(err, LAG_LIT(0.25)) / fac));
        if (err <= 1) {
            radau_accept(s, err, quot);
            return LAG_OK;
        }
        failure = LAG_ERR_STEP_TOO_SMALL;
        radau_retry(s, s->first ? s->h / 10 : s->h / quot);
    }
}

static int lag_stepper_dense(lag_stepper *s, real t, real *yout)
{
    int i;
    if (s->t == s->t_old) {
        for (i = 0; i < LAG_NY; ++i)
            yout[i] = s->y[i];
        return LAG_OK;
    }
    {
        real u = (t - s->t) / s->h_old, a = u - (s->c2 - 1), b = u - (s->c1 - 1);
        for (i = 0; i < LAG_NY; ++i)
            yout[i] = s->y[i] + u * (s->cont[0][i] + a * (s->cont[1][i] + b * s->cont[2][i]));
    }
    return LAG_OK;
}

static int lag_stepper_restart(lag_stepper *s)
{
    /* f(t, y) is re-evaluated at the start of the next step; J, the factors and the
     * extrapolated starting values remain good approximations after a small projection */
    s->have_f0 = 0;
    return LAG_OK;
}
