#!/usr/bin/env python3
"""Reference solutions for rigid-body dynamics (issue 37, rotations as configuration variables).

Writes crates/femvi/tests/all/rigid_reference.json.  Standard library and mpmath only.

Conventions
-----------
R in SO(3) maps body to space (its columns are the body axes in space); w is the body angular
velocity, dR/dt = R hat(w) with hat(w) x = w x x; Pi = I w is the body angular momentum.
Row i of R hat(w) is (row i of R) x w, which is how the script writes dR/dt.

Case A, free rigid body:   I dw/dt = (I w) x w,                       dR/dt = R hat(w).
Case B, heavy top:         I dw/dt = (I w) x w + m g (R^T e3) x chi,   dR/dt = R hat(w).

Heavy-top torque, derived
-------------------------
Fixed point at the origin, z up, centre of mass at R chi (chi in the body frame), so
    L(R, w) = 1/2 w.I w - V(R),    V(R) = m g e3.(R chi).
Vary R by dR = R hat(eta) (eta a body-frame vector):
    dV = m g e3.(R hat(eta) chi) = m g e3.(R (eta x chi)) = m g Gamma.(eta x chi)
       = eta.(m g chi x Gamma),      Gamma := R^T e3 (the vertical seen in the body).
The reduced (Euler-Poincare) equation is d/dt Pi = Pi x w - dV/deta, so the body torque is
    tau = -m g chi x Gamma = m g Gamma x chi = m g (R^T e3) x chi.
Check by mechanics: the space torque about the fixed point is r x F = (R chi) x (-m g e3);
in the body frame R^T[(R chi) x (-m g e3)] = chi x (-m g Gamma) = m g Gamma x chi (same).
Check by energy: with E = 1/2 w.I w + m g e3.(R chi),
    dE/dt = w.(Pi x w + tau) + m g e3.(R hat(w) chi) = m g w.(Gamma x chi) + m g Gamma.(w x chi) = 0.
Also d(Gamma)/dt = -w x Gamma, so the vertical angular momentum e3.(R I w) = Gamma.Pi is conserved.
(The form "I dw/dt = (I w) x w + m g chi x (R^T e3)" has the opposite sign: it is the top with
gravity pointing up.)  The script checks E and Gamma.Pi along its solution.

Method
------
Both systems are quadratic polynomial ODEs in y = (R row-major, w), so the Taylor coefficients
of the solution about each step's start follow exactly from Cauchy products,
    y_{k+1} = [f(y)]_k / (k + 1),
and each step sums the series (Horner) at mpmath precision DPS decimal digits.  The order is
chosen per step: coefficients are added until |y_k| h^k < 10^-(DPS+5) for three consecutive k
(all components).  Output times are step boundaries (steps are exact binary fractions).  Every
case is integrated with step h and with h/2, and the largest difference over all reported
entries is printed and stored in the provenance.  An independent check at t = 1 uses
mpmath.odefun (mpmath's own Taylor integrator) on the same equations.

Usage:
    .venv/bin/python benches/peers/rigid_reference.py            # writes the JSON
    .venv/bin/python benches/peers/rigid_reference.py --check-c /tmp/lgvi
        # runs the C LGVI (benches/peers/lgvi.c) for h = 0.01, 0.005, 0.0025 to t = 1 and 10
        # and prints its error in R and w against the JSON and the observed orders.
    .venv/bin/python benches/peers/rigid_reference.py --time-c /tmp/lgvi [K]
        # process CPU time (user + sys) of 10^6 steps with h = 0.01: one warm-up, K (5) runs.
"""

import json
import math
import os
import re
import subprocess
import sys
import time

import mpmath
from mpmath import mp, mpf

DPS = 50
mp.dps = DPS

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
OUT = os.path.join(ROOT, "crates", "femvi", "tests", "all", "rigid_reference.json")


