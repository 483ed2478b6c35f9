"""transplanter calibrate: fit keys to an observed success rate (and cycle), the loss, the
consistent ranges, the three files, refusals, determinism, Ctrl-C."""

import csv
import json
import math

import pytest

from transplanter.cli import main
from transplanter.scenario.schema import load_scenario
from transplanter.studies import backends as sweep_backends
from transplanter.studies.calibrate import (
    CalibrationSpec,
    Observation,
    binomial_deviance,
    consistent_ranges,
    cycle_penalty,
    is_consistent,
    loss,
    parse_observed,
    run_calibrate,
)
from transplanter.studies.sweep import SweepRefused
from transplanter.studies.tune import Param, TuneSpec

pytest.importorskip("optuna")

ZLOW = Param("taught.z_low_mm", "float", 18.0, 40.0)


# ---------------------------------------------------------------------------------------
# Observation
# ---------------------------------------------------------------------------------------


def test_parse_observed():
    assert parse_observed("112/120") == (112, 120)
    assert parse_observed(" 0 / 3 ") == (0, 3)
    assert parse_observed("5/5") == (5, 5)


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("121/120", "more than all"),
        ("0/0", "at least one seedling"),
        ("112", "SUCCESSES/SEEDLINGS"),
        ("1.5/2", "SUCCESSES/SEEDLINGS"),
        ("-1/2", "SUCCESSES/SEEDLINGS"),
        ("\u0661/\u0662", "SUCCESSES/SEEDLINGS"),  # Arabic-Indic digits
        ("1/2/3", "SUCCESSES/SEEDLINGS"),
        ("", "SUCCESSES/SEEDLINGS"),
    ],
)
def test_parse_observed_refusals(text, reason):
    with pytest.raises(SweepRefused, match=reason):
        parse_observed(text)


def test_observation_checks_and_interval():
    o = Observation(112, 120)
    assert o.rate == pytest.approx(112 / 120)
    lo, hi = o.ci95
    assert lo < o.rate < hi and hi < 1
    assert Observation(120, 120).ci95[1] == 1.0
    with pytest.raises(SweepRefused, match="--cycle-s"):
        Observation(1, 2, cycle_s=0.0)
    with pytest.raises(SweepRefused, match="--cycle-s"):
        Observation(1, 2, cycle_s=math.nan)
    with pytest.raises(SweepRefused, match="--cycle-tol-s"):
        Observation(1, 2, cycle_s=3.5, cycle_tol_s=0.0)
    with pytest.raises(SweepRefused, match="K <= N"):
        Observation(3, 2)


# ---------------------------------------------------------------------------------------
# The loss
# ---------------------------------------------------------------------------------------


def test_deviance_is_zero_when_the_twin_matches_the_observation():
    assert binomial_deviance(56, 60, 112, 120) == pytest.approx(0, abs=1e-12)
    assert binomial_deviance(3, 3, 120, 120) == 0
    assert binomial_deviance(0, 4, 0, 120) == 0
    assert binomial_deviance(2, 4, 1, 2) == pytest.approx(0, abs=1e-12)


def test_deviance_grows_with_the_distance_and_is_the_g_test():
    from scipy.stats import chi2_contingency

    far = [binomial_deviance(k, 60, 112, 120) for k in (56, 52, 45, 30, 0)]
    assert far == sorted(far) and far[0] < 1e-9 < far[1]
    assert binomial_deviance(60, 60, 112, 120) > binomial_deviance(57, 60, 112, 120)
    # more evidence for the same gap is a larger distance
    assert binomial_deviance(30, 60, 90, 120) > binomial_deviance(5, 10, 90, 120)
    g, *_ = chi2_contingency([[40, 20], [112, 8]], correction=False, lambda_="log-likelihood")
    assert binomial_deviance(40, 60, 112, 120) == pytest.approx(g)
    with pytest.raises(ValueError):
        binomial_deviance(3, 2, 1, 2)


