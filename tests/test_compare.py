"""`transplanter compare` (transplanter.studies.compare): rows pooled from each scenario's
runs, ranked at a success floor, equal to what `trial` gives; resumable; refusals."""

import json

import pytest

from transplanter.cli import main
from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario
from transplanter.studies.compare import (
    CompareSpec,
    compare_row,
    format_table,
    rank_rows,
    run_compare,
)
from transplanter.studies.grid import SweepRefused
from transplanter.twin.serial_pots import run_serial_pots
from transplanter.twin.trial import run_trial


def _row(seed, successes, seedlings, cycle, cycles, **more):
    return {
        "seed": seed, "successes": successes, "seedlings": seedlings, "cycle_time_s": cycle,
        "cycles": cycles, "error": None, "sim_time_s": 100.0, **more,
    }  # fmt: skip


def test_a_row_pools_the_runs_of_a_scenario():
    sc = load_scenario("paper", {"costs.drives_usd": 120})
    rows = [
        _row(1, 38, 40, 3.5, 39, plants_per_hour=1028.6, fail_damaged=1, fail_not_gripped=1,
             motor_energy_j=60.0, peak_motor_torque_nm=0.41),
        _row(2, 40, 40, 3.4, 39, plants_per_hour=1058.8, fail_shoot_crushed=0,
             motor_energy_j=70.0, peak_motor_torque_nm=0.52),
        {**_row(3, None, None, None, None), "error": "setting refused: x"},
    ]  # fmt: skip
    r = compare_row("paper", sc, rows, floor=0.9)
    assert (r["successes"], r["seedlings"], r["trials"], r["errors"]) == (78, 80, 2, 1)
    assert r["success_rate"] == pytest.approx(0.975) and r["meets_floor"]
    assert r["ci95"][0] < 0.975 < r["ci95"][1]
    assert r["cycle_time_s"] == pytest.approx(3.45)  # every timed cycle, pooled
    assert r["plants_per_hour"] == pytest.approx((1028.6 + 1058.8) / 2)
    assert r["damage_rate"] == pytest.approx(1 / 80)  # bent or crushed shoots only
    assert r["failures"] == {"damaged": 1, "not_gripped": 1}
    assert r["peak_motor_torque_nm"] == 0.52
    assert r["energy_per_seedling_j"] == pytest.approx(130 / 80)
    assert r["mean_power_w"] == pytest.approx(130 / 200)
    assert r["drives_usd"] == 120
    assert r["usd_per_plant_per_hour"] == pytest.approx(120 / r["plants_per_hour"])
    assert r["error_messages"] == ["setting refused: x"]
    assert compare_row("paper", sc, rows, floor=0.98)["meets_floor"] is False


def test_every_robot_on_the_pot_line_has_the_pot_lines_damage_rate():
    """The pot line's judge counts a bent or crushed shoot as damage whatever robot works
    the line; a job that judges no damage (the claws' bench) has none."""
    for name, job in (("serial_arm_pots", "serial4:conveyor_tube"),
                      ("delta_pots", "delta:conveyor_tube")):  # fmt: skip
        rows = [_row(1, 2, 4, 8.0, 3, plants_per_hour=450.0, fail_shoot_crushed=1,
                     fail_not_gripped=1)]  # fmt: skip
        r = compare_row("pots", load_scenario(name), rows, floor=0.5)
        assert r["damage_rate"] == pytest.approx(1 / 4) and r["unit"] == "seedlings"
        assert r["job"] == job
    r = compare_row("pots", load_scenario("serial_arm_pots"), [], floor=0.5)
    assert r["drives_usd"] == 27.0
    bench = compare_row("b", load_scenario("plug_bench"), rows, floor=0.5)
    assert bench["damage_rate"] is None and bench["trials"] == 1
    delta = compare_row("d", load_scenario("delta_refill"), [], floor=0.5)
    assert delta["cycle"] == "time per operation" and delta["unit"] == "serviced cells"
    assert delta["success_rate"] is None and delta["trials"] == 0


