"""femvi.solve of the double pendulum written with sympy.physics.mechanics (a femvi.System)
against the same system from a problem file (examples/double-pendulum-expression.toml), for
issue 38's "<= 1.1x its time". Both modes derive the SymPy Lagrangian and build the System, so
the two commands differ only in what femvi.solve is given:

    python benches/peers/python_system.py system   # femvi.solve(System, **run)
    python benches/peers/python_system.py file     # femvi.solve("examples/...toml", **run)

Time them alternately with a paired-run timer; `--steps N` sets the run (default 20 000 steps,
h = 0.01). Prints the final state, which the two modes must give bit for bit.
"""

import argparse
import sys
import time
from pathlib import Path

import sympy as sp
from sympy.physics.mechanics import Lagrangian, Particle, Point, ReferenceFrame, dynamicsymbols

import femvi

ROOT = Path(__file__).resolve().parents[2]


def system():
    q1, q2 = dynamicsymbols("q1 q2")
    m1, m2, l1, l2, g = sp.symbols("m1 m2 l1 l2 g")
    frame, pivot = ReferenceFrame("N"), Point("O")
    pivot.set_vel(frame, 0)
    p1 = pivot.locatenew("P1", l1 * sp.sin(q1) * frame.x - l1 * sp.cos(q1) * frame.y)
    p2 = p1.locatenew("P2", l2 * sp.sin(q2) * frame.x - l2 * sp.cos(q2) * frame.y)
    for p in (p1, p2):
        p.set_vel(frame, p.pos_from(pivot).dt(frame))
    a, b = Particle("a", p1, m1), Particle("b", p2, m2)
    a.potential_energy = m1 * g * p1.pos_from(pivot).dot(frame.y)
    b.potential_energy = m2 * g * p2.pos_from(pivot).dot(frame.y)
    L = sp.simplify(Lagrangian(frame, a, b))
    return femvi.System([q1, q2], L, {m1: 1.0, m2: 1.0, l1: 1.0, l2: 1.0, g: 9.81}, name="double-pendulum")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", choices=["system", "file"])
    ap.add_argument("--steps", type=int, default=20000)
    args = ap.parse_args()
    t0 = time.perf_counter()
    s = system()
    derived = time.perf_counter() - t0
    problem = s if args.mode == "system" else ROOT / "examples" / "double-pendulum-expression.toml"
    run = dict(q0=[1.0, 0.5], v0=[0.0, 0.0], t_span=(0.0, 0.01 * args.steps), dt=0.01, degree=3,
               nodes="lobatto", quadrature="gauss-lobatto", points=4)
    t1 = time.perf_counter()
    sol = femvi.solve(problem, **run)
    solved = time.perf_counter() - t1
    print(f"{args.mode}: derivation {derived:.3f} s, solve {solved:.3f} s, {sol.steps} steps, "
          f"q = {sol.q[-1].tolist()!r}", file=sys.stderr)


if __name__ == "__main__":
    main()
