"""The jupytext notebooks in notebooks/ run from top to bottom."""

import os
import runpy

import pytest

from conftest import ROOT

NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.py"))


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_runs(path, monkeypatch, capsys):
    monkeypatch.setenv("NOTEBOOK_SEEDLINGS", "3")
    monkeypatch.chdir(path.parent)
    runpy.run_path(str(path), run_name="__main__")
    out = capsys.readouterr().out
    assert "success rate" in out
    assert os.environ["NOTEBOOK_SEEDLINGS"] == "3"


def test_there_are_notebooks():
    assert NOTEBOOKS, "notebooks/ holds jupytext .py notebooks"
