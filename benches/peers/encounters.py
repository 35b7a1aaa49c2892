"""Close encounters (issue 21, item 4): the Arenstorf orbit and the Pleiades, femvi's adaptive
and fixed steps against REBOUND IAS15 and scipy DOP853 in the same run, errors against
published reference values, CPU time.

Arenstorf (Hairer, Norsett, Wanner, Solving ODEs I, section II.0): the restricted three-body
problem in the frame rotating with the Earth (mass 1 - mu at x = -mu) and the Moon (mu at
1 - mu), mu = 0.012277471, periodic with T = 17.0652165601579625588917206249 from
(0.994, 0, 0, -2.00158510637908252240537862224). Reference: the initial state itself after
whole periods. femvi integrates L = |v|^2/2 + x y_dot - y x_dot + |q|^2/2 + (1 - mu)/r_E
+ mu/r_M (an expression, gyroscopic) with the monitor g = ((1 - mu)/r_E^3 + mu/r_M^3)^(-1/2);
DOP853 the equations of HNW (II.0.1); REBOUND has no rotating frame, so IAS15 integrates the
same motion in the inertial frame (Earth and Moon as two bodies of masses 1 - mu and mu on
their circular orbit, the satellite a test particle) and the state is rotated back by the
angle t. The orbit is unstable: the error grows by about the monodromy matrix's largest
eigenvalue per period (printed), so after about six periods any double-precision run has lost
it (the rounding of the initial state alone, 1e-16, grows to O(1)). The table is therefore
for one period (HNW's own setting, x_end = T), and a second table gives each code's error
after k = 1 ... 10 periods.

Pleiades (HNW I, section II.10): seven bodies in the plane, m_i = i, G = 1, t in [0, 3].
Reference: the solution at t = 3 of the Test Set for IVP Solvers (Mazzia, Magherini, problem
PLEI, 16 digits).

Errors: "position" is the Euclidean norm of the position error (2 or 14 components), "state"
the Euclidean norm over positions and velocities (HNW's error at the endpoint), both against
the reference at the time the run ended: fixed steps, IAS15 and DOP853 land on the end time;
femvi's adaptive runs end on the first node past it (q and the discrete momentum p there),
and the reference is carried to that time by DOP853 over that short interval (`reference`).
The growth table reads femvi's states at whole periods from the element polynomial in s
(`output_step` rows), whose positions are as accurate as the nodes' (its velocities less). CPU: process time for the
in-process Python codes, the child's user + system time for femvi (including process start,
about 3 ms, and compiling the expression Lagrangian). Every configuration runs `--rounds`
times, alternating codes; the least CPU time is kept (results are identical between rounds).

Usage: python encounters.py [--femvi PATH] [--rounds N]
Writes encounters.csv next to this script and prints the tables (markdown).
"""

import argparse
import csv
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np
import rebound
from scipy.integrate import solve_ivp

HERE = os.path.dirname(os.path.abspath(__file__))

MU = 0.012277471
PERIOD = 17.0652165601579625588917206249
AREN_Q0 = np.array([0.994, 0.0])
AREN_V0 = np.array([0.0, -2.00158510637908252240537862224])

PLEI_MASSES = np.arange(1.0, 8.0)
PLEI_X0 = [3.0, 3.0, -1.0, -3.0, 2.0, -2.0, 2.0]
PLEI_Y0 = [3.0, -3.0, 2.0, 0.0, 0.0, -4.0, 4.0]
PLEI_VX0 = [0.0, 0.0, 0.0, 0.0, 0.0, 1.75, -1.5]
PLEI_VY0 = [0.0, 0.0, 0.0, -1.25, 1.0, 0.0, 0.0]
# Test Set for IVP Solvers, PLEI: x_1..x_7, y_1..y_7, x'_1..x'_7, y'_1..y'_7 at t = 3.
PLEI_REF = np.array([
    0.3706139143970502, 0.3237284092057233e1, -0.3222559032418324e1, 0.6597091455775310,
    0.3425581707156584, 0.1562172101400631e1, -0.7003092922212495, -0.3943437585517392e1,
    -0.3271380973972550e1, 0.5225081843456543e1, -0.2590612434977470e1, 0.1198213693392275e1,
    -0.2429682344935824, 0.1091449240428980e1, 0.3417003806314313e1, 0.1354584501625501e1,
    -0.2590065597810775e1, 0.2025053734714242e1, -0.1155815100160448e1, -0.8072988170223021,
    0.5952396354208710, -0.3741244961234010e1, 0.3773459685750630, 0.9386858869551073,
    0.3667922227200571, -0.3474046353808490, 0.2344915448180937e1, -0.1947020434263292e1,
])

