"""scripts/push_drift_figure.py and the tally of benchmarks/push_drift.py it draws from: the
offsets by push count, near and far halves, pots left out as the benchmark leaves them out,
and the figure written atomically."""

from __future__ import annotations

import importlib.util
import json
import sys

import numpy as np
import pytest

from conftest import ROOT

SCRIPT = ROOT / "scripts" / "push_drift_figure.py"


def _script():
    spec = importlib.util.spec_from_file_location("push_drift_figure", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def _run(rows=8, cols=5, indexes=2, x_of=lambda i, pot: 0.0):
    """A push_drift.py --json of one seed: every pot a body, pushed at every index."""
    out = []
    for i in range(indexes):
        n = rows * cols
        out.append({
            "offset": [[x_of(i, p), 0.0002] for p in range(n)],
            "live": [True] * n,
            "pushes": [i + 1] * n,
            "lag": 1e-4,
        })  # fmt: skip
    return {"args": {"rows": rows}, "seeds": [{"seed": 1, "cols": cols, "indexes": out}]}


def test_the_tally_leaves_out_the_pickup_rows_and_struck_pots_and_splits_the_belt():
    fig = _script()
    tally = sys.modules["push_drift"].tally
    # after index i the rows below i + 3 are at or past the pickup; pot 39 was struck (7 mm)
    run = _run(x_of=lambda i, pot: 0.007 if pot == 39 else 0.001 * (pot // 5 >= 4))
    by_push, last, first_by_col, lags = tally(run["seeds"], 8)
    assert sorted(by_push) == [1, 2]
    first = np.array(by_push[1])  # rows 3-7 after the first index, less the struck pot
    assert len(first) == 5 * 5 - 1
    assert (first[first[:, 2] > 0, 0] == 1.0).all()  # rows 4-7: the far half, +1 mm
    assert (first[first[:, 2] == 0, 0] == 0.0).all()
    assert first[:, 1] == pytest.approx(0.2)
    assert len(by_push[2]) == 4 * 5 - 1 and sorted(last) == [4, 5, 6, 7]
    assert sorted(first_by_col) == [0, 1, 2, 3, 4] and lags == [1e-4, 1e-4]
    assert fig.tally is tally


def test_the_figure_is_drawn_from_saved_runs(tmp_path, monkeypatch):
    fig = _script()
    runs = []
    for name, spread in (("cylinder", 0.002), ("feet", 0.001)):
        rng = np.random.default_rng(3)
        run = _run(rows=40, indexes=3,
                   x_of=lambda i, pot, s=spread, g=rng: float(g.normal(0, s)))  # fmt: skip
        path = tmp_path / f"{name}.json"
        path.write_text(json.dumps(run))
        runs.append(f"{name}={path}")
    curves = fig.curves(str(tmp_path / "feet.json"))
    assert curves["pushes"].tolist() == [1, 2, 3]
    assert curves["sd"] == pytest.approx([1.0, 1.0, 1.0], abs=0.15)  # mm, 150-185 pots a push
    out = tmp_path / "push_drift.png"
    monkeypatch.setattr(sys, "argv", ["push_drift_figure.py", *runs, "--out", str(out)])
    assert fig.main() == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no temp left
    monkeypatch.setattr(sys, "argv", ["push_drift_figure.py", "no-label.json"])
    with pytest.raises(SystemExit):
        fig.main()
