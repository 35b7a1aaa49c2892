"""The tour (examples/tour.py) runs and leaves its plots and small energy errors."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

TOUR = Path(__file__).resolve().parents[1] / "examples" / "tour.py"


def test_tour(tmp_path):
    pytest.importorskip("matplotlib", reason="matplotlib is not installed")
    # The full 10⁴-member ensemble takes about a second on two cores.
    subprocess.run([sys.executable, str(TOUR), str(tmp_path), "10000"], check=True, timeout=300)
    for png in ("kepler.png", "outer-solar-system.png", "henon-heiles-ensemble.png"):
        assert (tmp_path / png).stat().st_size > 10_000
    r = json.loads((tmp_path / "results.json").read_text())
    assert r["members"] == 10_000 and r["ensemble_failures"] == 0
    assert r["kepler_energy_error"] < 1e-6
    assert r["solar_energy_error"] < 1e-8
    assert r["ensemble_max_rel_energy_error"] < 1e-5
    assert r["ensemble_energy_error"] < 1e-6