def _ranked(name, job, verdict, pph, band=None, ci=(0.95, 1.0), **more):
    return {"scenario": name, "workcell": job, "verdict": verdict, "plants_per_hour": pph,
            "plants_per_hour_ci95": band, "ci95": list(ci), **more}  # fmt: skip


def test_rows_rank_within_their_job_decided_first_then_undecided_then_below():
    """A row ranks among the rows of its own job only; those whose interval lies above the
    floor by plants per hour, then the undecided, then those below, however fast."""
    rows = [
        _ranked("fast_below", "line", "below", 2000.0),
        _ranked("slow_good", "line", "above", 400.0),
        _ranked("tray", "trays", "above", 5000.0),
        _ranked("fast_open", "line", "undecided", 1500.0),
        _ranked("fast_good", "line", "above", 1000.0),
        _ranked("none", "line", "below", None),
    ]
    ranked = rank_rows(rows)
    assert [(r["workcell"], r["scenario"], r["rank"]) for r in ranked] == [
        ("line", "fast_good", 1), ("line", "slow_good", 2), ("line", "fast_open", 3),
        ("line", "fast_below", 4), ("line", "none", 5), ("trays", "tray", 1),
    ]  # fmt: skip
    # rows of the old layout (meets_floor, no verdict, no job) still rank
    old = rank_rows([{"scenario": "a", "meets_floor": False, "plants_per_hour": 9.0},
                     {"scenario": "b", "meets_floor": True, "plants_per_hour": 1.0}])  # fmt: skip
    assert [r["scenario"] for r in old] == ["b", "a"]


def test_ranked_rows_whose_plants_per_hour_intervals_overlap_tie():
    rows = [
        _ranked("a", "line", "above", 1945.0, band=(1900.0, 1990.0)),
        _ranked("b", "line", "above", 1894.0, band=(1850.0, 1920.0)),
        _ranked("c", "line", "above", 1581.0, band=(1581.0, 1581.0)),  # a planned cycle
        _ranked("d", "line", "undecided", 1570.0, band=(1560.0, 1590.0)),
    ]
    ranked = rank_rows(rows)
    assert [(r["scenario"], r["rank"], r["tie"]) for r in ranked] == [
        ("a", 1, 1), ("b", 2, 1), ("c", 3, None), ("d", 4, None),
    ]  # fmt: skip
    # two planned cycles 0.03 plants/h apart (the gantry's and the five-bar's at the paper's
    # setting) are below the table's whole plants: tied; a whole plant apart they are not
    same = [
        _ranked("gantry", "line", "above", 995.41, band=(995.41, 995.41)),
        _ranked("fivebar", "line", "above", 995.38, band=(995.38, 995.38)),
        _ranked("slower", "line", "above", 994.0, band=(994.0, 994.0)),
    ]
    assert [(r["rank"], r["tie"]) for r in rank_rows(same)] == [(1, 1), (2, 1), (3, None)]


def test_a_row_is_decided_only_by_its_interval_against_the_floor():
    from transplanter.studies.compare import ABOVE, BELOW, UNDECIDED, verdict

    assert verdict((0.929, 0.991), 0.9) == ABOVE
    assert verdict((0.80, 0.95), 0.9) == UNDECIDED
    assert verdict((0.50, 0.706), 0.9) == BELOW
    sc = load_scenario("serial_arm_pots")
    # 35/40 and 36/40: 88.75 %, its interval holds the 90 % floor
    rows = [_row(1, 35, 40, 7.9, 40, plants_per_hour=455.0),
            _row(2, 36, 40, 7.9, 40, plants_per_hour=450.0)]  # fmt: skip
    r = compare_row("pots", sc, rows, floor=0.9)
    assert r["verdict"] == UNDECIDED and r["meets_floor"] is False
    assert r["decide_seedlings"] > 1000  # at 88.75 %, 1.25 points from the floor
    assert r["plants_per_hour_ci95"][0] < 452.5 < r["plants_per_hour_ci95"][1]
    perfect = compare_row("pots", sc, [_row(1, 40, 40, 7.9, 40)], floor=0.9)
    assert perfect["verdict"] == ABOVE and perfect["decide_seedlings"] is None


