/* The baseline of the FPU scaling table (issue 15): the alpha-FPUT chain of N unit masses with
 * fixed ends (alpha = 0.25, beta = 0), the same force as femvi's models::fpu
 * (V'(d) = d + alpha d^2 + beta d^3 of the bonds d_i = q_{i+1} - q_i), by Stormer-Verlet
 * (kick-drift-kick, what femvi's degree 1 with the trapezoid rule computes), h = 0.1, from the
 * lowest mode's velocities. Arguments: N (default 1000), STEPS (default 2*10^7 / N), REPS
 * (default 3, the least time kept), and "compensated" to add the increments to q and p by
 * compensated (Kahan) sums with their error terms in two more arrays, as femvi does.
 * Prints "fpu,c loop[ compensated],N,steps,cpu_seconds,ns_per_step_per_dof".
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
    int comp = argc > 4 && argv[4][0] == 'c';
    double h = 0.1, best = 1e300;
    double *q = malloc(n * sizeof *q), *p = malloc(n * sizeof *p), *f = malloc(n * sizeof *f);
    double *cq = calloc(n, sizeof *cq), *cp = calloc(n, sizeof *cp), *dq = malloc(n * sizeof *dq);
    if (!q || !p || !f || !cq || !cp || !dq) return 1;
    for (int rep = 0; rep < (reps > 0 ? reps : 1); rep++) {
        for (long i = 0; i < n; i++) {
            q[i] = 0.0;
            p[i] = sin(M_PI * (i + 1) / (n + 1));
            cq[i] = cp[i] = 0.0;
        }
        double t0 = cpu();
        force(n, q, f);
        for (long k = 0; k < steps && comp; k++) {
            /* Positions y = q + dq for the new force, then q += dq and p += h/2 (f0 + f1) by
             * compensated sums (the old force kept in dq's place after use). */
            for (long i = 0; i < n; i++) {
                dq[i] = h * p[i] + 0.5 * h * h * f[i];
                double y = dq[i] + cq[i], t = q[i] + y;
                cq[i] = (q[i] - t) + y;
                q[i] = t;
                dq[i] = f[i];
            }
            force(n, q, f);
            for (long i = 0; i < n; i++) {
                double y = 0.5 * h * (dq[i] + f[i]) + cp[i], t = p[i] + y;
                cp[i] = (p[i] - t) + y;
                p[i] = t;
            }
        }
        for (long k = 0; k < steps && !comp; k++) {
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
    printf("fpu,c loop%s,%ld,%ld,%g,%g\n", comp ? " compensated" : "", n, steps, best, 1e9 * best / steps / n);
    fprintf(stderr, "(q[0] = %.17g, p[0] = %.17g)\n", q[0], p[0]);
    free(q); free(p); free(f); free(cq); free(cp); free(dq);
    return 0;
}