def test_cycle_penalty_beyond_the_tolerance():
    o = Observation(112, 120, cycle_s=3.5, cycle_tol_s=0.1)
    assert cycle_penalty(3.5, o) == 0
    assert cycle_penalty(3.58, o) == 0
    assert cycle_penalty(3.42, o) == 0
    assert cycle_penalty(3.7, o) == pytest.approx(1.0)  # one tolerance beyond
    assert cycle_penalty(3.2, o) == pytest.approx(4.0)
    assert cycle_penalty(None, o) == math.inf
    assert cycle_penalty(9.9, Observation(112, 120)) == 0  # no cycle observed
    assert loss(56, 60, 3.7, o) == pytest.approx(1.0)
    assert loss(50, 60, 3.5, o) == pytest.approx(binomial_deviance(50, 60, 112, 120))


def test_consistency_uses_the_observed_interval_and_the_cycle():
    o = Observation(1, 2)  # Wilson 9.5-90.5 %
    assert is_consistent({"success_rate": 0.5}, o)
    assert not is_consistent({"success_rate": 1.0}, o)
    assert not is_consistent({"success_rate": None}, o)
    oc = Observation(1, 2, cycle_s=3.5)
    assert is_consistent({"success_rate": 0.5, "cycle_time_s": 3.55}, oc)
    assert not is_consistent({"success_rate": 0.5, "cycle_time_s": 3.65}, oc)


def _row(z, ok):
    return {"taught.z_low_mm": z, "loss": 0.0 if ok else 5.0, "consistent": ok}


def test_consistent_ranges():
    rows = [_row(19.0, False), _row(24.0, True), _row(30.0, True), _row(36.0, False)]
    r = consistent_ranges(rows, [ZLOW])["taught.z_low_mm"]
    assert (r["low"], r["high"], r["points"], r["notes"]) == (24.0, 30.0, 2, [])
    r = consistent_ranges(rows[:3], [ZLOW])["taught.z_low_mm"]
    assert r["notes"] == ["open above: no evaluated point over 30 disagrees"]
    rows = [_row(18.5, True), _row(25.0, False), _row(39.9, True)]
    r = consistent_ranges(rows, [ZLOW])["taught.z_low_mm"]
    assert any("touches the search bound 18" in n for n in r["notes"])
    assert any("touches the search bound 40" in n for n in r["notes"])
    r = consistent_ranges([_row(20.0, False), _row(27.0, True), _row(33.0, False)], [ZLOW])
    assert r["taught.z_low_mm"]["notes"] == ["a single point: add trials to see how far it extends"]
    r = consistent_ranges([_row(20.0, False)], [ZLOW])["taught.z_low_mm"]
    assert r["low"] is None and r["notes"] == ["no evaluated point is consistent"]


# ---------------------------------------------------------------------------------------
# The search, with a stand-in for the physics
# ---------------------------------------------------------------------------------------


def fake_run_one(task):
    """Seedlings succeed from Z_low 26 mm up (seed 2: from 28); the cycle shortens with Z."""
    z = task["setting"]["taught.z_low_mm"]
    n = task["seedlings"]
    k = n if z >= 26 + 2 * (task["seed"] == 2) else 0
    row = {**task["setting"], "seed": task["seed"], **sweep_backends._empty_result()}
    row.update(successes=k, seedlings=n, success_rate=k / n, cycle_time_s=4.0 - 0.03 * (z - 18),
               cycles=n, error=None, wall_time_s=0.0)  # fmt: skip
    return row


@pytest.fixture
def fake_physics(monkeypatch):
    monkeypatch.setattr(sweep_backends, "run_one", fake_run_one)


HALF = Observation(2, 4)


def spec_of(observed=HALF, seeds=(1, 2), **kw):
    search = TuneSpec("paper", (ZLOW,), seeds, 4, option="--fit", **kw)
    return CalibrationSpec(search, observed)


