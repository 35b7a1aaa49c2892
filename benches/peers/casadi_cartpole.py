"""Independent reference solution of the cart-pole swing-up with CasADi + IPOPT.

Problem: q = (x, theta), mc = 2.0, mp = 0.5, l = 0.5, g = 9.81,
  L = 0.5 (mc+mp) xdot^2 + mp l xdot thetadot cos(theta) + 0.5 mp l^2 thetadot^2
      + mp g l cos(theta)          (theta = 0 hangs down, theta = pi upright),
generalised force (u, 0). Euler-Lagrange, solved for the accelerations:
  [mc+mp        mp l cos th] [xddot ]   [u + mp l thetadot^2 sin th]
  [mp l cos th  mp l^2     ] [thddot] = [-mp g l sin th            ]
Horizon [0, 2]; x, theta, xdot, thetadot = 0 at t = 0; (0.8, pi, 0, 0) at t = 2;
-100 <= u <= 100; minimise int_0^2 u^2 dt.

Transcription: orthogonal collocation on N uniform intervals, degree d (default 3)
Legendre-Gauss-Radau points (Radau IIA; --scheme legendre for Gauss points), state
polynomial through the interval start and the d collocation points, one control value per
collocation point, cost by the collocation quadrature h sum_j b_j u_j^2. Solved by IPOPT
(exact Hessian, MUMPS, tol 1e-12 by default, print_level 0).

Initial guesses (--guess): line (x, theta linear to (0.8, pi), constant velocities, u = 0),
neg (theta = pi s - 3 sin(pi s), dips negative first), over (theta = pi s + 2 sin(pi s),
overshoots pi), swing (theta = pi s + 2.5 sin(3 pi s)), wrap (theta = pi s - 2 pi sin(pi s)^2,
down to about -4.7 first), sin:A:k (theta = pi s + A sin(k pi s)),
file:PATH (interpolate a CSV written by --csv: warm start), randu (line states, u uniform
random in [-50, 50], --seed), where s = t/2; the velocities of every guess are the
derivatives of its positions.

Usage:
  nice -n 19 env OMP_NUM_THREADS=1 python casadi_cartpole.py --N 25 50 100 --guess line
  ... --N 800 --guess line --csv /tmp/casadi_ref/line_solution.csv
  ... --N 200 --guess line --repeat 5          (median process CPU time of the solve)
  ... --json out.json                          (machine-readable results, one per N)
Prints one line per mesh: N, cost, IPOPT status, iterations, build and solve CPU seconds,
and a description of the path (min/max theta, swings, max |u|, active bounds).
"""

import argparse
import json
import math
import statistics
import sys
import time

import casadi as ca
import numpy as np

MC, MP, L, G = 2.0, 0.5, 0.5, 9.81
T = 2.0
X0 = [0.0, 0.0, 0.0, 0.0]
XF = [0.8, math.pi, 0.0, 0.0]
UMAX = 100.0


def dynamics():
    s = ca.SX.sym("s", 4)
    u = ca.SX.sym("u")
    th, xd, td = s[1], s[2], s[3]
    c, sn = ca.cos(th), ca.sin(th)
    m11, m12, m22 = MC + MP, MP * L * c, MP * L * L
    r1 = u + MP * L * td * td * sn
    r2 = -MP * G * L * sn
    det = m11 * m22 - m12 * m12
    xdd = (m22 * r1 - m12 * r2) / det
    tdd = (m11 * r2 - m12 * r1) / det
    return ca.Function("f", [s, u], [ca.vertcat(xd, td, xdd, tdd)])


def coefficients(d, scheme):
    """Collocation data on [0, 1]: nodes tau (tau_0 = 0), C[r, j] = l_r'(tau_j), D[r] = l_r(1),
    B[r] = int_0^1 l_r. Barycentric formulas (the derivative matrix's diagonal by the
    negative-sum rule, so constants have zero derivative to round-off): the naive monomial
    expansion loses ~1e-13 at degree 5, which drifts the states by O(N eps) and shows in J."""
    tau = np.array([0.0] + list(ca.collocation_points(d, scheme)))
    n = d + 1
    w = np.array([1.0 / np.prod([tau[r] - tau[m] for m in range(n) if m != r]) for r in range(n)])
    C = np.zeros((n, n))
    for j in range(n):
        for r in range(n):
            if r != j:
                C[r, j] = (w[r] / w[j]) / (tau[j] - tau[r])
        C[j, j] = -sum(C[r, j] for r in range(n) if r != j)

    def basis(r, t):
        return np.prod([(t - tau[m]) / (tau[r] - tau[m]) for m in range(n) if m != r], axis=0)

    D = np.array([basis(r, 1.0) for r in range(n)])
    gx, gw = np.polynomial.legendre.leggauss(n + 1)
    gx, gw = 0.5 * (gx + 1.0), 0.5 * gw
    B = np.array([np.dot(gw, basis(r, gx)) for r in range(n)])
    return tau, C, D, B