def test_the_table_is_one_per_job_and_says_what_the_data_cannot_decide():
    from transplanter.studies.compare import format_table

    rows = rank_rows([
        _ranked("a", "line", "above", 1945.0, band=(1900.0, 1990.0), ci=(0.929, 0.991)),
        _ranked("b", "line", "above", 1894.0, band=(1850.0, 1920.0), ci=(0.954, 1.0)),
        _ranked("c", "line", "undecided", 453.0, ci=(0.80, 0.95), decide_seedlings=1282,
                unit="seedlings", more="--seedlings x seeds"),
        _ranked("t", "trays", "below", 1650.0, ci=(0.5, 0.7), unit="serviced cells"),
    ])  # fmt: skip
    for r in rows:
        r.update(robot="r", effector="e", success_rate=0.9, successes=9, seedlings=10,
                 cycle_time_s=1.0, damage_rate=None, peak_motor_torque_nm=None,
                 energy_per_seedling_j=None, mean_power_w=None, drives_usd=None,
                 usd_per_plant_per_hour=None, failures={}, errors=0, trials=3)  # fmt: skip
    text = format_table(rows, 0.9)
    assert "job line (seedlings), ranked within the job:" in text
    assert "job trays (serviced cells), ranked within the job:" in text
    lines = text.splitlines()
    a, b, c, t = (next(x for x in lines if x[5:].startswith(n + " ")) for n in "abct")
    assert a.startswith(" 1=") and b.startswith(" 1=")  # tied on plants per hour
    assert c.startswith("  3") and c.endswith(" ?") and t.startswith("  1") and t.endswith(" *")
    assert "tie: a and b on plants per hour" in text
    assert (
        "undecided: c: its 95 % interval (80.0-95.0 %) holds the 90 % floor; at its rate "
        "about 1282 seedlings would decide it (--seedlings x seeds)" in text
    )
    assert "note: the success intervals of a (92.9-99.1 %) and b (95.4-100.0 %) overlap" in text


def test_the_spec_refuses_what_it_cannot_compare():
    with pytest.raises(SweepRefused, match="at least one scenario"):
        CompareSpec((), (1,))
    with pytest.raises(SweepRefused, match="not a share"):
        CompareSpec(("paper",), (1,), success_floor=90)
    with pytest.raises(SweepRefused, match="two scenarios compare as 'paper'"):
        CompareSpec(("paper", "paper"), (1,))


