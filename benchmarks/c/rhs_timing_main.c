/* ---- benchmarks/c/rhs_timing_main.c: the cost of one right-hand-side call ----
 *
 * Appended by benchmarks/double_pendulum_speed.py after the C file lagdsl generates for the
 * double pendulum's scene `chaos` and after double_pendulum_hand.c, so both right-hand sides
 * are static functions of one translation unit, compiled with the same flags. The generated
 * file has its own main(): the script compiles with -Dmain=lag_generated_main, and the
 * #undef below gives this file the real one back. Needs -D_POSIX_C_SOURCE=199309L for
 * clock_gettime under -std=c99.
 *
 * Each loop calls its function RHS_CALLS times on a state that every call moves a little
 * (y += 1e-9 * dy/dt): the next call depends on the last result, so the compiler can neither
 * drop calls nor hoist them out of the loop. Both loops follow the same path from the same
 * state, so their final states (printed) agree to rounding. Loops alternate, best of ROUNDS.
 * Output: one line "generated_ns=... hand_ns=... max_rhs_difference=... ..." for the script. */
#undef main

#ifndef RHS_CALLS
#define RHS_CALLS 10000000L
#endif
#define ROUNDS 5
#define NUDGE 1e-9

/* CPU time of the process, not wall-clock time: the machine may be shared with other work. */
static double seconds_now(void)
{
    struct timespec now;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
    return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}

/* A state away from rest, read through volatile so nothing is known at compile time. */
static void start_state(real *y)
{
    static volatile double start[4] = {1.0, 2.0, 0.3, -0.4};
    int i;
    for (i = 0; i < LAG_NY; ++i)
        y[i] = (real)start[i];
}

static double ns_per_generated_call(const lag_system *sys, real *checksum)
{
    real y[LAG_NY], dydt[LAG_NY];
    long k;
    int i;
    double started;
    start_state(y);
    started = seconds_now();
    for (k = 0; k < RHS_CALLS; ++k) {
        if (lag_rhs(sys, 0, y, dydt) != LAG_OK) {
            fprintf(stderr, "generated lag_rhs failed at call %ld\n", k);
            exit(1);
        }
        for (i = 0; i < LAG_NY; ++i)
            y[i] += NUDGE * dydt[i];
    }
    *checksum = y[0] + y[1] + y[2] + y[3];
    return (seconds_now() - started) / RHS_CALLS * 1e9;
}

static double ns_per_hand_call(const real *par, real *checksum)
{
    real y[LAG_NY], dydt[LAG_NY];
    long k;
    int i;
    double started;
    start_state(y);
    started = seconds_now();
    for (k = 0; k < RHS_CALLS; ++k) {
        if (hand_rhs(par, 0, y, dydt) != LAG_OK) {
            fprintf(stderr, "hand_rhs failed at call %ld\n", k);
            exit(1);
        }
        for (i = 0; i < LAG_NY; ++i)
            y[i] += NUDGE * dydt[i];
    }
    *checksum = y[0] + y[1] + y[2] + y[3];
    return (seconds_now() - started) / RHS_CALLS * 1e9;
}

/* The two functions must compute the same thing: max |generated - hand| at the start state. */
static double rhs_difference(const lag_system *sys)
{
    real y[LAG_NY], a[LAG_NY], b[LAG_NY];
    double largest = 0;
    int i;
    start_state(y);
    lag_rhs(sys, 0, y, a);
    hand_rhs(sys->par, 0, y, b);
    for (i = 0; i < LAG_NY; ++i)
        if (fabs((double)(a[i] - b[i])) > largest)
            largest = fabs((double)(a[i] - b[i]));
    return largest;
}

int main(void)
{
    lag_system sys;
    double generated = 1e300, hand = 1e300;
    real generated_end = 0, hand_end = 0;
    int round;
    lag_default_parameters(sys.par);
    for (round = 0; round < ROUNDS; ++round) {
        double g = ns_per_generated_call(&sys, &generated_end);
        double h = ns_per_hand_call(sys.par, &hand_end);
        generated = g < generated ? g : generated;
        hand = h < hand ? h : hand;
    }
    printf("generated_ns=%.3f hand_ns=%.3f max_rhs_difference=%.3g generated_end=%.17g hand_end=%.17g calls=%ld\n",
           generated, hand, rhs_difference(&sys), (double)generated_end, (double)hand_end, (long)RHS_CALLS);
    return 0;
}
