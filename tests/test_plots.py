"""transplanter.studies.plots: the sweep's PNGs from its rows (no physics)."""

from transplanter.studies.plots import pareto_plot, sweep_plots

PNG = b"\x89PNG\r\n\x1a\n"


def _row(z, up, seed, k, n=10, cycle=3.5, error=None):
    return {"taught.z_low_mm": z, "taught.z_up_mm": up, "seed": seed, "successes": k,
            "seedlings": n, "cycle_time_s": cycle, "cycles": n, "error": error}  # fmt: skip


def test_one_key_gives_success_and_cycle_plots(tmp_path):
    rows = [_row(z, 60.0, s, k) for z, k in ((26.0, 3), (30.0, 9), (34.0, 10)) for s in (1, 2)]
    paths = sweep_plots(tmp_path, ["taught.z_low_mm"], rows)
    assert [p.name for p in paths] == ["success_taught.z_low_mm.png", "cycle_taught.z_low_mm.png"]
    assert all(p.read_bytes()[:8] == PNG for p in paths)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in paths)


def test_two_keys_add_a_heat_map_and_survive_an_error_setting(tmp_path):
    rows = [_row(z, up, 1, 10 if z > 26 else 2) for z in (26.0, 30.0, 34.0) for up in (50.0, 60.0)]
    rows.append(_row(40.0, 50.0, 1, None, None, None, "setting refused: unreachable"))
    keys = ["taught.z_low_mm", "taught.z_up_mm"]
    paths = sweep_plots(tmp_path, keys, rows)
    assert [p.name for p in paths] == [
        "success_taught.z_low_mm.png",
        "cycle_taught.z_low_mm.png",
        "success_taught.z_up_mm.png",
        "cycle_taught.z_up_mm.png",
        "success_heatmap.png",
    ]
    assert all(p.stat().st_size > 1000 for p in paths)


def test_pareto_plot(tmp_path):
    path = pareto_plot(tmp_path / "p.png", [(3.4, 0.5), (3.2, 0.3)], [(3.4, 0.5)], (3.4, 0.5))
    assert path.read_bytes()[:8] == PNG
