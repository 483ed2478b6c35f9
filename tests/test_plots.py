"""transplanter.studies.plots: the sweep's PNGs from its rows, tune's Pareto plot (no physics)."""

import pytest

from transplanter.studies import plots
from transplanter.studies.plots import key_label, pareto_plot, sample_text, sweep_plots

PNG = b"\x89PNG\r\n\x1a\n"


def _row(z, up, seed, k, n=10, cycle=3.5, error=None):
    return {"taught.z_low_mm": z, "taught.z_up_mm": up, "seed": seed, "successes": k,
            "seedlings": n, "cycle_time_s": cycle, "cycles": n, "error": error}  # fmt: skip


@pytest.fixture
def figures(monkeypatch):
    """The figures each plot saves, as {file name: (suptitle, [(title, xlabel, ylabel)])},
    read before they are written."""
    seen = {}
    save = plots._save

    def reading(fig, path):
        title = fig._suptitle.get_text() if fig._suptitle is not None else ""
        axes = [(a.get_title(), a.get_xlabel(), a.get_ylabel()) for a in fig.axes]
        seen[path.name] = (title, axes)
        return save(fig, path)

    monkeypatch.setattr(plots, "_save", reading)
    return seen


def test_key_label_carries_the_file_unit():
    assert key_label("taught.z_low_mm") == "taught.z_low_mm (mm)"
    assert key_label("taught.s_high_mm_s") == "taught.s_high_mm_s (mm/s)"
    assert key_label("taught.drop_wrist_deg") == "taught.drop_wrist_deg (deg)"
    assert key_label("gripper.close_dwell_ms") == "gripper.close_dwell_ms (ms)"
    assert key_label("scenario.seedlings") == "scenario.seedlings"  # a count: no unit


def test_sample_text_names_seedlings_and_seeds():
    rows = [_row(30.0, 60.0, s, 5, n=20) for s in (1, 2, 3, 7)]
    rows.append(_row(40.0, 60.0, 8, None, None, None, "setting refused"))
    assert sample_text(rows) == "n = 20 seedlings x 5 seeds (1-3, 7-8)"
    assert sample_text(rows[:1]) == "n = 20 seedlings x 1 seed (1)"


def test_one_key_gives_one_png_with_success_and_cycle_in_units(tmp_path, figures):
    rows = [_row(z, 60.0, s, k) for z, k in ((26.0, 3), (30.0, 9), (34.0, 10)) for s in (1, 2)]
    paths = sweep_plots(tmp_path, ["taught.z_low_mm"], rows)
    assert [p.name for p in paths] == ["sweep_taught.z_low_mm.png"]
    assert all(p.read_bytes()[:8] == PNG for p in paths)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in paths)
    title, axes = figures["sweep_taught.z_low_mm.png"]
    assert "n = 10 seedlings x 2 seeds (1-2)" in title
    (s_title, s_x, s_y), (c_title, c_x, c_y) = axes
    assert s_x == c_x == "taught.z_low_mm (mm)"
    assert "success" in s_title and "(%)" in s_y and "95 %" in s_y
    assert "cycle" in c_title and c_y == "mean cycle time (s)"


def test_two_keys_add_a_heat_map_and_survive_an_error_setting(tmp_path, figures):
    rows = [_row(z, up, 1, 10 if z > 26 else 2) for z in (26.0, 30.0, 34.0) for up in (50.0, 60.0)]
    rows.append(_row(40.0, 50.0, 1, None, None, None, "setting refused: unreachable"))
    keys = ["taught.z_low_mm", "taught.z_up_mm"]
    paths = sweep_plots(tmp_path, keys, rows)
    assert [p.name for p in paths] == [
        "sweep_taught.z_low_mm.png",
        "sweep_taught.z_up_mm.png",
        "success_heatmap.png",
    ]
    assert all(p.stat().st_size > 1000 and p.read_bytes()[:8] == PNG for p in paths)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in paths)
    assert figures["sweep_taught.z_up_mm.png"][1][0][1] == "taught.z_up_mm (mm)"
    _, heat = figures["success_heatmap.png"]
    title, x, y = heat[0]
    assert (x, y) == ("taught.z_low_mm (mm)", "taught.z_up_mm (mm)")
    assert "n = 10 seedlings x 1 seed (1)" in title
    assert heat[1][2] == "pooled success rate (%)"  # the colour bar


def test_pareto_plot_is_optunas_with_units_and_the_sample(tmp_path, figures):
    optuna = pytest.importorskip("optuna")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(directions=["maximize", "minimize"])
    for lower, cycle in ((0.9, 3.4), (0.8, 3.2), (0.7, 3.5)):
        trial = study.ask()
        study.tell(trial, [lower, cycle])
    path = pareto_plot(tmp_path / "p.png", study, (3.4, 0.9), title="n = 20 seedlings x 2 seeds")
    assert path.read_bytes()[:8] == PNG
    _, axes = figures["p.png"]
    title, x, y = axes[0]
    assert x == "mean cycle time (s)"
    assert y == "lower 95 % bound of pooled success (%)"
    assert title == "n = 20 seedlings x 2 seeds"
