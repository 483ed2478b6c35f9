"""The jupytext notebooks in notebooks/ execute from top to bottom in a Jupyter kernel."""

import pytest

from conftest import ROOT

NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.py"))


# The PNG files each notebook writes into NOTEBOOK_OUT (its own subdirectory).
PLOTS = {
    "via_point_heights.py": [
        "via_point_heights_3/sweep_taught.z_low_mm.png",
        "via_point_heights_3/success_heatmap.png",
    ],
    "speed_vs_success.py": ["speed_vs_success_3/pareto.png"],
    "compare_arms.py": ["compare_arms_3/compare.png"],
}


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_executes_with_its_plots_in_the_output(path, monkeypatch, tmp_path):
    """Each notebook runs top to bottom in a Jupyter kernel (jupytext reads the .py file,
    nbclient executes it), prints its results and shows its plots as PNG outputs."""
    _execute(path, monkeypatch, tmp_path)
    for name in PLOTS.get(path.name, []):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name


@pytest.mark.slow
def test_the_pot_line_notebook_runs_any_robot_on_the_line(monkeypatch, tmp_path):
    """notebooks/paper_trial.py with the delta on the pot line (`transplanter.run_job`): the
    same records, its own tuning variant."""
    monkeypatch.setenv("NOTEBOOK_SCENARIO", "delta_pots")
    text = _execute(ROOT / "notebooks" / "paper_trial.py", monkeypatch, tmp_path, seedlings=2)
    assert "delta_pots (seed 1)" in text
    assert "{'delta_pots.grip_settle_ms': 105.0} cycle" in text


def _execute(path, monkeypatch, tmp_path, seedlings: int = 3) -> str:
    """The notebook executed in a Jupyter kernel: its printed text (no error output, at
    least one PNG shown)."""
    jupytext = pytest.importorskip("jupytext")
    nbclient = pytest.importorskip("nbclient")
    monkeypatch.setenv("NOTEBOOK_SEEDLINGS", str(seedlings))
    monkeypatch.setenv("NOTEBOOK_TRIALS", "3")
    monkeypatch.setenv("NOTEBOOK_OUT", str(tmp_path))
    monkeypatch.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")
    notebook = jupytext.read(path)
    client = nbclient.NotebookClient(
        notebook,
        timeout=600,
        kernel_name="python3",
        resources={"metadata": {"path": str(path.parent)}},
    )
    client.execute()
    outputs = [o for c in notebook.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    text = "".join(o.get("text", "") for o in outputs if o.get("output_type") == "stream")
    assert "success rate" in text
    assert not [o for o in outputs if o.get("output_type") == "error"]
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert images, "the executed notebook shows its plots"
    return text


def test_there_are_notebooks():
    assert NOTEBOOKS, "notebooks/ holds jupytext .py notebooks"
