/* RATTLE (Andersen 1983; Hairer-Lubich-Wanner, Geometric Numerical Integration, VII.1.4) for
 * the spherical pendulum in Cartesian coordinates, written out by hand: the peer of
 * `femvi run` on examples/constrained/spherical-pendulum.toml at degree 1 with the trapezoid
 * rule (rattle.md).
 *
 *   L = m/2 |v|^2 - m g z,   g(q) = |q|^2 - l^2,   G(q) = 2 q^T,   M = m I,  F = (0, 0, -m g),
 *
 *   q_{k+1} = q_k + (h/m) (p_k + (h/2) F - G(q_k)^T lambda),   |q_{k+1}|^2 = l^2,
 *   p~ = m (q_{k+1} - q_k)/h + (h/2) F,   p_{k+1} = p~ - G(q_{k+1})^T mu,   q_{k+1} . p_{k+1} = 0.
 *
 * The position constraint is a quadratic in the multiplier: with the unconstrained drift
 * e = (h/m)(p_k + (h/2) F) and the increment d = e - c q_k,
 *   |q|^2 c^2 - 2 c (|q|^2 + q.e) + (|q|^2 - l^2 + 2 q.e + |e|^2) = 0,
 * whose smaller root is taken in the form without cancellation. q is accumulated with
 * compensated summation, as femvi keeps its nodes. The projection is a dot product.
 *
 * Usage: rattle [STEPS [H]]  (defaults 1000000 and 0.01); prints t, q, p of the last node
 * with 17 significant digits.
 *
 * Build: gcc -O2 -o rattle rattle.c -lm
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

int main(int argc, char **argv) {
    long steps = argc > 1 ? atol(argv[1]) : 1000000;
    double h = argc > 2 ? atof(argv[2]) : 0.01;
    const double mass = 1.0, grav = 9.81, len = 1.0;
    /* The example's start: theta = 1 from the downward vertical, v tangent (already on T*N). */
    double q[3] = {0.8414709848078965, 0.0, -0.5403023058681398};
    double p[3] = {0.0, mass * 1.682941969615793, 0.0};
    double comp[3] = {0.0, 0.0, 0.0};
    const double force[3] = {0.0, 0.0, -mass * grav};
    for (long k = 0; k < steps; k++) {
        double e[3], d[3], q1[3], pt[3];
        for (int i = 0; i < 3; i++) {
            e[i] = h / mass * (p[i] + 0.5 * h * force[i]);
        }
        double qq = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
        double qe = q[0] * e[0] + q[1] * e[1] + q[2] * e[2];
        double ee = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
        double b = qq + qe;
        double c0 = (qq - len * len) + 2.0 * qe + ee;
        double c = c0 / (b + sqrt(b * b - qq * c0));
        for (int i = 0; i < 3; i++) {
            d[i] = e[i] - c * q[i];
            double y = d[i] + comp[i];
            q1[i] = q[i] + y;
            comp[i] = y - (q1[i] - q[i]);
            pt[i] = mass * d[i] / h + 0.5 * h * force[i];
        }
        double mu = (q1[0] * pt[0] + q1[1] * pt[1] + q1[2] * pt[2]) /
                    (q1[0] * q1[0] + q1[1] * q1[1] + q1[2] * q1[2]);
        for (int i = 0; i < 3; i++) {
            p[i] = pt[i] - mu * q1[i];
            q[i] = q1[i];
        }
    }
    printf("t %.17g\n", (double)steps * h);
    printf("q %.17g %.17g %.17g\n", q[0], q[1], q[2]);
    printf("p %.17g %.17g %.17g\n", p[0], p[1], p[2]);
    return 0;
}