def cauchy(a, b, k):
    """k-th coefficient of the product of the series a and b."""
    return mpmath.fdot(zip(a[: k + 1], b[k::-1]))


class Body:
    """I = diag(inertia); gravity term m g (R^T e3) x chi when mg != 0."""

    def __init__(self, inertia, mg=0, chi=(0, 0, 0)):
        self.I = [mpf(x) for x in inertia]
        self.mg = mpf(mg)
        self.chi = [mpf(x) for x in chi]

    def rhs_coeff(self, c, k):
        """k-th Taylor coefficient of f(y), c[i] the coefficient lists of y (length > k)."""
        R = c[:9]
        w = c[9:]
        out = [None] * 12
        # rows of R x w
        for i in range(3):
            r0, r1, r2 = R[3 * i], R[3 * i + 1], R[3 * i + 2]
            out[3 * i + 0] = cauchy(r1, w[2], k) - cauchy(r2, w[1], k)
            out[3 * i + 1] = cauchy(r2, w[0], k) - cauchy(r0, w[2], k)
            out[3 * i + 2] = cauchy(r0, w[1], k) - cauchy(r1, w[0], k)
        I1, I2, I3 = self.I
        # (I w) x w = ((I2 - I3) w1 w2, (I3 - I1) w2 w0, (I1 - I2) w0 w1)
        t0 = (I2 - I3) * cauchy(w[1], w[2], k)
        t1 = (I3 - I1) * cauchy(w[2], w[0], k)
        t2 = (I1 - I2) * cauchy(w[0], w[1], k)
        if self.mg:
            g0, g1, g2 = R[6][k], R[7][k], R[8][k]  # Gamma = R^T e3 = third row of R
            x0, x1, x2 = self.chi
            t0 += self.mg * (g1 * x2 - g2 * x1)
            t1 += self.mg * (g2 * x0 - g0 * x2)
            t2 += self.mg * (g0 * x1 - g1 * x0)
        out[9] = t0 / I1
        out[10] = t1 / I2
        out[11] = t2 / I3
        return out

    def rhs(self, y):
        return self.rhs_coeff([[v] for v in y], 0)

    def step(self, y, h, stats):
        tol = mpf(10) ** (-(DPS + 5))
        c = [[v] for v in y]
        small = 0
        k = 0
        hk = mpf(1)
        while True:
            f = self.rhs_coeff(c, k)
            hk *= h
            big = 0
            for i in range(12):
                ck = f[i] / (k + 1)
                c[i].append(ck)
                big = max(big, abs(ck) * hk)
            k += 1
            small = small + 1 if big < tol else 0
            if small >= 3:
                break
            if k > 200:
                raise RuntimeError("Taylor series does not converge: step too large")
        stats["max_order"] = max(stats.get("max_order", 0), k)
        out = []
        for i in range(12):
            s = mpf(0)
            for ck in reversed(c[i]):
                s = s * h + ck
            out.append(s)
        return out

    def integrate(self, y0, times, h):
        """States at the given times (each a multiple of h) starting at t = 0."""
        y = list(y0)
        t = mpf(0)
        res = []
        stats = {}
        for T in times:
            n = int(mpmath.nint((mpf(T) - t) / h))
            assert abs(t + n * h - T) < mpf(10) ** (-DPS + 5)
            for _ in range(n):
                y = self.step(y, h, stats)
            t = mpf(T)
            res.append(list(y))
        return res, stats

    # invariants
    def energy(self, y):
        R, w = y[:9], y[9:]
        e = sum(self.I[i] * w[i] ** 2 for i in range(3)) / 2
        if self.mg:
            Rchi_z = R[6] * self.chi[0] + R[7] * self.chi[1] + R[8] * self.chi[2]
            e += self.mg * Rchi_z
        return e

    def Pi(self, y):
        return [self.I[i] * y[9 + i] for i in range(3)]

    def spatial_Pi(self, y):
        R, P = y[:9], self.Pi(y)
        return [sum(R[3 * i + j] * P[j] for j in range(3)) for i in range(3)]


