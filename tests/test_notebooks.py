"""The jupytext notebooks in notebooks/ run from top to bottom."""

import os
import runpy

import pytest

from conftest import ROOT

NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.py"))


# The PNG files each notebook writes into NOTEBOOK_OUT (its own subdirectory).
PLOTS = {
    "via_point_heights.py": [
        "via_point_heights_3/success_taught.z_low_mm.png",
        "via_point_heights_3/cycle_taught.z_low_mm.png",
        "via_point_heights_3/success_heatmap.png",
    ],
    "speed_vs_success.py": ["speed_vs_success_3/pareto.png"],
}


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_runs(path, monkeypatch, capsys, tmp_path):
    monkeypatch.setenv("NOTEBOOK_SEEDLINGS", "3")
    monkeypatch.setenv("NOTEBOOK_TRIALS", "3")
    monkeypatch.setenv("NOTEBOOK_OUT", str(tmp_path))
    monkeypatch.chdir(path.parent)
    runpy.run_path(str(path), run_name="__main__")
    out = capsys.readouterr().out
    assert "success rate" in out
    assert os.environ["NOTEBOOK_SEEDLINGS"] == "3"
    for name in PLOTS.get(path.name, []):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name


def test_there_are_notebooks():
    assert NOTEBOOKS, "notebooks/ holds jupytext .py notebooks"