def test_rows_equal_the_trials_and_a_rerun_resumes(tmp_path):
    spec = CompareSpec(("paper", "serial_arm_pots"), (3,), seedlings=2, success_floor=0.5)
    report = run_compare(spec, tmp_path / "c", backend="inline")
    assert report.ran == 2 and not report.interrupted
    by = {r["scenario"]: r for r in report.rows}
    fivebar = run_trial(
        assemble(load_scenario("paper", {"scenario.seedlings": 2, "scenario.seed": 3}))
    ).to_dict()
    row = by["paper"]
    assert (row["successes"], row["seedlings"]) == (fivebar["successes"], fivebar["seedlings"])
    assert row["cycle_time_s"] == fivebar["cycle_time_s"]
    assert row["plants_per_hour"] == fivebar["plants_per_hour"]
    assert row["motor_energy_j"] == fivebar["motors"]["energy_j"]
    assert row["peak_motor_torque_nm"] == fivebar["motors"]["peak_robot_torque_nm"]
    pots = run_serial_pots(load_scenario("serial_arm_pots", {"scenario.seedlings": 2}), 3)
    d = pots.to_dict()
    row = by["serial_arm_pots"]
    assert (row["successes"], row["seedlings"]) == (d["successes"], d["seedlings"])
    assert row["plants_per_hour"] == d["plants_per_hour"]  # the five-bar's definition
    assert row["cycle_time_s"] == d["cycle_time_s"]
    assert row["motor_energy_j"] == d["motors"]["energy_j"]
    # the files: the rows as JSON, the table, the CSV and the plot
    saved = json.loads((tmp_path / "c" / "compare.json").read_text())
    assert [r["scenario"] for r in saved["rows"]] == [r["scenario"] for r in report.rows]
    assert saved["rows"] == json.loads(json.dumps(report.rows))
    assert (tmp_path / "c" / "compare.txt").read_text() == report.table
    assert (tmp_path / "c" / "compare.png").stat().st_size > 10_000
    assert (tmp_path / "c" / "compare.csv").read_text().count("\n") == 3
    # a rerun runs nothing and gives the same rows; another comparison there is refused
    again = run_compare(spec, tmp_path / "c", backend="inline", plots=False)
    assert (again.ran, again.skipped) == (0, 2) and again.rows == report.rows
    with pytest.raises(SweepRefused, match="another comparison"):
        run_compare(CompareSpec(("paper",), (3,), seedlings=2), tmp_path / "c")


def test_cli_refusals_name_the_problem(tmp_path, capsys):
    out = str(tmp_path / "c")
    assert main(["compare", "paper", "--success-floor", "1.5", "--out", out]) == 2
    assert "not a share" in capsys.readouterr().err
    assert main(["compare", "paper", "--seeds", "x", "--out", out]) == 2
    assert main(["compare", "paper", "no_such_scenario", "--out", out]) == 2
    assert "no_such_scenario" in capsys.readouterr().err
    assert not (tmp_path / "c").exists()