AREN_LAGRANGIAN = ("0.5*(x_dot^2 + y_dot^2) + x*y_dot - y*x_dot + 0.5*(x^2 + y^2) "
                   "+ (1 - mu)/sqrt((x + mu)^2 + y^2) + mu/sqrt((x - 1 + mu)^2 + y^2)")
AREN_MONITOR = "((1 - mu)/((x + mu)^2 + y^2)^1.5 + mu/((x - 1 + mu)^2 + y^2)^1.5)^(-0.5)"


def arenstorf_rhs(_t, y):
    """HNW I (II.0.1) as a first-order system (x, y, x', y')."""
    x, yy, vx, vy = y
    m1 = 1.0 - MU
    d1 = ((x + MU) ** 2 + yy ** 2) ** 1.5
    d2 = ((x - m1) ** 2 + yy ** 2) ** 1.5
    return [vx, vy, x + 2 * vy - m1 * (x + MU) / d1 - MU * (x - m1) / d2,
            yy - 2 * vx - m1 * yy / d1 - MU * yy / d2]


def pleiades_rhs(_t, y):
    x, yy = y[:7], y[7:14]
    dx = x[None, :] - x[:, None]
    dy = yy[None, :] - yy[:, None]
    r3 = (dx * dx + dy * dy) ** 1.5
    np.fill_diagonal(r3, np.inf)
    return np.concatenate([y[14:], (PLEI_MASSES[None, :] * dx / r3).sum(1),
                           (PLEI_MASSES[None, :] * dy / r3).sum(1)])


def arenstorf_jacobian(y):
    """d(rhs)/dy of HNW I (II.0.1): gravity of each primary -m (I/r^3 - 3 d d^T/r^5)."""
    u = np.array(y[:2])
    jac = np.zeros((4, 4))
    jac[0, 2] = jac[1, 3] = 1.0
    acc = np.eye(2)
    for m, c in ((1.0 - MU, np.array([-MU, 0.0])), (MU, np.array([1.0 - MU, 0.0]))):
        d = u - c
        r2 = d @ d
        acc -= m * (np.eye(2) / r2 ** 1.5 - 3.0 * np.outer(d, d) / r2 ** 2.5)
    jac[2:, :2] = acc
    jac[2, 3], jac[3, 2] = 2.0, -2.0
    return jac


def monodromy_eigenvalue():
    """The largest |eigenvalue| of the Arenstorf orbit's monodromy matrix (the variational
    equations over one period by DOP853 at rtol 1e-13): the error's growth factor per period."""
    def f(t, z):
        y, m = z[:4], z[4:].reshape(4, 4)
        return np.concatenate([arenstorf_rhs(t, y), (arenstorf_jacobian(y) @ m).ravel()])
    z0 = np.concatenate([AREN_Q0, AREN_V0, np.eye(4).ravel()])
    sol = solve_ivp(f, (0.0, PERIOD), z0, method="DOP853", rtol=1e-13, atol=1e-15)
    return max(abs(np.linalg.eigvals(sol.y[4:, -1].reshape(4, 4))))


# ---------------------------------------------------------------------------------- femvi