def orth_err(R):
    m = 0
    for i in range(3):
        for j in range(3):
            s = sum(R[3 * k + i] * R[3 * k + j] for k in range(3)) - (1 if i == j else 0)
            m = max(m, abs(s))
    return m


def norm(v):
    return mpmath.sqrt(sum(x * x for x in v))


def fl(x):
    return float(x)


def run_case(body, y0, times, h):
    t0 = time.time()
    fine, st1 = body.integrate(y0, times, h)
    coarse_h = h * 2
    coarse, st2 = body.integrate(y0, times, coarse_h)
    diffs = [max(abs(a - b) for a, b in zip(yf, yc)) for yf, yc in zip(fine, coarse)]
    print(
        f"  h = {mpmath.nstr(h, 6)} and {mpmath.nstr(coarse_h, 6)}: max orders {st1['max_order']}, "
        f"{st2['max_order']}; {time.time() - t0:.1f} s"
    )
    for T, d, y in zip(times, diffs, fine):
        print(
            f"  t = {T:>5}: |y(h) - y(2h)|_max = {mpmath.nstr(d, 3)}, "
            f"|R^T R - 1|_max = {mpmath.nstr(orth_err(y[:9]), 3)}"
        )
    return fine, diffs


def odefun_check(body, y0, T=1):
    """Independent: mpmath.odefun (its own Taylor method) to t = T."""
    with mp.workdps(30):
        F = mpmath.odefun(lambda t, y: body.rhs(y), 0, [mpf(v) for v in y0], tol=mpf(10) ** -28)
        return F(T)


def rot_x(a):
    a = mpf(a)
    c, s = mpmath.cos(a), mpmath.sin(a)
    return [1, 0, 0, 0, c, -s, 0, s, c]


def states_json(times, ys):
    return [{"t": float(T), "R": [fl(x) for x in y[:9]], "w": [fl(x) for x in y[9:]]} for T, y in zip(times, ys)]


