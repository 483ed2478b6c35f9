"""scripts/funnel_jams.py: jams per 1,000 seedlings at risk (no jam standing as a seedling is
judged) with Poisson's exact interval, and each jam's cost, from the trials' JSON."""

from __future__ import annotations

import importlib.util
import json
import sys

import pytest

from conftest import ROOT

SCRIPT = ROOT / "scripts" / "funnel_jams.py"


def _script():
    spec = importlib.util.spec_from_file_location("funnel_jams", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def _trial(seed, outcomes, jams=()):
    per = [{"outcome": o, "after_jam": a} for o, a in outcomes]
    return {"seed": seed, "successes": sum(o == "success" for o, _ in outcomes),
            "per_seedling": per, "funnel_jams": list(jams)}  # fmt: skip


def test_the_rate_counts_only_seedlings_at_risk_and_its_interval_is_poissons():
    fj = _script()
    jam = {"seedling": 2, "later_failures": 2,
           "later_failures_by_kind": {"position_lost": 1, "dropped_outside": 1}}  # fmt: skip
    results = [
        _trial(1, [("success", None), ("success", None), ("funnel_jam", None),
                   ("position_lost", 2), ("dropped_outside", 2)], [jam]),
        _trial(2, [("success", None)] * 4 + [("not_run", None)]),
    ]  # fmt: skip
    text = fj.summarise(results)
    # at risk: 3 of seed 1 (the jam's own included, not the two after it) + 4 of seed 2
    assert "1 funnel jams in 7 seedlings at risk (9 judged, 2 trials): 142.86 per 1,000" in text
    lo, hi = fj.poisson_interval(1, 7)
    assert (lo * 7, hi * 7) == pytest.approx((0.02532, 5.5716), abs=1e-4)  # exact, k = 1
    assert f"(95 % {1000 * lo:.2f}-{1000 * hi:.2f})" in text
    assert "failures while a jam stood: 2 (1 position_lost, 1 dropped_outside); per jam 2-2" in text
    assert "seed   1:    2/5 successes, 1 jam(s), first at seedling 2, 3 seedlings at risk" in text


def test_a_first_strike_is_said_to_follow_a_jam_only_within_the_window():
    fj = _script()
    jam = {"seedling": 0, "t_release_s": 10.0, "later_failures": 0, "later_failures_by_kind": {}}
    strike = [{"t_s": 14.0}]
    soon = _trial(1, [("funnel_jam", None), ("lost_steps", None), ("position_lost", None)], [jam])
    for s in soon["per_seedling"][1:]:
        s["lost_step_event"] = 0
    soon["lost_step_events"] = strike
    late = {**soon, "seed": 2, "lost_step_events": [{"t_s": 10.0 + fj.STRIKE_WINDOW_S + 1}]}
    text = fj.summarise([soon, late])
    assert (
        "seed   1:" in text and "first strike at 14.0 s cost 2, 4.0 s after a jam's release" in text
    )
    assert "1 within 30 s of a jam's release, costing 2 seedlings; 1 with no jam" in text
    assert "released in the 30 s before, costing 2" in text


def test_a_rerun_reads_what_out_holds(tmp_path, capsys):
    fj = _script()
    (tmp_path / "seed_4.json").write_text(json.dumps(_trial(4, [("success", None)] * 3)))
    assert fj.main(["--seeds", "4", "--out", str(tmp_path)]) == 0  # nothing is run again
    assert "0 funnel jams in 3 seedlings at risk" in capsys.readouterr().out
