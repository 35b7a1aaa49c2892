/* Lie group variational integrator (Lee, Leok, McClamroch 2005/2007) for the free rigid body,
 * written out by hand: the C peer for issue 37 (rotations as configuration variables), see
 * lgvi.md.  Second order.
 *
 * R in SO(3) maps body to space, dR/dt = R hat(w), Pi = I w (body), I = diag(1, 2, 3).
 * With J_d = 1/2 tr(I) 1 - I, each step solves
 *     h hat(Pi_k) = F J_d - J_d F^T                                         (1)
 * for F in SO(3), then R_{k+1} = R_k F, Pi_{k+1} = F^T Pi_k.
 *
 * Vector form.  F = exp(hat f) = 1 + a hat(f) + b hat(f)^2, a = sin|f|/|f|, b = (1-cos|f|)/|f|^2.
 * The 1 terms of (1) cancel.  hat(f) J_d + J_d hat(f) = hat((tr(J_d) 1 - J_d) f) and
 * tr(J_d) 1 - J_d = I, so the a terms give a hat(I f).  hat(f)^2 = f f^T - |f|^2 1, the |f|^2
 * terms cancel and f (J_d f)^T - (J_d f) f^T = hat((J_d f) x f) = hat(f x (I f)).  Hence (1) is
 *     h Pi_k = a I f + b f x (I f).                                          (2)
 * Newton on (2): the Jacobian is
 *     a I + a'(t)/t (I f) f^T + b (hat(f) I - hat(I f)) + b'(t)/t (f x I f) f^T,  t = |f|,
 * started from the second-order solution of (2), f0 = h w - (h^2/2) I^-1 (w x Pi),
 * w = I^-1 Pi_k; stopped when max|df| <= 1e-15 max|f| or after 10 iterations.  b is computed
 * as 2 sin^2(t/2)/t^2 (no cancellation), a as 2 sin(t/2) cos(t/2)/t (one sincos per
 * evaluation); a'/t and b'/t by their series for t < 0.1.
 *
 * Usage: lgvi [STEPS [H [every]]]  (defaults 1000000 and 0.01; "every" checks |R^T R - 1|
 * after every step, otherwise at the end).  Case A: R0 = 1, w0 = (0.5, 1, 0.3).  Prints the
 * final R (row-major), Pi and w = I^-1 Pi with 17 significant digits, max|R^T R - 1|, the
 * relative change of |Pi| and of the energy, and the Newton iteration counts.
 *
 * Build: gcc -O2 -o lgvi lgvi.c -lm
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX(x, y) ((x) > (y) ? (x) : (y))

static double orth_err(const double *R) {
    double m = 0.0;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            double s = R[i] * R[j] + R[3 + i] * R[3 + j] + R[6 + i] * R[6 + j] - (i == j ? 1.0 : 0.0);
            if (fabs(s) > m) m = fabs(s);
        }
    }
    return m;
}

/* a = sin t / t, b = (1 - cos t)/t^2 = 2 sin^2(t/2)/t^2, da = a'(t)/t, db = b'(t)/t, t = |f|. */
static void coefficients(const double *f, double *a, double *b, double *da, double *db) {
    double t2 = f[0] * f[0] + f[1] * f[1] + f[2] * f[2];
    double t = sqrt(t2);
    if (t < 1e-4) {
        *a = 1.0 - t2 / 6.0;
        *b = 0.5 - t2 / 24.0;
    } else {
        double s = sin(0.5 * t), c = cos(0.5 * t); /* one sincos */
        *a = 2.0 * s * c / t;
        *b = 2.0 * s * s / t2;
    }
    if (t < 0.1) {
        *da = -1.0 / 3.0 + t2 * (1.0 / 30.0 - t2 * (1.0 / 840.0 - t2 / 45360.0));
        *db = -1.0 / 12.0 + t2 * (1.0 / 180.0 - t2 * (1.0 / 6720.0 - t2 / 453600.0));
    } else {
        *da = (1.0 - *b * t2 - *a) / t2;          /* (t cos t - sin t)/t^3, cos t = 1 - b t^2 */
        *db = (*a - 2.0 * *b) / t2;               /* (t sin t - 2 (1 - cos t))/t^4 */
    }
}