def guess_paths(name, t, seed):
    s = t / T
    if name == "line":
        th, thd = math.pi * s, math.pi / T * np.ones_like(s)
    elif name == "neg":
        th = math.pi * s - 3.0 * np.sin(math.pi * s)
        thd = (math.pi - 3.0 * math.pi * np.cos(math.pi * s)) / T
    elif name == "over":
        th = math.pi * s + 2.0 * np.sin(math.pi * s)
        thd = (math.pi + 2.0 * math.pi * np.cos(math.pi * s)) / T
    elif name == "swing":
        th = math.pi * s + 2.5 * np.sin(3 * math.pi * s)
        thd = (math.pi + 7.5 * math.pi * np.cos(3 * math.pi * s)) / T
    elif name == "wrap":
        # theta goes down towards about -pi first, then back up through 0 to pi
        th = math.pi * s - 2 * math.pi * np.sin(math.pi * s) ** 2
        thd = (math.pi - 4 * math.pi * math.pi * np.sin(math.pi * s) * np.cos(math.pi * s)) / T
    elif name.startswith("sin:"):
        A, k = (float(v) for v in name.split(":")[1:3])
        th = math.pi * s + A * np.sin(k * math.pi * s)
        thd = (math.pi + A * k * math.pi * np.cos(k * math.pi * s)) / T
    elif name == "randu":
        th, thd = math.pi * s, math.pi / T * np.ones_like(s)
    else:
        raise SystemExit("unknown guess " + name)
    x = 0.8 * s
    xd = 0.8 / T * np.ones_like(s)
    return np.vstack([x, th, xd, thd])


def build(N, d, scheme):
    t0 = time.process_time()
    tau, C, D, B = coefficients(d, scheme)
    h = T / N
    f = dynamics()
    W = ca.SX.sym("W", 4, N * (d + 1) + 1)  # per interval: start + d collocation states; final
    U = ca.SX.sym("U", 1, N * d)
    Cm = ca.DM(C[:, 1:])
    Dm = ca.DM(D)
    deriv, colx, cont = [], [], []
    for k in range(N):
        Wk = W[:, k * (d + 1):(k + 1) * (d + 1)]
        deriv.append(ca.mtimes(Wk, Cm))
        colx.append(Wk[:, 1:])
        cont.append(W[:, (k + 1) * (d + 1)] - ca.mtimes(Wk, Dm))
    F = f.map(N * d)
    dyn = ca.horzcat(*deriv) - h * F(ca.horzcat(*colx), U)
    g = ca.vertcat(ca.vec(dyn), ca.vec(ca.horzcat(*cont)))
    Bu = np.tile(B[1:], N)
    J = h * ca.dot(ca.DM(Bu), ca.vec(U) ** 2)
    z = ca.vertcat(ca.vec(W), ca.vec(U))
    nlp = {"x": z, "f": J, "g": g}
    return nlp, tau, h, time.process_time() - t0


def make_solver(nlp, tol, max_iter):
    opts = {
        "ipopt.tol": tol,
        "ipopt.print_level": 0,
        "ipopt.max_iter": max_iter,
        "ipopt.linear_solver": "mumps",
        "print_time": False,
        "ipopt.sb": "yes",
    }
    return ca.nlpsol("solver", "ipopt", nlp, opts)


def times_of(N, d, tau, h):
    tW = np.array([k * h + h * tau[r] for k in range(N) for r in range(d + 1)] + [T])
    tU = np.array([k * h + h * tau[r] for k in range(N) for r in range(1, d + 1)])
    return tW, tU


def solve(N, d, scheme, guess, seed, tol, max_iter, repeat):
    nlp, tau, h, tbuild = build(N, d, scheme)
    t1 = time.process_time()
    solver = make_solver(nlp, tol, max_iter)
    tsolver = time.process_time() - t1
    tW, tU = times_of(N, d, tau, h)
    nW = 4 * len(tW)
    Ug = np.zeros(len(tU))
    if guess.startswith("file:"):
        ref = np.loadtxt(guess[5:], delimiter=",", skiprows=1)
        Wg = np.vstack([np.interp(tW, ref[:, 0], ref[:, i]) for i in range(1, 5)])
        Ug = np.interp(tU, ref[:, 0], ref[:, 5])
    else:
        Wg = guess_paths(guess, tW, seed)
    if guess == "randu":
        Ug = np.random.default_rng(seed).uniform(-50, 50, len(tU))
    z0 = np.concatenate([Wg.flatten(order="F"), Ug])
    lbx = -np.inf * np.ones(nW + len(tU))
    ubx = np.inf * np.ones(nW + len(tU))
    lbx[nW:], ubx[nW:] = -UMAX, UMAX
    lbx[0:4] = ubx[0:4] = X0
    lbx[nW - 4:nW] = ubx[nW - 4:nW] = XF
    z0[0:4] = X0
    z0[nW - 4:nW] = XF
    ng = nlp["g"].shape[0]
    args = dict(x0=z0, lbx=lbx, ubx=ubx, lbg=np.zeros(ng), ubg=np.zeros(ng))
    cpu = []
    for _ in range(repeat):
        ts = time.process_time()
        sol = solver(**args)
        cpu.append(time.process_time() - ts)
    st = solver.stats()
    z = np.array(sol["x"]).ravel()
    Ws = z[:nW].reshape((len(tW), 4)).T
    Us = z[nW:]
    return dict(
        N=N, d=d, scheme=scheme, guess=guess, seed=seed,
        J=float(sol["f"]), status=st["return_status"], success=bool(st["success"]),
        iters=int(st["iter_count"]), build_cpu=tbuild, solver_setup_cpu=tsolver,
        solve_cpu=cpu, solve_cpu_median=statistics.median(cpu),
        nvar=int(z.size), ncon=int(ng),
    ), (tW, Ws, tU, Us, tau, d, N)