def test_search_finds_the_region_and_writes_the_files(tmp_path, fake_physics):
    report = run_calibrate(spec_of(), 12, tmp_path / "out", backend="inline")
    assert report.finished == report.ran == 12 and not report.interrupted
    best = report.best
    # half the picks succeed only between the two seeds' thresholds
    assert 26 <= best["taught.z_low_mm"] < 28
    assert best["loss"] == pytest.approx(0, abs=1e-12)
    assert best["successes"] == 4 and best["seedlings"] == 8
    r = report.ranges["taught.z_low_mm"]
    assert 26 <= r["low"] <= r["high"] < 28 and r["points"] >= 1
    rows = list(csv.DictReader((tmp_path / "out" / "calibration.csv").open()))
    assert len(rows) == 12 and rows[0]["loss"] and rows[0]["consistent"] in ("True", "False")
    data = json.loads((tmp_path / "out" / "calibration.json").read_text())
    assert data["observed"]["successes"] == 2 and data["best"]["trial"] == best["trial"]
    assert data["command"].startswith("transplanter calibrate paper --observed 2/4 --fit ")
    text = (tmp_path / "out" / "calibrated.toml").read_text()
    assert "# observed: 2/4 (50.0 %" in text and "# command: transplanter calibrate" in text
    calibrated = load_scenario(tmp_path / "out" / "calibrated.toml")
    assert calibrated.taught.z_low_m == pytest.approx(best["taught.z_low_mm"] * 1e-3)
    assert (
        calibrated.taught
        == load_scenario("paper", {"taught.z_low_mm": best["taught.z_low_mm"]}).taught
    )


def test_the_same_command_gives_the_same_calibration(tmp_path, fake_physics):
    a = run_calibrate(spec_of(sampler_seed=3), 6, tmp_path / "a", backend="inline")
    b = run_calibrate(spec_of(sampler_seed=3), 6, tmp_path / "b", backend="inline")
    assert a.rows == b.rows
    assert (tmp_path / "a" / "calibration.csv").read_text() == (
        tmp_path / "b" / "calibration.csv"
    ).read_text()
    c = run_calibrate(spec_of(sampler_seed=4), 6, tmp_path / "c", backend="inline")
    assert c.rows != a.rows


def test_a_stored_study_resumes_and_refuses_another_observation(tmp_path, fake_physics):
    db = tmp_path / "c.db"
    first = run_calibrate(spec_of(), 3, tmp_path / "o", storage=db, backend="inline")
    again = run_calibrate(spec_of(), 5, tmp_path / "o", storage=db, backend="inline")
    assert (again.finished, again.ran) == (5, 2)
    assert again.rows[:3] == first.rows
    whole = run_calibrate(spec_of(), 5, tmp_path / "w", backend="inline")
    assert whole.rows == again.rows  # resumed or not, the same study
    with pytest.raises(SweepRefused, match="differs in: observed"):
        run_calibrate(spec_of(Observation(3, 4)), 5, tmp_path / "o", storage=db, backend="inline")


def test_cycle_time_is_fitted_too(tmp_path, fake_physics):
    # all succeed from 28 mm up; a 3.5 s cycle is Z_low 34.67 mm in the stand-in
    observed = Observation(8, 8, cycle_s=3.5, cycle_tol_s=0.05)
    report = run_calibrate(spec_of(observed), 15, tmp_path / "out", backend="inline")
    assert abs(report.best["cycle_time_s"] - 3.5) < 0.1
    for row in report.rows:
        if row["consistent"]:
            assert abs(row["cycle_time_s"] - 3.5) <= 0.05 + 1e-9


def test_ctrl_c_keeps_the_finished_points(tmp_path, monkeypatch):
    calls = []

    def stop_on_the_fifth(task):
        calls.append(task)
        if len(calls) == 5:
            raise KeyboardInterrupt
        return fake_run_one(task)

    monkeypatch.setattr(sweep_backends, "run_one", stop_on_the_fifth)
    report = run_calibrate(spec_of(), 10, tmp_path / "out", backend="inline")
    assert report.interrupted and report.ran == 2 and len(report.rows) == 2
    rows = list(csv.DictReader((tmp_path / "out" / "calibration.csv").open()))
    assert [r["trial"] for r in rows] == ["0", "1"]
    assert (tmp_path / "out" / "calibrated.toml").exists()


