"""The notebooks in examples/notebooks run from top to bottom (nbclient, the venv's kernel),
with no error, and draw their figures. Outputs are not committed; with
$FEMVI_NOTEBOOK_FIGURES set, each figure is written there as NAME-CELL-K.png to be looked at."""

import base64
import os
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

from conftest import EXAMPLES

NOTEBOOKS = sorted((EXAMPLES / "notebooks").glob("*.ipynb"))


def test_there_are_notebooks():
    assert {p.name for p in NOTEBOOKS} >= {"tour.ipynb", "double-pendulum.ipynb"}


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs_and_draws(path):

    nb = nbformat.read(path, as_version=4)
    assert all(not c.get("outputs") for c in nb.cells if c.cell_type == "code"), "outputs are committed"
    NotebookClient(nb, timeout=600, kernel_name="python3",
                   resources={"metadata": {"path": str(path.parent)}}).execute()
    figures = []
    for i, cell in enumerate(nb.cells):
        for out in cell.get("outputs", []):
            assert out.get("output_type") != "error", (i, out)
            data = out.get("data", {})
            if "image/png" in data:
                figures.append((i, base64.b64decode(data["image/png"])))
    expected = sum("plot(" in c.source or "subplots(" in c.source for c in nb.cells if c.cell_type == "code")
    assert len(figures) == expected, (len(figures), expected)
    where = os.environ.get("FEMVI_NOTEBOOK_FIGURES")
    if where:
        Path(where).mkdir(parents=True, exist_ok=True)
        for k, (i, png) in enumerate(figures):
            (Path(where) / f"{path.stem}-{i}-{k}.png").write_bytes(png)
