"""transplanter.twin.plug_bench_trial: a run of picks on the claws' bench, its seedlings drawn
from the seed (moisture in its band, root vigour)."""

import json

import pytest

from transplanter.scenario.schema import ScenarioError, load_scenario
from transplanter.twin.plug_bench_trial import run_bench_trial

WET = {"scenario.seedlings": 3, "plugs.moisture_pct": 85.0,
       "plug_bench.extraction_accel_m_s2": 30.0}  # fmt: skip


def test_without_spread_every_pick_is_the_benchs_optimum():
    sc = load_scenario("plug_bench", {"scenario.seedlings": 2, "plug_bench.vigour_cv_pct": 0.0,
                                      "plug_bench.moisture_band_pct": 0.0})  # fmt: skip
    r = run_bench_trial(sc, 1)
    assert (r.successes, r.seedlings, r.dropped) == (2, 2, 0)
    # run_pick at 65 %, 25 d, 20 m/s^2: 93.0 % (docs/plug_claws.md), whatever the rotary
    assert [p["retention"] for p in r.picks] == [0.930099, 0.930099]
    assert [p["rotary_deg"] for p in r.picks] == [0.0, 90.0]
    assert r.substrate_retention == pytest.approx(0.930099)


def test_a_wet_run_has_a_success_rate_from_its_drawn_seedlings():
    sc = load_scenario("plug_bench", WET)
    a, b = run_bench_trial(sc, 1), run_bench_trial(sc, 1)
    assert (a.successes, a.seedlings, a.dropped) == (1, 3, 2)
    assert [p["arrived"] for p in a.picks] == [True, False, False]
    assert all(80.0 <= p["moisture_pct"] <= 90.0 for p in a.picks)
    assert [round(p["moisture_pct"], 2) for p in a.picks] == [84.48, 89.22, 88.69]
    assert [round(p["vigour"], 3) for p in a.picks] == [1.124, 0.924, 1.27]
    # the wetter plugs shear round the pins: each drops as its load reaches their capacity
    for p in a.picks[1:]:
        assert p["peak_load_n"] == pytest.approx(p["pin_capacity_n"], rel=0.03)
    assert a.substrate_retention == pytest.approx(0.830425)
    # a seedling's draws are its own: the first of a longer run are these
    longer = run_bench_trial(load_scenario("plug_bench", {**WET, "scenario.seedlings": 4}), 1)
    assert longer.picks[:3] == a.picks
    da, db = a.to_dict(), b.to_dict()
    da.pop("wall_time_s"), db.pop("wall_time_s")
    assert json.dumps(da) == json.dumps(db)  # the same seed, the same run


def test_a_moisture_band_leaving_0_100_is_refused_for_the_bench():
    with pytest.raises(ScenarioError, match="plug_bench.moisture_band_pct"):
        load_scenario("plug_bench", {"plugs.moisture_pct": 96.0})
    # the tray job draws no band: the same moisture is its to use
    assert load_scenario("delta_refill", {"plugs.moisture_pct": 96.0}).plugs.moisture_pct == 96


def test_transplanter_trial_runs_the_bench(tmp_path, capsys):
    from transplanter import cli

    out = tmp_path / "b.json"
    status = cli.main(["trial", "plug_bench", "--seedlings", "3", "--json", str(out),
                       *sum((["--set", f"{k}={v}"] for k, v in WET.items()
                             if k != "scenario.seedlings"), [])])  # fmt: skip
    assert status == 0
    text = capsys.readouterr().out
    assert text.startswith("seed 1: 1/3 seedlings arrived (33.3 %), dropped 2, substrate "
                           "retention 83.0 %")  # fmt: skip
    d = json.loads(out.read_text())
    assert d["trial"] == "plug_bench" and d["successes"] == 1 and len(d["picks"]) == 3