def femvi_problem(which, order, ds=None, h=None, end=None, output_step=None):
    """Problem text for femvi: adaptive (ds) or fixed steps (h)."""
    if which == "arenstorf":
        system = (f'[system]\ncoordinates = ["x", "y"]\nparameters = {{ mu = {MU!r} }}\n'
                  f'lagrangian = "{AREN_LAGRANGIAN}"\n'
                  f"[initial]\nq = [{float(AREN_Q0[0])!r}, 0.0]\nv = [0.0, {float(AREN_V0[1])!r}]\n")
        monitor = AREN_MONITOR
    else:
        masses = ", ".join(f"m{i} = {float(m)!r}" for i, m in enumerate(PLEI_MASSES))
        q = ", ".join(f"{x!r}, {y!r}" for x, y in zip(PLEI_X0, PLEI_Y0))
        v = ", ".join(f"{x!r}, {y!r}" for x, y in zip(PLEI_VX0, PLEI_VY0))
        system = (f'[system]\nmodel = "n-body"\nparameters = {{ bodies = 7, dim = 2, G = 1.0, {masses} }}\n'
                  f"[initial]\nq = [{q}]\nv = [{v}]\n")
        monitor = "nbody"
    scheme = f'[scheme]\ndegree = {order // 2}\nquadrature = "gauss-legendre"\n'
    if ds is not None:
        time_table = (f'mode = "adaptive"\nmonitor = "{monitor}"\nds = {ds!r}\nend = {end!r}\n'
                      f"output_step = {output_step!r}\n")
    else:
        time_table = f"step = {h!r}\nend = {end!r}\n"
    return f'name = "{which}"\n{system}{scheme}[time]\n{time_table}[output]\nevery = 1000000000\n'


def femvi_run(binary, text):
    """Runs a problem; returns (cpu, summary, rows of trajectory.csv as a structured array)."""
    with tempfile.TemporaryDirectory() as out:
        path = os.path.join(out, "p.toml")
        with open(path, "w") as f:
            f.write(text)
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        # Exit 1 (a failed step, e.g. once a lost Arenstorf orbit escapes) keeps the rows before it.
        if subprocess.run([binary, "run", path, "--quiet", "--out", out]).returncode not in (0, 1):
            raise RuntimeError(f"femvi failed on\n{text}")
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        with open(os.path.join(out, "summary.json")) as f:
            summary = json.load(f)
        rows = np.atleast_1d(np.genfromtxt(os.path.join(out, "trajectory.csv"), delimiter=",", names=True))
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, summary, rows


def femvi_states(which, summary, rows, dense):
    """[(t, q, v)]: the output rows (`dense`: adaptive, at the requested physical times from
    the element polynomial) or the final node (q and the discrete momentum p, which are
    more accurate than the dense output's velocity)."""
    if dense:
        names = rows.dtype.names
        qs = [n for n in names if n not in ("row", "t", "energy") and not n.startswith("p_")]
        out = [(r["t"], np.array([r[n] for n in qs]), np.array([r["p_" + n] for n in qs])) for r in rows]
    else:
        out = [(summary["final_t"], np.array(summary["final_q"]), np.array(summary["final_p"]))]
    states = []
    for t, q, p in out:
        if which == "arenstorf":  # p = (x_dot - y, y_dot + x)
            v = np.array([p[0] + q[1], p[1] - q[0]])
        else:
            v = p / np.repeat(PLEI_MASSES, 2)
        states.append((t, q, v))
    return states


def femvi_config(binary, which, order, periods=1, ds=None, n_steps=None, steps_out=False):
    """A femvi run of `which` over `periods` Arenstorf periods (Pleiades: [0, 3]); returns
    (cpu, steps, [(t, q, v)]) with the states at every period (Arenstorf) or at the end."""
    if which == "arenstorf":
        end, step_out = periods * PERIOD, PERIOD if steps_out else periods * PERIOD
    else:
        end, step_out = 3.0, 3.0
    if ds is not None:
        text = femvi_problem(which, order, ds=ds, end=end, output_step=step_out)
    else:
        text = femvi_problem(which, order, h=end / n_steps, end=end)
    cpu, summary, rows = femvi_run(binary, text)
    states = femvi_states(which, summary, rows, steps_out)
    return cpu, summary["steps"], [s for s in states if s[0] > 0.0]


# -------------------------------------------------------------------------------- REBOUND

