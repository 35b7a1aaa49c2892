# %% [markdown]
# # A tour of femvi from Python
#
# Kepler's problem and the outer solar system with plots of the orbit and the energy error,
# then an ensemble of Hénon–Heiles orbits at E = 1/8 started on the section x = 0.
# Run as a script: `python tour.py [OUTPUT_DIR] [MEMBERS]` (default: ./tour-output, 10⁴).

# %%
import json
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import femvi  # noqa: E402

OUT = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("tour-output")
MEMBERS = int(sys.argv[2]) if len(sys.argv) > 2 else 10_000
OUT.mkdir(parents=True, exist_ok=True)
results = {}

# %% Kepler, eccentricity 0.6, ten periods with degree 4 (order 8)
kepler = femvi.solve(femvi.model_problem("kepler"), **{"initial.q": [0.4, 0.0], "initial.p": [0.0, 2.0],
                                                      "time.step": 0.05, "time.end": 20 * np.pi})
rel = np.abs(kepler.energy / kepler.energy[0] - 1)
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
ax1.plot(kepler.q[:, 0], kepler.q[:, 1], lw=0.8)
ax1.set_aspect("equal")
ax1.set_title("Kepler orbit, e = 0.6")
ax2.semilogy(kepler.t[1:], rel[1:] + 1e-18)
ax2.set_xlabel("t")
ax2.set_title("relative energy error")
fig.savefig(OUT / "kepler.png", dpi=100)
plt.close(fig)
results["kepler_energy_error"] = float(rel.max())

# %% The outer solar system (Sun, Jupiter, Saturn, Uranus, Neptune, Pluto) for 20 000 days
sun = femvi.solve(femvi.model_problem("outer-solar-system"), every=1)
n_bodies = sun.q.shape[1] // 3
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
for b in range(n_bodies):
    ax1.plot(sun.q[:, 3 * b], sun.q[:, 3 * b + 1], lw=0.8)
ax1.set_aspect("equal")
ax1.set_title("outer solar system (x, y)")
sun_rel = np.abs(sun.energy / sun.energy[0] - 1)
ax2.semilogy(sun.t[1:], sun_rel[1:] + 1e-18)
ax2.set_title("relative energy error")
fig.savefig(OUT / "outer-solar-system.png", dpi=100)
plt.close(fig)
results["solar_energy_error"] = float(sun_rel.max())

# %% Hénon–Heiles: random points of the section x = 0, p_x ≥ 0 at E = 1/8
E = 1 / 8
rng = np.random.default_rng(0)
y, py = np.empty(0), np.empty(0)
while len(y) < MEMBERS:
    cy, cpy = rng.uniform(-0.5, 0.7, 4 * MEMBERS), rng.uniform(-0.5, 0.5, 4 * MEMBERS)
    ok = 2 * E - cpy**2 - cy**2 + 2 * cy**3 / 3 > 0
    y, py = np.r_[y, cy[ok]][:MEMBERS], np.r_[py, cpy[ok]][:MEMBERS]
px = np.sqrt(2 * E - py**2 - y**2 + 2 * y**3 / 3)
states = np.column_stack([np.zeros(MEMBERS), y, px, py])  # rows (x, y, p_x, p_y)
clock = time.perf_counter()
ens = femvi.ensemble(femvi.model_problem("henon-heiles"), initial_states=states,
                     **{"scheme.degree": 2, "scheme.quadrature": "gauss-legendre", "time.step": 0.1,
                        "time.end": 20.0})
results["ensemble_seconds"] = time.perf_counter() - clock
q, p = ens.final_q, ens.final_p
energy = (p**2).sum(1) / 2 + (q**2).sum(1) / 2 + q[:, 0] ** 2 * q[:, 1] - q[:, 1] ** 3 / 3
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
ax1.plot(q[:, 1], p[:, 1], ",", alpha=0.5)
ax1.set_title(f"{MEMBERS} Hénon–Heiles orbits at t = 20 (y, p_y)")
ax2.hist(energy - E, bins=60)
ax2.set_title("final energy − 1/8")
fig.savefig(OUT / "henon-heiles-ensemble.png", dpi=100)
plt.close(fig)
results["members"] = MEMBERS
results["ensemble_failures"] = int((~ens.ok).sum())
results["ensemble_energy_error"] = float(np.abs(energy - E).max())
results["ensemble_max_rel_energy_error"] = float(ens.energy_error.max())

# %%
(OUT / "results.json").write_text(json.dumps(results, indent=2) + "\n")
print(json.dumps(results, indent=2))
