"""femvi's MEGNO side by side with REBOUND's on the same star + two planets system
(G = 1; masses 1, 1e-3, 3e-4; inner planet at a = 1, e = 0; outer planet over a grid of
semi-major axes A2 and eccentricities E2, true anomaly 60 degrees apart, coplanar orbits in
three dimensions), the same initial states (REBOUND's, barycentric), the same initial tangent
vectors (REBOUND's random variational particles, seed 0, with δp = m δv for femvi) and the
same step h = P1 / STEPS_PER_ORBIT for ORBITS inner periods. Three dimensions because
REBOUND's tangent vector has out-of-plane components: on a coplanar orbit they evolve apart
from the in-plane ones and can carry the instability (at a2 = 1.411, e2 = 0 REBOUND's <Y>
after 20 000 orbits is 5.79 with its 3-D vector, 1.99 with the vector's z parts zeroed; a
planar femvi run saw 2.00). REBOUND: WHFast with its variational MEGNO (seed 0). femvi: the element of order
ORDER (default 4: degree 2, 2-point Gauss-Legendre; 2: degree 1 trapezoid, Stormer-Verlet)
with its tangent-map MEGNO, through the example planetary_megno.

    cargo build --release -p femvi --example planetary_megno
    python megno_rebound.py ../../target/release/examples/planetary_megno [N] [ORBITS] [ORDER] [STEPS_PER_ORBIT] [ENCOUNTER]

ENCOUNTER = hill (default none): a close encounter, two bodies closer than the planets'
mutual Hill radius ((m1 + m2) / 3)^(1/3) (1 + a2) / 2, makes a point unstable (chaotic) for
both codes, as in REBOUND's own MEGNO-map example (which counts an escape as unstable):
REBOUND stops with `exit_min_distance` (rebound.Encounter), femvi reports the smallest
distance at its force evaluations. Neither code follows such an encounter with a fixed step.

Prints the verdicts (regular: <Y> < THRESHOLD) and how often they agree, the relative
difference of <Y> where both say regular, and the CPU time of each (process time for
REBOUND, the child's user + system time for femvi); writes megno_rebound_orderORDER.csv.
"""

import math
import resource
import subprocess
import sys
import time

import numpy as np
import rebound

BIN = sys.argv[1]
N = int(sys.argv[2]) if len(sys.argv) > 2 else 10
ORBITS = float(sys.argv[3]) if len(sys.argv) > 3 else 1000.0
ORDER = int(sys.argv[4]) if len(sys.argv) > 4 else 4
STEPS_PER_ORBIT = int(sys.argv[5]) if len(sys.argv) > 5 else 50
ENCOUNTER = sys.argv[6] if len(sys.argv) > 6 else "none"
THRESHOLD = 2.5
A2 = np.linspace(1.35, 1.9, N)
E2 = np.linspace(0.0, 0.3, N)
P1 = 2 * math.pi
T, H = ORBITS * P1, P1 / STEPS_PER_ORBIT


def simulation(a2, e2):
    sim = rebound.Simulation()
    sim.G = 1.0
    sim.add(m=1.0)
    sim.add(m=1e-3, a=1.0, e=0.0, f=0.0)
    sim.add(m=3e-4, a=a2, e=e2, f=math.pi / 3)
    sim.move_to_com()
    return sim


grid = [(a, e) for e in E2 for a in A2]


def hill(a2):
    """The encounter distance at outer semi-major axis a2, or None without the criterion."""
    return ((1e-3 + 3e-4) / 3.0) ** (1.0 / 3.0) * (1.0 + a2) / 2.0 if ENCOUNTER == "hill" else None


states = []
for a, e in grid:
    ps = simulation(a, e).particles
    sim = simulation(a, e)
    sim.init_megno(seed=0)
    vp = sim.var_config[0].particles
    tangent = [c for i in range(len(ps)) for c in (vp[i].x, vp[i].y, vp[i].z)]
    tangent += [c for i in range(len(ps)) for c in (vp[i].vx, vp[i].vy, vp[i].vz)]
    states.append([c for p in ps for c in (p.x, p.y, p.z)] + [c for p in ps for c in (p.vx, p.vy, p.vz)] + tangent
                  + ([float(hill(a))] if hill(a) else []))

clock = time.process_time()
ours_rebound = []
for a, e in grid:
    sim = simulation(a, e)
    sim.integrator = "whfast"
    sim.dt = H
    sim.init_megno(seed=0)
    if hill(a):
        sim.exit_min_distance = hill(a)
    try:
        sim.integrate(T, exact_finish_time=0)
        ours_rebound.append(sim.megno())
    except rebound.Encounter:
        ours_rebound.append(math.inf)
cpu_rebound = time.process_time() - clock

before = resource.getrusage(resource.RUSAGE_CHILDREN)
text = "\n".join(",".join(repr(x) for x in s) for s in states) + "\n"
femvi_args = [repr(T), repr(H), "verlet" if ORDER == 2 else str(ORDER), "3"]
out = subprocess.run([BIN] + femvi_args, input=text, capture_output=True, text=True)
if out.returncode:
    sys.exit(f"femvi failed: {out.stderr}")
after = resource.getrusage(resource.RUSAGE_CHILDREN)
cpu_femvi = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
femvi = [[float(x) for x in line.split(",")] for line in out.stdout.split()]

agree, rel, rows = 0, [], []
for (a, e), yr, (yf, fli, steps, failed, closest) in zip(grid, ours_rebound, femvi):
    regular_r, regular_f = yr < THRESHOLD, (yf < THRESHOLD and not failed)
    agree += regular_r == regular_f
    if regular_r and regular_f:
        rel.append(abs(yf - yr) / yr)
    rows.append(f"{a},{e},{yr},{yf},{int(failed)},{closest}")
suffix = ("" if STEPS_PER_ORBIT == 50 else f"_h{STEPS_PER_ORBIT}") + ("" if ENCOUNTER == "none" else f"_{ENCOUNTER}")
with open(f"megno_rebound_order{ORDER}_{ORBITS:g}orbits_3d{suffix}.csv", "w") as f:
    f.write("a2,e2,megno_rebound,megno_femvi,femvi_failed,femvi_min_distance\n" + "\n".join(rows) + "\n")
both_regular = len(rel)
print(f"{len(grid)} points, {ORBITS:g} inner orbits, h = P1/{STEPS_PER_ORBIT}, femvi order {ORDER}: verdicts agree on {agree}/{len(grid)}; "
      f"regular for REBOUND {sum(y < THRESHOLD for y in ours_rebound)}, for femvi "
      f"{sum(y < THRESHOLD and not fl for y, _, _, fl, _ in femvi)}")
if rel:
    print(f"where both say regular ({both_regular} points): |<Y>_femvi - <Y>_rebound| / <Y>_rebound "
          f"median {np.median(rel):.4f}, max {max(rel):.4f}")
print(f"CPU time: REBOUND (WHFast + variational MEGNO) {cpu_rebound:.2f} s, femvi (order {ORDER} + tangent map) "
      f"{cpu_femvi:.2f} s, ratio femvi/REBOUND {cpu_femvi / cpu_rebound:.2f}")
