"""The README's Python quick start runs as written, in at most 12 lines (issue 38)."""

import os
import re

import matplotlib

from conftest import ROOT


def quick_start():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("## Quick start: Python", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_quick_start_is_short_and_runs(tmp_path, capsys):
    code = quick_start()
    lines = [line for line in code.splitlines() if line.strip()]
    assert len(lines) <= 12, len(lines)
    matplotlib.use("Agg")
    here = os.getcwd()
    os.chdir(tmp_path)
    try:
        scope = {}
        exec(compile(code, "README.md", "exec"), scope)
    finally:
        os.chdir(here)
    assert (tmp_path / "pendulum.png").stat().st_size > 10_000
    df, sol = scope["df"], scope["sol"]
    assert list(df.columns[:3]) == ["theta", "theta_dot", "p_theta"] and len(df) == sol.steps + 1 == 2001
    assert sol.max_rel_energy_error < 1e-7
    # What it prints is a problem file that reads back as the same system.
    printed = capsys.readouterr().out
    assert 'lagrangian = "' in printed and "order = 4" in printed
    import femvi
    again = femvi.solve(printed)
    assert (again.q == sol.q).all() and (again.p == sol.p).all() and (again.t == sol.t).all()