def ias15_arenstorf(eps, times):
    """The satellite in the inertial frame; states at `times` rotated back to the rotating
    frame (x_rot = R(-t) x, v_rot = R(-t) v - omega x x_rot, omega = 1)."""
    sim = rebound.Simulation()
    sim.integrator = "ias15"
    sim.integrator.epsilon = eps
    sim.add(m=1.0 - MU, x=-MU, vy=-MU)
    sim.add(m=MU, x=1.0 - MU, vy=1.0 - MU)
    x0, y0 = AREN_Q0
    vx0, vy0 = AREN_V0[0] - y0, AREN_V0[1] + x0
    sim.add(m=0.0, x=x0, y=y0, vx=vx0, vy=vy0)
    sim.N_active = 2
    states = []
    for t in times:
        sim.integrate(t)
        c, s = math.cos(sim.t), math.sin(sim.t)
        b = sim.particles[2]
        q = np.array([c * b.x + s * b.y, -s * b.x + c * b.y])
        w = np.array([c * b.vx + s * b.vy, -s * b.vx + c * b.vy])
        states.append((sim.t, q, np.array([w[0] + q[1], w[1] - q[0]])))
    return sim.steps_done, states


def ias15_pleiades(eps):
    sim = rebound.Simulation()
    sim.integrator = "ias15"
    sim.integrator.epsilon = eps
    for m, x, y, vx, vy in zip(PLEI_MASSES, PLEI_X0, PLEI_Y0, PLEI_VX0, PLEI_VY0):
        sim.add(m=m, x=x, y=y, vx=vx, vy=vy)
    sim.integrate(3.0)
    ps = sim.particles
    q = np.array([c for p in ps for c in (p.x, p.y)])
    v = np.array([c for p in ps for c in (p.vx, p.vy)])
    return sim.steps_done, [(sim.t, q, v)]


# --------------------------------------------------------------------------------- DOP853

def dop853(which, rtol, times):
    if which == "arenstorf":
        rhs, y0 = arenstorf_rhs, np.concatenate([AREN_Q0, AREN_V0])
    else:
        rhs, y0 = pleiades_rhs, np.array(PLEI_X0 + PLEI_Y0 + PLEI_VX0 + PLEI_VY0)
    sol = solve_ivp(rhs, (0.0, times[-1]), y0, method="DOP853", rtol=rtol, atol=rtol * 1e-2, t_eval=times)
    states = []
    for k, t in enumerate(sol.t):
        y = sol.y[:, k]
        if which == "arenstorf":
            states.append((t, y[:2], y[2:]))
        else:  # (x.., y.., x'.., y'..) to interleaved (x0, y0, x1, ...)
            states.append((t, np.ravel(np.column_stack([y[:7], y[7:14]])),
                           np.ravel(np.column_stack([y[14:21], y[21:]]))))
    return sol.nfev, states


# --------------------------------------------------------------------------------- errors

def reference(which, t):
    """The reference (q, v) at time t: the published state at the reference time t_r (k T for
    Arenstorf, 3 for the Pleiades), carried to t by DOP853 at its tightest tolerance when t
    differs from t_r (femvi's adaptive runs end on the first node past the end time, at most
    one physical step past it; over such a short interval DOP853's error is at round-off)."""
    if which == "arenstorf":
        t_ref, y = round(t / PERIOD) * PERIOD, np.concatenate([AREN_Q0, AREN_V0])
        rhs = arenstorf_rhs
    else:
        t_ref, y = 3.0, PLEI_REF.copy()
        rhs = pleiades_rhs
    if t != t_ref:
        sol = solve_ivp(rhs, (t_ref, t), y, method="DOP853", rtol=2.3e-14, atol=1e-16)
        y = sol.y[:, -1]
    if which == "arenstorf":
        return y[:2], y[2:]
    return (np.ravel(np.column_stack([y[:7], y[7:14]])), np.ravel(np.column_stack([y[14:21], y[21:]])))


def errors(which, state):
    """(position error, state error) of (t, q, v) against the reference at t."""
    t, q, v = state
    ref_q, ref_v = reference(which, t)
    dq, dv = q - ref_q, v - ref_v
    return float(np.linalg.norm(dq)), float(math.sqrt(np.dot(dq, dq) + np.dot(dv, dv)))


def timed(thunk):
    c0 = time.process_time()
    steps, states = thunk()
    return time.process_time() - c0, steps, states


