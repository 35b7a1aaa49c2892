"""Fixtures: the repository's examples and the `femvi` command, to compare against."""

import csv
import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[3]
EXAMPLES = ROOT / "examples"


def same(a, b):
    """Whether two arrays have the same shape and the same bits."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and (a.view(np.uint64) == b.view(np.uint64)).all()


def columns(rows):
    """trajectory.csv rows (header first) as a dict column name -> array."""
    header, body = rows[0], rows[1:]
    table = np.array([[float(x) for x in r] for r in body])
    return {name: table[:, i] for i, name in enumerate(header)}


@pytest.fixture(scope="session")
def femvi_bin():
    """The CLI binary: $FEMVI_BIN, else built with cargo (into $CARGO_TARGET_DIR or target/)."""
    given = os.environ.get("FEMVI_BIN")
    if given:
        return Path(given)
    subprocess.run(["cargo", "build", "--release", "-p", "femvi-cli"], cwd=ROOT, check=True)
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    return target / "release" / "femvi"


@pytest.fixture()
def run_cli(femvi_bin, tmp_path):
    """Runs `femvi run FILE --out DIR --quiet`; returns (exit code, summary dict, csv rows, stderr)."""

    def run(problem):
        out = tmp_path / "out"
        proc = subprocess.run([str(femvi_bin), "run", str(problem), "--out", str(out), "--quiet"],
                              capture_output=True, text=True)
        summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() else None
        rows = None
        if (out / "trajectory.csv").exists():
            with open(out / "trajectory.csv", newline="") as f:
                rows = list(csv.reader(f))
        return proc.returncode, summary, rows, proc.stderr

    return run