def main():
    t_start = time.time()
    I = [1, 2, 3]
    w0 = [mpf("0.5"), mpf(1), mpf("0.3")]

    # ---- Case A: free rigid body
    print("Case A: free rigid body")
    A = Body(I)
    yA0 = [mpf(v) for v in [1, 0, 0, 0, 1, 0, 0, 0, 1]] + w0
    tA = [1, 2, 10, 100]
    hA = mpf(1) / 16
    yA, dA = run_case(A, yA0, tA, hA)
    EA0, EA1 = A.energy(yA0), A.energy(yA[-1])
    PA0, PA1 = norm(A.Pi(yA0)), norm(A.Pi(yA[-1]))
    sA0, sA1 = A.spatial_Pi(yA0), A.spatial_Pi(yA[-1])
    dsA = max(abs(a - b) for a, b in zip(sA0, sA1))
    print(f"  energy {mpmath.nstr(EA0, 20)}, change to t=100 {mpmath.nstr(EA1 - EA0, 3)}")
    print(f"  |Pi| {mpmath.nstr(PA0, 20)}, change {mpmath.nstr(PA1 - PA0, 3)}; R Pi change {mpmath.nstr(dsA, 3)}")
    ref1 = odefun_check(A, yA0)
    oA = max(abs(a - b) for a, b in zip(ref1, yA[0]))
    print(f"  mpmath.odefun at t = 1 (tol 1e-28, 30 digits): max difference {mpmath.nstr(oA, 3)}")

    # ---- Case B: heavy top
    print("Case B: heavy top")
    mg = mpf(1) * mpf("9.81")
    chi = [mpf("0.1"), mpf("0.2"), mpf("0.5")]
    B = Body(I, mg, chi)
    yB0 = [mpf(v) for v in rot_x("0.5")] + w0
    tB = [1, 2, 10]
    hB = mpf(1) / 32
    yB, dB = run_case(B, yB0, tB, hB)
    EB = [B.energy(yB0)] + [B.energy(y) for y in yB]
    vB = [sum(y[6 + j] * B.Pi(y)[j] for j in range(3)) for y in [yB0] + yB]
    dEB = max(abs(e - EB[0]) for e in EB)
    dvB = max(abs(v - vB[0]) for v in vB)
    print(f"  energy {mpmath.nstr(EB[0], 20)}, max change {mpmath.nstr(dEB, 3)}")
    print(f"  e3.(R I w) {mpmath.nstr(vB[0], 20)}, max change {mpmath.nstr(dvB, 3)}")
    ref1B = odefun_check(B, yB0)
    oB = max(abs(a - b) for a, b in zip(ref1B, yB[0]))
    print(f"  mpmath.odefun at t = 1 (tol 1e-28, 30 digits): max difference {mpmath.nstr(oB, 3)}")

    def g(x):
        return mpmath.nstr(x, 2)

    provenance = (
        "benches/peers/rigid_reference.py: Taylor-series integration (coefficients by Cauchy "
        f"products of the quadratic ODE in (R row-major, w), order chosen per step until "
        f"|y_k| h^k < 1e-{DPS + 5} three times running) in mpmath at {DPS} significant digits. "
        f"Case A with h = 1/16 against h = 1/8: max difference over all reported entries "
        f"{g(max(dA))} (t=1: {g(dA[0])}, t=100: {g(dA[-1])}); case B with h = 1/32 against "
        f"h = 1/16: {g(max(dB))}. mpmath.odefun (independent Taylor code, 30 digits, tol 1e-28) "
        f"at t = 1: {g(oA)} (A), {g(oB)} (B). Invariants along the stored solution: A energy "
        f"change {g(EA1 - EA0)}, |Pi| change {g(PA1 - PA0)}, R Pi change {g(dsA)} to t = 100; "
        f"B energy change {g(dEB)}, e3.(R I w) change {g(dvB)} to t = 10. "
        "Heavy-top body torque m g (R^T e3) x chi, from V(R) = m g e3.(R chi). "
        "Numbers are the 50-digit values rounded to double."
    )

    data = {
        "provenance": provenance,
        "conventions": "R maps body to space (columns are body axes in space), R row-major; "
        "dR/dt = R hat(w), hat(w) x = w x x; w body angular velocity; Pi = I w.",
        "free_body": {
            "case": "A",
            "equations": "I dw/dt = (I w) x w, dR/dt = R hat(w)",
            "inertia": [1.0, 2.0, 3.0],
            "R0": [fl(x) for x in yA0[:9]],
            "w0": [fl(x) for x in w0],
            "states": states_json(tA, yA),
            "energy_t0": fl(EA0),
            "energy_end": fl(EA1),
            "Pi_norm_t0": fl(PA0),
            "Pi_norm_end": fl(PA1),
            "spatial_Pi_t0": [fl(x) for x in sA0],
            "spatial_Pi_end": [fl(x) for x in sA1],
            "t_end": 100.0,
        },
        "heavy_top": {
            "case": "B",
            "equations": "I dw/dt = (I w) x w + m g (R^T e3) x chi, dR/dt = R hat(w); "
            "L = 1/2 w.I w - m g e3.(R chi), fixed point at the origin, z up",
            "inertia": [1.0, 2.0, 3.0],
            "m": 1.0,
            "g": 9.81,
            "chi": [0.1, 0.2, 0.5],
            "R0": [fl(x) for x in yB0[:9]],
            "w0": [fl(x) for x in w0],
            "states": states_json(tB, yB),
            "energy_t0": fl(EB[0]),
            "energy_end": fl(EB[-1]),
            "vertical_Pi_t0": fl(vB[0]),
            "vertical_Pi_end": fl(vB[-1]),
            "t_end": 10.0,
        },
    }
    text = json.dumps(data, indent=1)
    # one line per list of numbers
    text = re.sub(r"\[\s*([-+0-9.e,\s]+?)\s*\]", lambda m: "[" + ", ".join(x.strip() for x in m.group(1).split(",")) + "]", text)
    assert json.loads(text) == data
    with open(OUT, "w") as f:
        f.write(text + "\n")
    print(f"wrote {OUT} ({time.time() - t_start:.0f} s)")