def configs(binary):
    """(problem, code, configuration, thunk -> (cpu, steps, states))."""
    runs = []
    for which in ("arenstorf", "pleiades"):
        ends = [PERIOD] if which == "arenstorf" else [3.0]
        for order, dss in {8: (0.1, 0.05, 0.025, 0.0125), 4: (0.01,)}.items():
            for ds in dss:
                runs.append((which, "femvi adaptive", f"order {order}, ds = {ds}",
                             lambda w=which, o=order, ds=ds: femvi_config(binary, w, o, ds=ds)))
        fixed = {"arenstorf": (2000, 8000, 32000), "pleiades": (1500, 6000, 24000)}[which]
        for n in fixed:
            runs.append((which, "femvi fixed", f"order 8, {n} steps",
                         lambda w=which, n=n: femvi_config(binary, w, 8, n_steps=n)))
        for eps in (1e-9, 1e-7, 1e-5):
            label = f"epsilon = {eps}" + (" (default)" if eps == 1e-9 else "")
            if which == "arenstorf":
                thunk = lambda eps=eps: timed(lambda: ias15_arenstorf(eps, [PERIOD]))  # noqa: E731
            else:
                thunk = lambda eps=eps: timed(lambda: ias15_pleiades(eps))  # noqa: E731
            runs.append((which, "REBOUND IAS15", label, thunk))
        for rtol in (1e-8, 1e-10, 1e-12, 1e-14):
            runs.append((which, "scipy DOP853", f"rtol = {rtol}",
                         lambda w=which, r=rtol, e=ends: timed(lambda: dop853(w, r, e))))
    return runs


def growth(binary):
    """Each code's Arenstorf error after k = 1 ... 10 periods (one run to 10 T)."""
    times = [k * PERIOD for k in range(1, 11)]
    rows = []
    for code, thunk in (
        ("femvi adaptive order 8, ds = 0.0125",
         lambda: femvi_config(binary, "arenstorf", 8, periods=10, ds=0.0125, steps_out=True)[1:]),
        ("REBOUND IAS15 epsilon = 1e-9", lambda: ias15_arenstorf(1e-9, times)),
        ("scipy DOP853 rtol = 1e-14", lambda: dop853("arenstorf", 1e-14, times)),
    ):
        _steps, states = thunk()
        errs = [errors("arenstorf", s)[0] for s in states]
        rows.append((code, errs + [float("nan")] * (10 - len(errs))))
    return rows


def main():
    parser = argparse.ArgumentParser()
    default = os.path.join(os.environ.get("CARGO_TARGET_DIR", "target"), "release", "femvi")
    parser.add_argument("--femvi", default=default)
    parser.add_argument("--rounds", type=int, default=1)
    args = parser.parse_args()
    print(f"rebound {rebound.__version__}, femvi {args.femvi}", file=sys.stderr)
    runs = configs(args.femvi)
    best = {}
    for r in range(args.rounds):
        for i in range(len(runs)) if r % 2 == 0 else reversed(range(len(runs))):
            which, code, config, thunk = runs[i]
            cpu, steps, states = thunk()
            pos, full = errors(which, states[-1])
            print(f"  {which} {code:15s} {config:24s} pos={pos:.2e} state={full:.2e} cpu={cpu:.4f}s",
                  file=sys.stderr)
            if i not in best or cpu < best[i][0]:
                best[i] = (cpu, steps, pos, full)
    rows = [dict(problem=w, code=c, config=cfg, steps=best[i][1], position_error=best[i][2],
                 state_error=best[i][3], cpu_s=best[i][0]) for i, (w, c, cfg, _) in enumerate(runs)]
    with open(os.path.join(HERE, "encounters.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for row in rows:
            w.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in row.items()})
    print("| problem | code | configuration | steps (DOP853: f evaluations) | position error | state error | CPU s |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['problem']} | {r['code']} | {r['config']} | {r['steps']} | {r['position_error']:.1e} | "
              f"{r['state_error']:.1e} | {r['cpu_s']:.4f} |")
    print(f"\nArenstorf monodromy matrix, largest |eigenvalue|: {monodromy_eigenvalue():.1f}\n")
    print("| code | " + " | ".join(f"k = {k}" for k in range(1, 11)) + " |")
    print("|---|" + "---|" * 10)
    for code, errs in growth(args.femvi):
        print(f"| {code} | " + " | ".join(f"{e:.1e}" for e in errs) + " |")


if __name__ == "__main__":
    main()