@pytest.mark.parametrize("where", ["asking", "telling"])
def test_a_stop_while_asking_or_telling_leaves_no_trial_running(
    tmp_path, fake_physics, monkeypatch, where
):
    """Ctrl-C (or SIGTERM) while the sampler chose a trial's point, or while its results were
    stored, left the trial RUNNING in the study for good. Now a stop while asking fails the
    trial (no results: it does not count), one while telling lets it finish and stops
    after it; the signal is sent by this process from inside Optuna, at exactly that point."""
    import os
    import signal

    import optuna

    sent = []

    def stop_once(trial_number):
        if trial_number == 1 and not sent:
            sent.append(trial_number)
            os.kill(os.getpid(), signal.SIGINT)

    if where == "asking":
        real = optuna.samplers.TPESampler.sample_independent

        def sample(self, study, trial, name, distribution):
            stop_once(trial.number)
            return real(self, study, trial, name, distribution)

        monkeypatch.setattr(optuna.samplers.TPESampler, "sample_independent", sample)
    else:
        real = optuna.study.Study.tell

        def tell(self, trial, *args, **kwargs):
            stop_once(trial.number)
            return real(self, trial, *args, **kwargs)

        monkeypatch.setattr(optuna.study.Study, "tell", tell)
    db = tmp_path / "c.db"
    report = run_calibrate(spec_of(), 5, tmp_path / "out", storage=db, backend="inline")
    assert sent == [1] and report.interrupted
    study = optuna.load_study(study_name="calibrate", storage=f"sqlite:///{db}")
    states = [t.state.name for t in study.get_trials(deepcopy=False)]
    if where == "asking":
        assert states == ["COMPLETE", "FAIL"]  # trial 1 stopped before it ran: not counted
        assert (report.finished, report.ran, len(report.rows)) == (1, 1, 1)
    else:
        assert states == ["COMPLETE", "COMPLETE"]  # trial 1 finished whole, then the stop
        assert (report.finished, report.ran, len(report.rows)) == (2, 2, 2)
    again = run_calibrate(spec_of(), 3, tmp_path / "out", storage=db, backend="inline")
    assert not again.interrupted and again.finished == 3  # the rerun goes on


def test_cli_exit_130_on_ctrl_c(tmp_path, monkeypatch, capsys):
    def stop(task):
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep_backends, "run_one", stop)
    out = tmp_path / "out"
    code = main(["calibrate", "paper", "--observed", "1/2", "--fit", "taught.z_low_mm=18..40",
                 "--seeds", "1", "--seedlings", "2", "--backend", "inline", "--out", str(out),
                 "--quiet"])  # fmt: skip
    assert code == 130
    assert "interrupted" in capsys.readouterr().err
    assert (out / "calibration.csv").exists() and not (out / "calibrated.toml").exists()


# ---------------------------------------------------------------------------------------
# The command line
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("extra", "reason"),
    [
        (["--observed", "5/4", "--fit", "taught.z_low_mm=18..40"], "more than all"),
        (["--observed", "x", "--fit", "taught.z_low_mm=18..40"], "SUCCESSES/SEEDLINGS"),
        (["--observed", "1/2"], "at least one --fit"),
        (["--observed", "1/2", "--fit", "taught.nope_mm=1..2"], "--fit 'taught.nope_mm=1..2'"),
        (["--observed", "1/2", "--fit", "taught.z_low_mm=40..18"], "LO must be below HI"),
        (["--observed", "1/2", "--fit", "taught.z_low_mm=18..4000"], "outside the allowed range"),
        (["--observed", "1/2", "--fit", "motion.profile=0..1"], "only number keys"),
        (
            [
                "--observed",
                "1/2",
                "--fit",
                "taught.z_low_mm=18..40",
                "--fit",
                "taught.z_low_mm=20..30",
            ],
            "--fit: a key is given twice",
        ),  # fmt: skip
        (
            ["--observed", "1/2", "--fit", "taught.z_low_mm=18..40", "--set", "taught.z_low_mm=30"],
            "both set (--set) and fitted (--fit)",
        ),  # fmt: skip
        (
            ["--observed", "1/2", "--fit", "taught.z_low_mm=18..40", "--cycle-s", "-1"],
            "--cycle-s",
        ),  # fmt: skip
        (["--observed", "1/2", "--fit", "taught.z_low_mm=18..40", "--trials", "0"], "--trials"),
        (
            ["--observed", "1/2", "--fit", "taught.z_low_mm=18..40", "--address", "x:1"],
            "--address",
        ),  # fmt: skip
    ],
)
def test_cli_refusals_before_anything_runs(tmp_path, capsys, monkeypatch, extra, reason):
    def never(task):  # pragma: no cover - a refusal runs nothing
        raise AssertionError("ran")

    monkeypatch.setattr(sweep_backends, "run_one", never)
    out, db = tmp_path / "out", tmp_path / "c.db"
    code = main(["calibrate", "paper", "--seedlings", "2", "--backend", "inline", "--out",
                 str(out), "--storage", str(db), *extra])  # fmt: skip
    assert code == 2
    err = capsys.readouterr().err
    assert "calibrate refused" in err and reason in err
    assert not out.exists() and not db.exists()


