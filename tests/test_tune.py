"""transplanter tune: an Optuna study over scenario keys, resumed from SQLite, tuned.toml."""

import csv

import pytest

from transplanter.cli import main
from transplanter.scenario.schema import ScenarioError, load_scenario
from transplanter.studies.sweep import SweepRefused
from transplanter.studies.tune import Param, TuneSpec, base_reference, tuned_toml

pytest.importorskip("optuna")


def test_tuned_toml_names_the_base_and_only_the_tuned_keys(tmp_path):
    spec = TuneSpec("paper", (Param("taught.z_low_mm", "float", 28.0, 40.0),), (1, 2), 2)
    text = tuned_toml(spec, {"taught.z_low_mm": 36.78101606283719}, tmp_path)
    assert text.splitlines()[1:] == [
        "",
        "[scenario]",
        'base = "paper"',
        "",
        "[taught]",
        "z_low_mm = 36.78101606283719",
    ]
    path = tmp_path / "tuned.toml"
    path.write_text(text)
    assert load_scenario(path).taught.z_low_m == pytest.approx(0.03678101606283719)


def test_base_reference_of_a_file_elsewhere_is_absolute(tmp_path):
    from conftest import PAPER_PATH

    mine = tmp_path / "lab" / "mine.toml"
    mine.parent.mkdir()
    mine.write_text(PAPER_PATH.read_text())
    assert base_reference(str(PAPER_PATH), tmp_path / "out") == "paper"  # the packaged file
    assert base_reference(str(mine), tmp_path / "out") == str(mine.resolve())
    assert base_reference(str(mine), tmp_path) == "lab/mine.toml"


def test_tune_refusals(tmp_path, capsys):
    args = ["tune", "paper", "--trials", "2", "--seedlings", "2", "--storage",
            str(tmp_path / "t.db"), "--out", str(tmp_path / "out")]  # fmt: skip
    assert main([*args, "--param", "taught.z_low_mm=40..28"]) == 2
    assert "LO must be below HI" in capsys.readouterr().err
    assert main([*args, "--param", "motion.profile=0..1"]) == 2
    assert "only number keys can be tuned" in capsys.readouterr().err
    with pytest.raises(SweepRefused, match="both set"):
        TuneSpec("paper", (Param("taught.z_low_mm", "float", 28.0, 40.0),), (1,), 2,
                 {"taught.z_low_mm": 30.0})  # fmt: skip
    assert not (tmp_path / "t.db").exists()