@pytest.mark.parametrize(("text", "kind"), [("null", "null"), ("[]", "a list"), ("7", "a number")])
def test_a_manifest_that_is_not_an_object_is_refused_in_one_line(tmp_path, capsys, text, kind):
    """compare.json holding null (or a scenario's sweep.json holding []) was an
    AttributeError when compare resumed from that --out."""
    args = ["compare", "paper", "--seeds", "1", "--seedlings", "1", "--quiet"]
    out = tmp_path / "c"
    out.mkdir()
    (out / "compare.json").write_text(text)
    assert main([*args, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{out / 'compare.json'} is not a comparison's manifest" in err[0]
    assert f"it holds {kind}" in err[0]
    assert [p.name for p in out.iterdir()] == ["compare.json"]
    # a scenario's own sweep under runs/
    out = tmp_path / "d"
    (out / "runs" / "paper").mkdir(parents=True)
    (out / "runs" / "paper" / "sweep.json").write_text(text)
    assert main([*args, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "runs/paper/sweep.json is not a sweep's manifest" in err[0], err
    assert sorted(p.name for p in out.rglob("*")) == ["paper", "runs", "sweep.json"]


def test_a_link_planted_under_runs_is_refused_and_nothing_is_written_through_it(
    tmp_path, capsys, monkeypatch
):
    """A link at OUT/runs/paper was followed: the sweep's runs.csv, runs.jsonl, settings.csv
    and sweep.json were written into its target, outside --out."""
    from transplanter.studies import backends
    from transplanter.studies.sweep import run_sweep

    def no_physics(task):  # pragma: no cover - a refusal runs nothing
        return {**task["setting"], "seed": task["seed"], **backends._empty_result()}

    monkeypatch.setattr(backends, "run_one", no_physics)
    monkeypatch.setattr(backends, "ProcessBackend", lambda workers: backends.InlineBackend())
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    args = ["compare", "paper", "--seeds", "1", "--seedlings", "1", "--quiet"]
    out = tmp_path / "c"
    (out / "runs").mkdir(parents=True)
    (out / "runs" / "paper").symlink_to(elsewhere)
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "runs").symlink_to(elsewhere)  # OUT/runs itself
    for link in (out / "runs" / "paper", tmp_path / "d" / "runs"):
        assert main([*args, "--out", str(link.parent if link.name == "runs" else out)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"{link} is a symbolic link" in err[0], err
        assert "compare refused" in err[0]
    assert not any(elsewhere.iterdir())  # nothing written there
    assert sorted(p.name for p in out.rglob("*")) == ["paper", "runs"]  # nor in --out
    # a link planted after compare checked: the scenario's sweep refuses it too
    sweep = CompareSpec(("paper",), (1,), seedlings=1).sweeps()[0]
    with pytest.raises(SweepRefused, match="is a symbolic link"):
        run_sweep(sweep, out / "runs" / "paper", backend="inline", own_dir=True)
    assert not any(elsewhere.iterdir())


def test_compare_help_names_every_exit_status(capsys):
    """143 (SIGTERM), which compare returns as sweep does, was missing."""
    with pytest.raises(SystemExit) as info:
        main(["compare", "--help"])
    assert info.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    epilog = text[text.index("exit status:") :]
    for status in ("0 done", "2 refused", "5 a result file", "130 interrupted", "143 the same"):
        assert status in epilog, status


def test_no_help_shows_a_doubled_percent_sign(capsys):
    """compare's and tune's --help read '95 %%': argparse %-formats a help string, not a
    description. Every command's help is read."""
    from transplanter.cli import build_parser

    parser = build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    for command in commands:
        with pytest.raises(SystemExit) as info:
            main([command, "--help"])
        assert info.value.code == 0
        text = " ".join(capsys.readouterr().out.split())
        assert "%%" not in text, command
    for command, said in (("compare", "success with its 95 % interval"), ("tune", "95 % interval")):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        assert said in " ".join(capsys.readouterr().out.split()), command


def test_a_comparison_over_two_jobs_draws_each_jobs_picture(tmp_path):
    """Rows of two jobs: compare.png with both, and compare_JOB.png with each job's own rows,
    listed among the outputs."""
    from transplanter.studies.compare import job_png

    spec = CompareSpec(("paper", "plug_bench"), (1,), seedlings=2, success_floor=0.5)
    report = run_compare(spec, tmp_path / "c", backend="inline")
    jobs = sorted({r["workcell"] for r in report.rows})
    assert jobs == ["conveyor_tube", "plug_bench"]
    for name in ("compare.png", *(job_png(j) for j in jobs)):
        png = (tmp_path / "c" / name).read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000, name


def test_a_pot_line_row_carries_its_jam_rate_with_poissons_interval():
    """jams/1k: the pot line judge's funnel jams per 1,000 seedlings with Poisson's exact 95 %
    interval; a job whose judge names no jam has none."""
    from transplanter.studies.compare import JAM_FIELD
    from transplanter.studies.stats import poisson_interval

    sc = load_scenario("paper", {"scenario.seedlings": 40})
    runs = [
        {
            "seed": s,
            "successes": 38,
            "seedlings": 40,
            "cycles": 38,
            "cycle_time_s": 3.5,
            JAM_FIELD: j,
            "fail_dropped_outside": 2 - j,
        }
        for s, j in ((1, 1), (2, 0), (3, 1))
    ]
    row = compare_row("paper", sc, runs, 0.9)
    assert row["jams_per_1000"] == pytest.approx(1000 * 2 / 120)
    lo, hi = poisson_interval(2, 120)
    assert row["jams_per_1000_ci95"] == pytest.approx([1000 * lo, 1000 * hi])
    assert 1000 * lo == pytest.approx(2.018, abs=1e-3) and 1000 * hi == pytest.approx(
        60.206, abs=1e-3
    )
    none = [{**r, JAM_FIELD: None} for r in runs]
    assert compare_row("paper", sc, none, 0.9)["jams_per_1000"] is None
    assert "jams/1k" in format_table([row | {"rank": 1, "tie": None}], 0.9)