def check_lgvi_equation():
    """vee(F J_d - J_d F^T) against a I f + b f x (I f) for F = exp(hat f), one f, 30 digits."""
    with mp.workdps(30):
        I = mpmath.diag([1, 2, 3])
        Jd = mpf(3) * mpmath.eye(3) - I  # 1/2 tr(I) 1 - I
        f = [mpf("0.3"), mpf("-0.7"), mpf("0.45")]
        hat = mpmath.matrix([[0, -f[2], f[1]], [f[2], 0, -f[0]], [-f[1], f[0], 0]])
        F = mpmath.expm(hat)
        M = F * Jd - Jd * F.T
        t = norm(f)
        a, b = mpmath.sin(t) / t, (1 - mpmath.cos(t)) / t**2
        If = [I[i, i] * f[i] for i in range(3)]
        c = [f[1] * If[2] - f[2] * If[1], f[2] * If[0] - f[0] * If[2], f[0] * If[1] - f[1] * If[0]]
        d = max(abs(x - (a * If[i] + b * c[i])) for i, x in enumerate([M[2, 1], M[0, 2], M[1, 0]]))
        print(f"LGVI step equation, vector form against matrix form at |f| = {mpmath.nstr(t, 3)}: {mpmath.nstr(d, 2)}")


def check_c(exe):
    """Error of the C LGVI against the JSON at t = 1 and 10; observed orders."""
    check_lgvi_equation()
    with open(OUT) as f:
        ref = {s["t"]: s for s in json.load(f)["free_body"]["states"]}
    for T in (1, 10):
        errs = []
        for h, n in ((0.01, 100 * T), (0.005, 200 * T), (0.0025, 400 * T)):
            out = subprocess.run([exe, str(n), repr(h)], capture_output=True, text=True, check=True).stdout
            vals = {}
            for line in out.splitlines():
                parts = line.split()
                if parts and parts[0] in ("R", "w"):
                    vals[parts[0]] = [float(x) for x in parts[1:]]
            eR = max(abs(a - b) for a, b in zip(vals["R"], ref[float(T)]["R"]))
            ew = max(abs(a - b) for a, b in zip(vals["w"], ref[float(T)]["w"]))
            errs.append((h, eR, ew))
        for i, (h, eR, ew) in enumerate(errs):
            o = ""
            if i:
                o = (
                    f"  order R {math.log2(errs[i - 1][1] / eR):.3f}"
                    f"  order w {math.log2(errs[i - 1][2] / ew):.3f}"
                )
            print(f"t = {T:>2}  h = {h:<7} max|R - Rref| = {eR:.3e}  max|w - wref| = {ew:.3e}{o}")


def time_c(exe, reps=5, steps=1000000, h=0.01):
    """Process CPU time (user + sys, from wait4's rusage) of the C LGVI, one warm-up, then reps."""
    times = []
    for r in range(reps + 1):
        p = subprocess.Popen([exe, str(steps), repr(h)], stdout=subprocess.DEVNULL)
        _, status, ru = os.wait4(p.pid, 0)
        p.returncode = status
        if r:
            times.append(ru.ru_utime + ru.ru_stime)
    times.sort()
    med = times[len(times) // 2]
    print("CPU s: " + " ".join(f"{t:.4f}" for t in times))
    print(f"median {med:.4f} s for {steps} steps: {med / steps * 1e9:.1f} ns per step")


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--check-c":
        check_c(sys.argv[2])
    elif len(sys.argv) > 2 and sys.argv[1] == "--time-c":
        time_c(sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 5)
    else:
        main()