def test_cli_calibrates_with_the_physics_and_the_result_runs(tmp_path, capsys):
    """Real trials: a low Z_low drops seed 1's seedlings, a high one lands them; an observed
    0/2 (Wilson 0-65.8 %) is matched only low down."""
    args = ["calibrate", "paper", "--observed", "0/2", "--fit", "taught.z_low_mm=18..30",
            "--seeds", "1", "--seedlings", "2", "--trials", "3", "--backend", "inline",
            "--quiet"]  # fmt: skip
    out = tmp_path / "out"
    assert main([*args, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "observed: 0/2 (0.0 %" in printed and "fitted (lowest loss, trial" in printed
    rows = list(csv.DictReader((out / "calibration.csv").open()))
    assert len(rows) == 3 and all(r["state"] == "COMPLETE" for r in rows)
    for r in rows:
        assert 18 <= float(r["taught.z_low_mm"]) <= 30
        assert r["consistent"] == str(float(r["success_rate"]) <= 0.6577)  # 0/2 or 1/2
    data = json.loads((out / "calibration.json").read_text())
    best = data["best"]
    assert best["loss"] == min(float(r["loss"]) for r in rows)
    assert load_scenario(out / "calibrated.toml").taught.z_low_m == pytest.approx(
        best["taught.z_low_mm"] * 1e-3
    )
    # it runs (4: the firmware stopped on a fault, which a low Z_low may provoke)
    assert main(["trial", str(out / "calibrated.toml"), "--seedlings", "2", "--quiet"]) in (0, 4)
    capsys.readouterr()
    # the same command again: the same points and results
    assert main([*args, "--out", str(tmp_path / "again")]) == 0
    assert (tmp_path / "again" / "calibration.csv").read_text() == (
        out / "calibration.csv"
    ).read_text()


def test_cli_refuses_an_out_it_cannot_write_before_any_trial(tmp_path, capsys, monkeypatch):
    def never(task):  # pragma: no cover - a refusal runs nothing
        raise AssertionError("ran")

    monkeypatch.setattr(sweep_backends, "run_one", never)
    out = tmp_path / "out"
    args = ["calibrate", "paper", "--observed", "1/2", "--fit", "taught.z_low_mm=18..40",
            "--seeds", "1", "--seedlings", "2", "--backend", "inline",
            "--out", str(out)]  # fmt: skip
    for name in ("calibration.csv", "calibration.json", "calibrated.toml"):
        (out / name).mkdir(parents=True)
        assert main(args) == 2
        err = capsys.readouterr().err
        assert "calibrate refused" in err and name in err and "is a directory" in err
        (out / name).rmdir()
    (out / "calibration.json").symlink_to(tmp_path / "elsewhere.json")
    assert main(args) == 2
    assert "calibration.json is a symbolic link" in capsys.readouterr().err
    assert not (tmp_path / "elsewhere.json").exists()
