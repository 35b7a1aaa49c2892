/* The baseline of the work-precision benchmarks: a hand-written Störmer-Verlet loop (gcc -O2),
 * P1 (Kepler) or P3 (pendulum), run REPS times (argument 2, default 3) keeping the least time,
 * STEPS steps (argument 3, default 10^6 for P1 and 10^7 for P3); prints "verlet,PROBLEM,c loop,h,steps,cpu_seconds,ns_per_step". */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double cpu(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int main(int argc, char **argv) {
    int kepler = argc > 1 && strcmp(argv[1], "p1") == 0;
    int reps = argc > 2 ? atoi(argv[2]) : 3;
    double h = kepler ? 2 * M_PI / 1000 : 0.01;
    long steps = argc > 3 ? atol(argv[3]) : kepler ? 1000000 : 10000000;
    double best = 1e300, x = 0, y = 0, px = 0, py = 0;
    for (int rep = 0; rep < (reps > 0 ? reps : 1); rep++) {
        x = kepler ? 0.4 : 0.0; y = 0; px = kepler ? 0 : 1.5; py = kepler ? 2 : 0;
        double t0 = cpu();
        double r3 = pow(x * x + y * y, 1.5), fx = kepler ? -x / r3 : -sin(x), fy = kepler ? -y / r3 : 0;
        for (long k = 0; k < steps; k++) {
            px += 0.5 * h * fx; py += 0.5 * h * fy;
            x += h * px; y += h * py;
            if (kepler) { double r2 = x * x + y * y, c = -1 / (r2 * sqrt(r2)); fx = c * x; fy = c * y; }
            else fx = -sin(x);
            px += 0.5 * h * fx; py += 0.5 * h * fy;
        }
        double t = cpu() - t0;
        if (t < best) best = t;
    }
    printf("verlet,%s,c loop,%g,%ld,%g,%g\n", kepler ? "P1" : "P3", h, steps, best, 1e9 * best / steps);
    fprintf(stderr, "(final state %g %g %g %g)\n", x, y, px, py);
    return 0;
}