def describe(raw):
    tW, Ws, tU, Us, tau, d, N = raw
    th = Ws[1]
    td = Ws[3]
    # direction reversals of theta (sign changes of thetadot away from the ends)
    keep = np.abs(td) > 1e-6
    sgn, thk, tk = np.sign(td[keep]), th[keep], tW[keep]
    flips = np.nonzero(sgn[1:] != sgn[:-1])[0]
    rev = int(flips.size)
    extrema = [(round(float(tk[i]), 3), round(float(thk[i]), 4)) for i in flips]
    umax = float(np.max(np.abs(Us)))
    return dict(
        theta_min=float(th.min()), theta_max=float(th.max()),
        x_min=float(Ws[0].min()), x_max=float(Ws[0].max()),
        theta_reversals=rev, umax=umax, u_bound_active=bool(umax > UMAX - 1e-6),
        u0=float(Us[0]), uT=float(Us[-1]), theta_extrema=extrema,
    )


def write_csv(path, raw):
    tW, Ws, tU, Us, tau, d, N = raw
    # rows at the mesh points and collocation points; u at the interval start is
    # the value of the control (interpolated through the collocation values in the interval)
    rows = []
    for k in range(N):
        for r in range(d + 1):
            if r == 0 and k > 0 and tau[d] == 1.0:
                continue  # Radau: interval start duplicates the previous end point
            i = k * (d + 1) + r
            if r == 0:
                uc = Us[k * d:(k + 1) * d]
                tc = tau[1:]
                # Lagrange interpolation of the control at tau = 0
                u = sum(uc[j] * np.prod([(0 - tc[m]) / (tc[j] - tc[m]) for m in range(d) if m != j])
                        for j in range(d))
            else:
                u = Us[k * d + r - 1]
            rows.append((tW[i], *Ws[:, i], u))
    if tau[d] != 1.0:
        rows.append((tW[-1], *Ws[:, -1], Us[-1]))
    with open(path, "w") as fh:
        fh.write("t,x,theta,xdot,thetadot,u\n")
        for r in rows:
            fh.write(",".join("%.17g" % v for v in r) + "\n")
    return len(rows)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--N", type=int, nargs="+", default=[25, 50, 100, 200, 400, 800])
    ap.add_argument("--guess", default="line")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--degree", type=int, default=3)
    ap.add_argument("--scheme", default="radau", choices=["radau", "legendre"])
    ap.add_argument("--tol", type=float, default=1e-12)
    ap.add_argument("--max-iter", type=int, default=3000)
    ap.add_argument("--repeat", type=int, default=1, help="solve this many times, report median CPU")
    ap.add_argument("--csv", help="write the (last mesh's) solution to this CSV")
    ap.add_argument("--json", help="append results as JSON lines to this file")
    a = ap.parse_args()
    for N in a.N:
        res, raw = solve(N, a.degree, a.scheme, a.guess, a.seed, a.tol, a.max_iter, a.repeat)
        res.update(describe(raw))
        print("N=%4d d=%d %s guess=%s seed=%d  J=%.15g  %s iters=%d build=%.3fs setup=%.3fs "
              "solve=%.3fs (median of %d)  th=[%.4f, %.4f] rev=%d max|u|=%.4f bound=%s x=[%.4f, %.4f] extrema(t,theta)=%s"
              % (N, a.degree, a.scheme, a.guess, a.seed, res["J"], res["status"], res["iters"],
                 res["build_cpu"], res["solver_setup_cpu"], res["solve_cpu_median"], a.repeat,
                 res["theta_min"], res["theta_max"], res["theta_reversals"], res["umax"],
                 res["u_bound_active"], res["x_min"], res["x_max"], res["theta_extrema"]),
              flush=True)
        if a.json:
            with open(a.json, "a") as fh:
                fh.write(json.dumps(res) + "\n")
    if a.csv:
        n = write_csv(a.csv, raw)
        print("wrote %d rows to %s" % (n, a.csv))


if __name__ == "__main__":
    sys.exit(main())