int main(int argc, char **argv) {
    long steps = argc > 1 ? atol(argv[1]) : 1000000;
    double h = argc > 2 ? atof(argv[2]) : 0.01;
    int every = argc > 3 && strcmp(argv[3], "every") == 0;
    const double I[3] = {1.0, 2.0, 3.0};
    double R[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
    double Pi[3] = {I[0] * 0.5, I[1] * 1.0, I[2] * 0.3};
    const double pi_norm0 = sqrt(Pi[0] * Pi[0] + Pi[1] * Pi[1] + Pi[2] * Pi[2]);
    const double energy0 = 0.5 * (Pi[0] * Pi[0] / I[0] + Pi[1] * Pi[1] / I[1] + Pi[2] * Pi[2] / I[2]);
    double max_orth = 0.0;
    long newton_total = 0;
    int newton_max = 0, newton_capped = 0;

    for (long k = 0; k < steps; k++) {
        double w[3] = {Pi[0] / I[0], Pi[1] / I[1], Pi[2] / I[2]};
        double wxp[3] = {w[1] * Pi[2] - w[2] * Pi[1], w[2] * Pi[0] - w[0] * Pi[2], w[0] * Pi[1] - w[1] * Pi[0]};
        double f[3], hp[3];
        for (int i = 0; i < 3; i++) {
            f[i] = h * w[i] - 0.5 * h * h * wxp[i] / I[i];
            hp[i] = h * Pi[i];
        }
        double a, b, da, db;
        int it = 0;
        while (it < 10) {
            coefficients(f, &a, &b, &da, &db);
            double If[3] = {I[0] * f[0], I[1] * f[1], I[2] * f[2]};
            double c[3] = {f[1] * If[2] - f[2] * If[1], f[2] * If[0] - f[0] * If[2], f[0] * If[1] - f[1] * If[0]};
            double g[3];
            for (int i = 0; i < 3; i++) g[i] = a * If[i] + b * c[i] - hp[i];
            /* J = a I + da If f^T + b (hat(f) I - hat(If)) + db c f^T */
            double J[3][3];
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++) J[i][j] = (da * If[i] + db * c[i]) * f[j];
            for (int i = 0; i < 3; i++) J[i][i] += a * I[i];
            J[0][1] += b * (If[2] - f[2] * I[1]);
            J[0][2] += b * (f[1] * I[2] - If[1]);
            J[1][0] += b * (f[2] * I[0] - If[2]);
            J[1][2] += b * (If[0] - f[0] * I[2]);
            J[2][0] += b * (If[1] - f[1] * I[0]);
            J[2][1] += b * (f[0] * I[1] - If[0]);
            /* solve J d = -g by the adjugate */
            double A00 = J[1][1] * J[2][2] - J[1][2] * J[2][1];
            double A01 = J[0][2] * J[2][1] - J[0][1] * J[2][2];
            double A02 = J[0][1] * J[1][2] - J[0][2] * J[1][1];
            double A10 = J[1][2] * J[2][0] - J[1][0] * J[2][2];
            double A11 = J[0][0] * J[2][2] - J[0][2] * J[2][0];
            double A12 = J[0][2] * J[1][0] - J[0][0] * J[1][2];
            double A20 = J[1][0] * J[2][1] - J[1][1] * J[2][0];
            double A21 = J[0][1] * J[2][0] - J[0][0] * J[2][1];
            double A22 = J[0][0] * J[1][1] - J[0][1] * J[1][0];
            double inv_det = 1.0 / (J[0][0] * A00 + J[0][1] * A10 + J[0][2] * A20);
            double d0 = -(A00 * g[0] + A01 * g[1] + A02 * g[2]) * inv_det;
            double d1 = -(A10 * g[0] + A11 * g[1] + A12 * g[2]) * inv_det;
            double d2 = -(A20 * g[0] + A21 * g[1] + A22 * g[2]) * inv_det;
            f[0] += d0;
            f[1] += d1;
            f[2] += d2;
            it++;
            double dm = MAX(fabs(d0), MAX(fabs(d1), fabs(d2)));
            double fm = MAX(fabs(f[0]), MAX(fabs(f[1]), fabs(f[2])));
            if (dm <= 1e-15 * fm) break;
        }
        coefficients(f, &a, &b, &da, &db); /* a, b at the final f */
        if (it == 10) newton_capped++;
        newton_total += it;
        if (it > newton_max) newton_max = it;
        /* F = 1 + a hat(f) + b hat(f)^2 = 1 + a hat(f) + b (f f^T - |f|^2 1) */
        double t2 = f[0] * f[0] + f[1] * f[1] + f[2] * f[2];
        double F[9];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) F[3 * i + j] = b * f[i] * f[j];
        for (int i = 0; i < 3; i++) F[4 * i] += 1.0 - b * t2;
        F[1] -= a * f[2];
        F[2] += a * f[1];
        F[3] += a * f[2];
        F[5] -= a * f[0];
        F[6] -= a * f[1];
        F[7] += a * f[0];
        double Rn[9], Pn[3];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                Rn[3 * i + j] = R[3 * i] * F[j] + R[3 * i + 1] * F[3 + j] + R[3 * i + 2] * F[6 + j];
        for (int j = 0; j < 3; j++) Pn[j] = F[j] * Pi[0] + F[3 + j] * Pi[1] + F[6 + j] * Pi[2];
        memcpy(R, Rn, sizeof R);
        memcpy(Pi, Pn, sizeof Pi);
        if (every) {
            double e = orth_err(R);
            if (e > max_orth) max_orth = e;
        }
    }
    if (!every) max_orth = orth_err(R);
    double pi_norm = sqrt(Pi[0] * Pi[0] + Pi[1] * Pi[1] + Pi[2] * Pi[2]);
    double energy = 0.5 * (Pi[0] * Pi[0] / I[0] + Pi[1] * Pi[1] / I[1] + Pi[2] * Pi[2] / I[2]);
    printf("t %.17g\n", (double)steps * h);
    printf("R %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", R[0], R[1], R[2], R[3], R[4], R[5],
           R[6], R[7], R[8]);
    printf("Pi %.17g %.17g %.17g\n", Pi[0], Pi[1], Pi[2]);
    printf("w %.17g %.17g %.17g\n", Pi[0] / I[0], Pi[1] / I[1], Pi[2] / I[2]);
    printf("orth %.3e (%s)\n", max_orth, every ? "max over all steps" : "at the end");
    printf("dPi %.3e (relative change of |Pi|)\n", (pi_norm - pi_norm0) / pi_norm0);
    printf("dE %.3e (relative change of the energy)\n", (energy - energy0) / energy0);
    printf("newton %.3f mean, %d max, %d capped at 10\n", steps ? (double)newton_total / steps : 0.0, newton_max,
           newton_capped);
    return 0;
}
