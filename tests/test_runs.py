"""transplanter.runs: every job kind's run behind the one written interface (JobRun), and
the one command-line path that trial, render, view and export take for each of them."""

from __future__ import annotations

import ast
import importlib
import json
import types
from pathlib import Path

import pytest

from transplanter import cli, kinds, runs
from transplanter.scenario.schema import ScenarioError, load_scenario

SRC = Path(__file__).resolve().parents[1] / "src" / "transplanter"
TRUTH = ["--set", "delta_refill.image_delay_ms=0", "--set", "delta_refill.vision=truth"]


@pytest.mark.parametrize("name", kinds.names("job"))
def test_every_job_kind_names_a_run_that_implements_the_interface(name):
    module = importlib.import_module(kinds.job(name).RUN)
    assert runs.problems(module) == [], name
    assert isinstance(module, runs.JobRun)
    assert set(module.REFUSED_OPTIONS) <= {
        "--clips-of-failures", "--eeprom", "--no-preflight", "--seedlings-of", "--cells-of",
    }  # fmt: skip


def test_the_checker_names_what_a_run_lacks():
    half = types.SimpleNamespace(UNIT="", DEFINITIONS={}, REFUSED_OPTIONS=[], run=1)
    found = runs.problems(half)
    assert "UNIT is not a name" in found and "REFUSED_OPTIONS is not a mapping" in found
    assert "run is not callable" in found and "has no viewer" in found


@pytest.mark.parametrize(
    ("scenario", "run"),
    [
        ("paper", None),  # the twin's own trial
        ("paper_tuned", None),
        ("delta_pots", "transplanter.runs.pot_line"),
        ("serial_arm_pots", "transplanter.runs.pot_line"),
        ("delta_refill", "transplanter.runs.plug_trays"),
        ("plug_bench", "transplanter.runs.plug_bench"),
        ("serial_arm", "transplanter.runs.pool_to_belt"),
    ],
)
def test_a_scenario_finds_its_run_through_its_kinds(scenario, run):
    found = runs.of(load_scenario(scenario))
    assert (found.__name__ if found is not None else None) == run


def test_cli_has_no_module_per_machine_and_its_trials_name_no_kind():
    names = {p.stem for p in (SRC / "cli").glob("*.py")}
    assert not names & {"delta_trial", "serial_trial", "delta_pots_trial", "serial_pots_trial"}
    tree = ast.parse((SRC / "cli" / "trials.py").read_text())
    strings = {n.value for n in ast.walk(tree) if isinstance(n, ast.Constant)}
    every_kind = {n for c in kinds.CATEGORIES for n in kinds.names(c)}
    assert not strings & every_kind


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["trial", "delta_pots", "--clips-of-failures", "d"], "this robot's pot job (film it"),
        (["trial", "serial_arm", "--no-preflight"], "--no-preflight: the serial arm's"),
        (["trial", "delta_refill", "--clips-of-failures", "d"], "--cells-of I,J"),
        (["render", "delta_refill", "--out", "x.mp4", "--seedlings-of", "1"], "give --cells-of"),
        (["render", "serial_arm_pots", "--out", "x.mp4", "--cells-of", "1"], "filmed whole"),
        (["view", "delta_refill"], "no live view yet: film it instead"),
        (["render", "plug_bench", "--out", "x.mp4"], "not available for the claws' bench"),
        (["export", "plug_bench", "x.xml"], "export: not available for the claws' bench"),
        (["trial", "plug_bench", "--record", "x.rrd"], "--record: not available"),
    ],
)
def test_what_a_job_cannot_do_is_refused_by_name(argv, said, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("DISPLAY", ":99")  # `view` asks for a display before the job
    if argv[0] == "render":
        pytest.importorskip("imageio_ffmpeg")
    assert cli.main(argv) == 2
    assert said in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # nothing written


def test_a_jobs_trial_pools_its_seeds_with_its_own_lines(tmp_path, capsys):
    out = tmp_path / "r.json"
    argv = ["trial", "delta_refill", "--seeds", "3,4", "--seedlings", "1", *TRUTH]
    assert cli.main([*argv, "--json", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert text.count("operations, ") == 2  # a line per seed
    assert "pooled over 2 trays: " in text and "leaf damage pooled over 2 trays" in text
    assert "what each number means: --explain" in text
    d = json.loads(out.read_text())
    assert [t["seed"] for t in d["trials"]] == [3, 4]
    assert d["pooled"]["seedlings"] == 2 and d["pooled_leaf_damage"]["picked"] <= 2
    assert d["mean_time_per_operation_s"] == pytest.approx(
        sum(t["time_per_operation_s"] for t in d["trials"]) / 2
    )


def test_the_serial_arms_result_counts_its_tomatoes():
    from transplanter.runs import pool_to_belt

    sc = load_scenario("serial_arm", {"pool_to_belt.count": 1})
    r = pool_to_belt.run(sc, 1)
    assert (r.successes, r.seedlings) == (1, 1)
    assert pool_to_belt.line(r).startswith("seed 1: 1/1 tomatoes onto the belt")
    with pytest.raises(ValueError, match="one observer at a time"):
        pool_to_belt.run(sc, 1, observers=[object(), object()])


def test_the_serial_arms_pick_scene_is_exported(tmp_path, capsys):
    out = tmp_path / "arm.xml"
    assert cli.main(["export", "serial_arm", str(out)]) == 0
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(out))
    names = {model.body(i).name for i in range(model.nbody)}
    assert any("tomato" in n for n in names), sorted(names)[:20]


def test_a_job_check_refuses_before_anything_is_built():
    from transplanter.runs import plug_trays, pool_to_belt

    with pytest.raises(ScenarioError, match="physics.sleep"):
        plug_trays.check(load_scenario("delta_refill", {"physics.sleep": True}))
    with pytest.raises(ValueError, match="PWM frame"):
        pool_to_belt.check(load_scenario("serial_arm", {"physics.timestep_ms": 0.3}))


def test_run_job_gives_each_jobs_own_result_whatever_the_robot():
    """`transplanter.run_job`: the five-bar's pot trial (the twin's own) and the serial arm's
    on the same line give the pot line's records (one judge), at the seed and units asked;
    a loaded scenario runs as loaded; a key its kinds do not read is refused by name."""
    import transplanter
    from transplanter.twin.results import SeedlingRecord

    five = transplanter.run_job("paper", seed=2, units=1)
    serial = transplanter.run_job("serial_arm_pots", seed=2, units=1)
    for r in (five, serial):
        assert r.seed == 2 and len(r.per_seedling) == 1
        assert isinstance(r.per_seedling[0], SeedlingRecord)
        assert set(r.to_dict()["failures"]) == set(five.to_dict()["failures"])
    again = transplanter.run_job(load_scenario("paper", {"scenario.seedlings": 1}), seed=2)
    assert again.to_dict()["per_seedling"] == five.to_dict()["per_seedling"]
    with pytest.raises(ScenarioError, match=r"\[taught\] z_low_mm"):
        transplanter.run_job("serial_arm_pots", units=1, overrides={"taught.z_low_mm": 20})
    with pytest.raises(ValueError, match="units and overrides"):
        transplanter.run_job(load_scenario("paper"), units=3)