@pytest.mark.slow
def test_tune_writes_the_front_and_a_tuned_scenario_that_runs(tmp_path, capsys):
    db, out = tmp_path / "t.db", tmp_path / "out"
    args = ["tune", "paper", "--param", "taught.z_low_mm=28..44", "--param",
            "taught.s_high_mm_s=120..220", "--seeds", "1", "--seedlings", "2", "--storage",
            str(db), "--out", str(out), "--study", "s", "--quiet"]  # fmt: skip
    assert main([*args, "--trials", "3"]) == 0
    printed = capsys.readouterr().out
    assert "study s: 3 trials (3 run now)" in printed
    trials_seen = list(csv.DictReader((out / "trials.csv").open()))
    perfect = sum(t["successes"] == t["seedlings"] for t in trials_seen)
    chosen_perfect = next(csv.DictReader((out / "pareto.csv").open()))["successes"] == "2"
    assert ("too few to rank their success" in printed) == (perfect >= 2 and chosen_perfect)
    import optuna

    stored = optuna.load_study(study_name="s", storage=f"sqlite:///{db}")
    assert stored.metric_names == ["success_ci95_low", "cycle_time_s"]  # not values_0/1
    assert "optuna-dashboard sqlite:///" in printed
    trials = list(csv.DictReader((out / "trials.csv").open()))
    assert [t["state"] for t in trials] == ["COMPLETE"] * 3
    front = list(csv.DictReader((out / "pareto.csv").open()))
    assert 1 <= len(front) <= 3
    chosen = front[0]
    assert float(chosen["ci95_low"]) == max(float(t["ci95_low"]) for t in front)
    assert 28 <= float(chosen["taught.z_low_mm"]) <= 44
    assert (out / "pareto.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    tuned = load_scenario(out / "tuned.toml")
    assert tuned.taught.z_low_m == pytest.approx(float(chosen["taught.z_low_mm"]) * 1e-3)
    # resume: the 3 finished trials count, one more runs; the first three are unchanged
    assert main([*args, "--trials", "4"]) == 0
    assert "4 trials (1 run now)" in capsys.readouterr().out
    again = list(csv.DictReader((out / "trials.csv").open()))
    assert again[:3] == trials
    # a different command on the same study is refused
    assert main([*args, "--trials", "4", "--seeds", "1-2"]) == 2
    assert "differs in: seeds" in capsys.readouterr().err
    assert main(["trial", str(out / "tuned.toml"), "--seedlings", "2", "--quiet"]) == 0


def test_tune_refuses_an_out_it_cannot_write_before_any_trial(tmp_path, capsys, monkeypatch):
    from transplanter.studies import tune

    def never(*args, **kwargs):  # pragma: no cover - a refusal runs nothing
        raise AssertionError("a trial ran")

    monkeypatch.setattr(tune, "drive_study", never)
    out, db = tmp_path / "out", tmp_path / "t.db"
    args = ["tune", "paper", "--param", "taught.z_low_mm=28..40", "--trials", "1", "--seeds",
            "1", "--seedlings", "1", "--storage", str(db), "--out", str(out)]  # fmt: skip
    for name in ("trials.csv", "tuned.toml", "pareto.png"):
        (out / name).mkdir(parents=True)
        assert main(args) == 2
        err = capsys.readouterr().err
        assert "tune refused" in err and name in err and "is a directory" in err
        (out / name).rmdir()
    (out / "pareto.csv").symlink_to(tmp_path / "elsewhere.csv")  # a name tune derives
    assert main(args) == 2
    assert "pareto.csv is a symbolic link" in capsys.readouterr().err
    assert not db.exists()


def test_a_storage_that_cannot_hold_a_study_is_refused_in_one_line(tmp_path, capsys):
    """A text file, or a path under a regular file, ended in SQLAlchemy tracebacks."""
    text = tmp_path / "notes.txt"
    text.write_text("not a database\n")
    blocker = tmp_path / "file"
    blocker.write_text("")
    base = ["tune", "paper", "--param", "taught.z_low_mm=30..40", "--seeds", "1"]
    base += ["--seedlings", "1", "--trials", "1", "--out", str(tmp_path / "out")]
    for storage, why in ((text, "is not a SQLite database"), (blocker / "s.db", "cannot hold")):
        assert main([*base, "--storage", str(storage)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and why in err[0]
    assert text.read_text() == "not a database\n"  # untouched


def _fake_run_one(task):
    """A stand-in for the physics: every seedling placed, the cycle shorter as Z_low rises."""
    from transplanter.studies import backends

    z, n = task["setting"]["taught.z_low_mm"], task["seedlings"]
    row = {**task["setting"], "seed": task["seed"], **backends._empty_result()}
    row.update(successes=n, seedlings=n, success_rate=1.0, cycle_time_s=4.0 - 0.03 * z,
               cycles=n, error=None, wall_time_s=0.0)  # fmt: skip
    return row


def test_every_damaged_page_of_a_storage_is_refused_in_one_line(tmp_path, capsys, monkeypatch):
    """A study file with one damaged 4 KiB page: on some pages tune and calibrate crashed
    (the study's attributes and trials were read outside the refusal), on others the
    refusal blamed the commit; now SQLite's integrity check refuses each page, naming the
    file, and the file is left as it was."""
    from transplanter.studies import backends

    monkeypatch.setattr(backends, "run_one", _fake_run_one)
    monkeypatch.setattr(backends, "ProcessBackend", lambda workers: backends.InlineBackend())
    db = tmp_path / "study.db"
    common = ["--seeds", "1", "--seedlings", "2", "--trials", "3", "--quiet"]
    tune = ["tune", "paper", "--param", "taught.z_low_mm=28..40", *common]
    calibrate = ["calibrate", "paper", "--observed", "1/2", "--fit", "taught.z_low_mm=28..40",
                 "--backend", "inline", *common]  # fmt: skip
    for args in (tune, calibrate):  # both studies in one file
        assert main([*args, "--storage", str(db), "--out", str(tmp_path / "made")]) == 0
    capsys.readouterr()
    good = db.read_bytes()
    page_size = int.from_bytes(good[16:18], "big")  # the database header's page size
    pages = len(good) // page_size
    assert page_size == 4096 and pages >= 20
    bad, out = tmp_path / "bad.db", tmp_path / "out"
    for page in range(pages):
        damaged = bytearray(good)
        damaged[page * page_size : (page + 1) * page_size] = b"\xa5" * page_size
        for args in (tune, calibrate):
            bad.write_bytes(damaged)
            assert main([*args, "--storage", str(bad), "--out", str(out)]) == 2, page + 1
            err = capsys.readouterr().err.strip().splitlines()
            assert len(err) == 1 and f"--storage {bad} is " in err[0], (page + 1, err)
            why = "not a SQLite database" if page == 0 else "is damaged (SQLite: "
            assert why in err[0], (page + 1, err)
            assert bad.read_bytes() == damaged  # untouched
    assert not out.exists() or not any(out.iterdir())


def test_a_study_stopped_and_resumed_takes_the_points_of_an_uninterrupted_one(
    tmp_path, capsys, monkeypatch
):
    """The sampler was seeded by Optuna's trial number, and a trial stopped by Ctrl-C (told
    FAIL: it does not count) takes one: the resumed study drew other points from then on
    than the same study run without a stop. Now seeded by the trials that count."""
    import os
    import signal

    from transplanter.studies import backends

    runs = {"left": -1}  # runs before the Ctrl-C, -1: none

    def stopped_once(task):  # Ctrl-C during the 4th trial's run, sent from inside it
        runs["left"] -= 1
        if runs["left"] == 0:
            os.kill(os.getpid(), signal.SIGINT)
        return _fake_run_one(task)

    monkeypatch.setattr(backends, "run_one", stopped_once)
    monkeypatch.setattr(backends, "ProcessBackend", lambda workers: backends.InlineBackend())

    def tune(name, trials):
        out, db = tmp_path / name, tmp_path / f"{name}.db"
        args = ["tune", "paper", "--param", "taught.z_low_mm=28..40", "--param",
                "taught.s_high_mm_s=120..220", "--seeds", "1", "--seedlings", "2", "--quiet",
                "--storage", str(db), "--out", str(out)]  # fmt: skip
        status = main([*args, "--trials", str(trials)])
        capsys.readouterr()
        return status, list(csv.DictReader((out / "trials.csv").open()))

    assert tune("whole", 12)[0] == 0  # past the sampler's 10 random startup trials
    runs["left"] = 4
    status, before = tune("stopped", 12)
    assert status == 130 and len(before) == 3  # trial 3 stopped: told FAIL, not counted
    assert tune("stopped", 12)[0] == 0  # resumed
    whole, resumed = tune("whole", 12)[1], tune("stopped", 12)[1]

    def points(rows):  # every column but Optuna's number: the stopped trial took number 3
        return [{k: v for k, v in row.items() if k != "trial"} for row in rows]

    assert points(resumed) == points(whole)
    assert [r["trial"] for r in resumed] == ["0", "1", "2", *map(str, range(4, 13))]


def _scored(trial, k, n=40, cycle=3.2):
    return {"trial": trial, "successes": k, "seedlings": n, "cycle_time_s": cycle}


def test_saturation_note_when_perfect_points_tie_on_the_lower_bound():
    """The README's 20 seedlings x 2 seeds: five of six points 40/40 (docs/tuning.md)."""
    from transplanter.studies.tune import rule_of_three_seedlings, saturation_note

    rows = [_scored(t, 40, cycle=3.0 + t / 10) for t in range(5)] + [_scored(5, 39)]
    note = saturation_note(rows, rows[0])
    assert note is not None and "\n" not in note
    assert note.startswith("note: 5 of 6 points succeeded on all 40 seedlings")
    assert "above 7.2 %" in note  # 1 - 0.05 ** (1 / 40): the exact rule of three
    assert "about 300 seedlings per point" in note
    assert rule_of_three_seedlings(0.01) == 300 and rule_of_three_seedlings(0.05) == 60
    # a single perfect point, a chosen point that failed, no chosen point: nothing to say
    assert saturation_note([rows[0], rows[5]], rows[0]) is None
    assert saturation_note([_scored(0, 39), _scored(1, 38)], _scored(0, 39)) is None
    assert saturation_note([], None) is None
    # the delta's tray job counts serviced cells, and a user gives more through max_cells
    cells = saturation_note(rows, rows[0], "serviced cells", "delta_refill.max_cells x seeds")
    assert cells.startswith("note: 5 of 6 points succeeded on all 40 serviced cells")
    assert "about 300 serviced cells per point (delta_refill.max_cells x seeds)" in cells


def test_a_delta_jobs_study_is_identified_by_the_sections_it_reads():
    from transplanter.studies.tune import scenario_digest

    def digest(name, **over):
        return scenario_digest(load_scenario(name, over))

    # the five-bar's digest is its sections' as before: [plugs] is not one of them
    with pytest.raises(ScenarioError, match=r"\[plugs\] moisture_pct \(read by the plug"):
        digest("paper", **{"plugs.moisture_pct": 75})  # no kind of the five-bar's reads it
    assert digest("delta_refill", **{"plugs.moisture_pct": 75}) != digest("delta_refill")
    assert digest("delta_refill", **{"delta_refill.lift_mm": 90}) != digest("delta_refill")
