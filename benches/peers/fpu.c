/* The baseline of the FPU scaling table (issue 15): the alpha-FPUT chain of N unit masses with
 * fixed ends (alpha = 0.25, beta = 0), the same force as femvi's models::fpu
 * (V'(d) = d + alpha d^2 + beta d^3 of the bonds d_i = q_{i+1} - q_i), by Stormer-Verlet
 * (kick-drift-kick, what femvi's degree 1 with the trapezoid rule computes), h = 0.1, from the
 * lowest mode's velocities. Arguments: N (default 1000), STEPS (default 2*10^7 / N), REPS
 * (default 3, the least time kept). Prints "fpu,c loop,N,steps,cpu_seconds,ns_per_step_per_dof".
 * gcc -O2 -o fpu fpu.c -lm */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double cpu(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static const double alpha = 0.25, beta = 0.0;

static double dv(double d) { return d + alpha * d * d + beta * d * d * d; }

static void force(long n, const double *q, double *f) {
    double prev = dv(q[0]);
    for (long i = 0; i < n; i++) {
        double next = dv((i + 1 < n ? q[i + 1] : 0.0) - q[i]);
        f[i] = next - prev;
        prev = next;
    }
}

int main(int argc, char **argv) {
    long n = argc > 1 ? atol(argv[1]) : 1000;
    if (n < 1) n = 1;
    long steps = argc > 2 ? atol(argv[2]) : 20000000 / n;
    if (steps < 2) steps = 2;
    int reps = argc > 3 ? atoi(argv[3]) : 3;
    double h = 0.1, best = 1e300;
    double *q = malloc(n * sizeof *q), *p = malloc(n * sizeof *p), *f = malloc(n * sizeof *f);
    if (!q || !p || !f) return 1;
    for (int rep = 0; rep < (reps > 0 ? reps : 1); rep++) {
        for (long i = 0; i < n; i++) {
            q[i] = 0.0;
            p[i] = sin(M_PI * (i + 1) / (n + 1));
        }
        double t0 = cpu();
        force(n, q, f);
        for (long k = 0; k < steps; k++) {
            for (long i = 0; i < n; i++) {
                p[i] += 0.5 * h * f[i];
                q[i] += h * p[i];
            }
            force(n, q, f);
            for (long i = 0; i < n; i++) p[i] += 0.5 * h * f[i];
        }
        double t = cpu() - t0;
        if (t < best) best = t;
    }
    printf("fpu,c loop,%ld,%ld,%g,%g\n", n, steps, best, 1e9 * best / steps / n);
    fprintf(stderr, "(q[0] = %.17g, p[0] = %.17g)\n", q[0], p[0]);
    free(q); free(p); free(f);
    return 0;
}
