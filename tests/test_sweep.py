"""transplanter.studies.sweep: the files (manifest, resume, torn lines), the pooled table, and whole
sweeps on every backend (the grid and one run: test_sweep_grid.py, test_sweep_backends.py)."""

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from transplanter.cli import main
from transplanter.studies.sweep import (
    Axis,
    SweepRefused,
    SweepSpec,
    aggregate,
    comparable,
    read_runs,
    run_sweep,
)

# Settings the scenario refuses (Z_low above the paper's Z_up = 60 mm): rows with an error and
# no physics, so the file handling can be tested in milliseconds.
REFUSED = Axis("taught.z_low_mm", (61.0, 70.0))


def _spec(axis=REFUSED, seeds=(1,), seedlings=2, **kw):
    return SweepSpec("paper", (axis,), tuple(seeds), seedlings, kw)


# --- files --------------------------------------------------------------------------------


def test_refused_settings_are_rows_with_their_error(tmp_path):
    report = run_sweep(_spec(seeds=(1, 2)), tmp_path / "s", backend="inline")
    assert report.ran == 4 and report.complete and not report.interrupted
    assert [(r["taught.z_low_mm"], r["seed"]) for r in report.rows] == [
        (61.0, 1),
        (61.0, 2),
        (70.0, 1),
        (70.0, 2),
    ]
    for r in report.rows:
        assert r["error"] == ("setting refused: taught.z_up_mm must be above taught.z_low_mm."), r
        assert r["successes"] is None
    assert [(a["runs"], a["errors"], a["success_rate"]) for a in report.settings] == [
        (2, 2, None),
        (2, 2, None),
    ]
    lines = (tmp_path / "s" / "runs.jsonl").read_text().splitlines()
    assert len(lines) == 4 and all(json.loads(line)["error"] for line in lines)
    csv_lines = (tmp_path / "s" / "settings.csv").read_text().splitlines()
    assert csv_lines[0].startswith("taught.z_low_mm,runs,errors,successes,seedlings,success_rate")
    assert csv_lines[1] == "61.0,2,2,,,,,,,"


def test_a_different_sweep_into_the_same_directory_is_refused(tmp_path):
    out = tmp_path / "s"
    run_sweep(_spec(), out, backend="inline")
    before = (out / "runs.jsonl").read_bytes()
    for other, differs in (
        (_spec(seeds=(1, 2)), "seeds"),
        (_spec(seedlings=3), "seedlings"),
        (_spec(axis=Axis("taught.z_low_mm", (61.0, 71.0))), "vary"),
        (_spec(**{"taught.z_up_mm": 59.0}), "scenario_digest, overrides"),
    ):
        with pytest.raises(SweepRefused) as info:
            run_sweep(other, out, backend="inline")
        assert f"holds the results of a different sweep (it differs in: {differs})" in str(
            info.value
        )
    assert (out / "runs.jsonl").read_bytes() == before  # nothing mixed in
    (out / "sweep.json").unlink()
    with pytest.raises(SweepRefused, match="but no sweep.json"):
        run_sweep(_spec(), out, backend="inline")


def test_resume_skips_finished_runs_and_reruns_a_torn_last_line(tmp_path):
    out = tmp_path / "s"
    full = run_sweep(_spec(seeds=(1, 2)), out, backend="inline")
    table = (out / "runs.csv").read_text()
    again = run_sweep(_spec(seeds=(1, 2)), out, backend="inline")
    assert (again.ran, again.skipped) == (0, 4)
    # killed while writing the third line: half of it on disk, no newline
    lines = (out / "runs.jsonl").read_bytes().splitlines(keepends=True)
    (out / "runs.jsonl").write_bytes(b"".join(lines[:2]) + lines[2][:17])
    resumed = run_sweep(_spec(seeds=(1, 2)), out, backend="inline")
    assert (resumed.ran, resumed.skipped) == (2, 2)
    assert comparable(resumed.rows) == comparable(full.rows)
    assert len((out / "runs.jsonl").read_text().splitlines()) == 4
    assert _without_wall_time(out / "runs.csv") == _without_wall_time_text(table)


def test_read_runs_refuses_a_damaged_middle_line(tmp_path):
    path = tmp_path / "runs.jsonl"
    path.write_text('{"seed": 1}\nnot json\n{"seed": 2}\n')
    with pytest.raises(SweepRefused, match="line 2 is damaged"):
        read_runs(path)
    path.write_text('{"seed": 1}\n{"seed": 2}\n{"se')
    assert read_runs(path) == [{"seed": 1}, {"seed": 2}]
    assert path.read_text() == '{"seed": 1}\n{"seed": 2}\n'  # cut for clean appends


def test_aggregate_pools_seeds_and_counts_errors():
    def row(z, seed, k, n, cycle, error=None):
        return {"z": z, "seed": seed, "successes": k, "seedlings": n, "cycle_time_s": cycle,
                "cycles": n, "error": error}  # fmt: skip

    rows = [
        row(30.0, 1, 9, 10, 3.0),
        row(30.0, 2, 10, 10, 4.0),
        row(30.0, 3, None, None, None, "setting refused: x"),
        row(34.0, 1, 10, 10, 3.5),
    ]
    a30, a34 = aggregate(rows, ["z"])
    assert (a30["runs"], a30["errors"], a30["successes"], a30["seedlings"]) == (3, 1, 19, 20)
    assert a30["success_rate"] == 0.95 and a30["cycle_time_s"] == 3.5
    assert a30["ci95_low"] == pytest.approx(0.7639, abs=1e-4)  # Wilson 19/20
    assert a30["ci_method"] == "Wilson over all picks"
    assert (a34["successes"], a34["cycle_time_s"]) == (10, 3.5)


def test_sweep_cli_refuses_before_running(tmp_path, capsys):
    out = tmp_path / "s"
    args = ["sweep", "paper", "--seeds", "1", "--seedlings", "2", "--out", str(out)]
    assert main([*args, "--vary", "taught.z_lo_mm=30,34"]) == 2
    assert "sweep refused: --vary 'taught.z_lo_mm=30,34': taught.z_lo_mm: unknown key" in (
        capsys.readouterr().err
    )
    assert main([*args, "--vary", "taught.z_low_mm=30:40:3"]) == 2
    assert "does not divide the span 30..40" in capsys.readouterr().err
    assert main([*args, "--vary", "taught.z_low_mm=30", "--set", "arm.l9_mm=1"]) == 2
    assert "arm.l9_mm: unknown key" in capsys.readouterr().err
    assert main([*args, "--vary", "taught.z_low_mm=30", "--address", "x:1"]) == 2
    assert "use it with --backend ray" in capsys.readouterr().err
    assert main(["sweep", "paper", "--vary", "taught.z_low_mm=30", "--seedlings", "41",
                 "--out", str(out)]) == 2  # fmt: skip
    assert "more than the conveyor holds" in capsys.readouterr().err
    assert not out.exists()


def _without_wall_time_text(text):
    lines = [line.split(",") for line in text.splitlines()]
    col = lines[0].index("wall_time_s")
    return [row[:col] + row[col + 1 :] for row in lines]


def _without_wall_time(path):
    return _without_wall_time_text(path.read_text())


# --- physics: real trials, 2 seedlings ----------------------------------------------------

PHYSICS = Axis("taught.z_low_mm", (20.0, 34.0))  # 20: the jaws strike the belt table


@pytest.fixture(scope="module")
def inline_reference(tmp_path_factory):
    """The uninterrupted two-setting sweep, run in this process."""
    out = tmp_path_factory.mktemp("ref")
    return out, run_sweep(_spec(axis=PHYSICS), out, backend="inline", plots=False)


@pytest.mark.slow
def test_physics_rows_hold_real_numbers(inline_reference):
    _, ref = inline_reference
    low, nominal = ref.rows
    assert (nominal["successes"], nominal["seedlings"], nominal["error"]) == (2, 2, None)
    assert 3.0 < nominal["cycle_time_s"] < 4.0 and nominal["lost_step_events"] == 0
    assert (low["successes"], low["fail_lost_steps"], low["error"]) == (0, 1, None)
    assert low["fail_position_lost"] == 1  # the first strike left the arm off position
    assert low["lost_step_events"] > 0 and low["cycle_time_s"] > nominal["cycle_time_s"]


@pytest.mark.slow
def test_process_pool_with_one_and_two_workers_gives_identical_rows(tmp_path, inline_reference):
    _, ref = inline_reference
    one = run_sweep(_spec(axis=PHYSICS), tmp_path / "one", backend="process", workers=1)
    two = run_sweep(_spec(axis=PHYSICS), tmp_path / "two", backend="process", workers=2)
    assert comparable(one.rows) == comparable(two.rows) == comparable(ref.rows)
    assert _without_wall_time(tmp_path / "one" / "runs.csv") == _without_wall_time(
        tmp_path / "two" / "runs.csv"
    )
    assert (tmp_path / "two" / "settings.csv").read_text() == (
        tmp_path / "one" / "settings.csv"
    ).read_text()
    assert [p.name for p in two.plots] == ["sweep_taught.z_low_mm.png"]


@pytest.mark.slow
def test_interrupted_sweep_rerun_gives_the_uninterrupted_table(tmp_path, inline_reference):
    ref_dir, _ = inline_reference
    out = tmp_path / "cut"
    out.mkdir()
    shutil.copy(ref_dir / "sweep.json", out / "sweep.json")
    first, second = (ref_dir / "runs.jsonl").read_bytes().splitlines(keepends=True)
    (out / "runs.jsonl").write_bytes(first + second[: len(second) // 2])  # torn
    resumed = run_sweep(_spec(axis=PHYSICS), out, backend="inline", plots=False)
    assert (resumed.ran, resumed.skipped) == (1, 1)
    assert _without_wall_time(out / "runs.csv") == _without_wall_time(ref_dir / "runs.csv")
    assert (out / "settings.csv").read_text() == (ref_dir / "settings.csv").read_text()


@pytest.mark.slow
def test_ray_gives_the_rows_of_the_process_pool(tmp_path, inline_reference):
    pytest.importorskip("ray")
    _, ref = inline_reference
    report = run_sweep(_spec(axis=PHYSICS), tmp_path / "ray", backend="ray", workers=2)
    assert comparable(report.rows) == comparable(ref.rows)


@pytest.mark.slow
def test_ctrl_c_keeps_finished_runs_and_exits_130(tmp_path):
    out = tmp_path / "s"
    proc = subprocess.Popen(
        [sys.executable, "-m", "transplanter.cli", "sweep", "paper", "--vary",
         "taught.z_low_mm=30:40:0.5", "--seeds", "1", "--seedlings", "2", "--out", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    # 21 runs: the sweep cannot finish before a loaded machine's poll sees the first one
    runs = out / "runs.jsonl"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (runs.exists() and runs.read_text().count("\n")):
        time.sleep(0.2)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "interrupted after" in err and "rerun the same command" in err
    done = len(runs.read_text().splitlines())
    assert 1 <= done < 21
    assert len((out / "runs.csv").read_text().splitlines()) == 1 + done


# --- nothing finished is lost; one sweep per directory; no write through a link -------------


def _pool_workers(parent):
    """The pids of `parent`'s process-pool workers (spawned: `spawn_main` in the command)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            ppid = int(stat.read_text().rsplit(")", 1)[1].split()[1])
            cmdline = (stat.parent / "cmdline").read_bytes()
        except (OSError, ValueError, IndexError):
            continue
        if ppid == parent and b"spawn_main" in cmdline:
            found.append(int(stat.parent.name))
    return found


def _alive(pid):
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.slow
def test_sigterm_stops_the_workers_and_keeps_finished_runs_exit_143(tmp_path):
    out = tmp_path / "s"
    proc = subprocess.Popen(
        [sys.executable, "-m", "transplanter.cli", "sweep", "paper", "--vary",
         "taught.z_low_mm=30:40:2", "--seeds", "1", "--seedlings", "2", "--workers", "2",
         "--out", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    workers = []
    try:
        runs = out / "runs.jsonl"
        deadline = time.monotonic() + 300
        while proc.poll() is None and not (runs.exists() and runs.read_text().count("\n")):
            assert time.monotonic() < deadline, "no run finished"
            time.sleep(0.1)  # polls for the readiness signal: a finished run's line
        workers = _pool_workers(proc.pid)
        assert workers, "the pool's workers are running"
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
        assert proc.returncode == 143, err
        assert "Traceback" not in err
        assert "interrupted after" in err and "rerun the same command" in err
        assert not [pid for pid in workers if _alive(pid)], "orphaned workers"
        done = len(runs.read_text().splitlines())
        assert 1 <= done < 6
        assert len((out / "runs.csv").read_text().splitlines()) == 1 + done
        assert (out / "settings.csv").exists()
    finally:
        proc.kill()
        for pid in workers:  # today's code leaves them running: do not leak them
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)


def test_a_second_sweep_into_a_busy_directory_touches_nothing(tmp_path, monkeypatch):
    """The first sweep has checked the directory and not yet written its manifest; a second,
    different sweep into the same directory is refused at once and writes nothing; the first
    then runs as if alone."""
    from transplanter.studies import sweep

    out = tmp_path / "s"
    checked, go = threading.Event(), threading.Event()
    real_check = sweep.check_manifest

    def check_then_wait(*args):
        resumed = real_check(*args)
        if threading.current_thread() is not threading.main_thread():
            checked.set()
            assert go.wait(60)
        return resumed

    monkeypatch.setattr(sweep, "check_manifest", check_then_wait)
    first = {}
    thread = threading.Thread(
        target=lambda: first.update(report=run_sweep(_spec(), out, backend="inline"))
    )
    thread.start()
    try:
        assert checked.wait(60)
        listing = sorted(p.name for p in out.iterdir()) if out.exists() else None
        with pytest.raises(SweepRefused, match="another sweep is writing"):
            run_sweep(_spec(seeds=(1, 2)), out, backend="inline")
        assert sorted(p.name for p in out.iterdir()) == listing
    finally:
        go.set()
        thread.join(60)
    assert first["report"].ran == 2
    assert json.loads((out / "sweep.json").read_text())["seeds"] == [1]
    assert [r["seed"] for r in read_runs(out / "runs.jsonl")] == [1, 1]


def test_sweep_files_are_never_written_through_a_planted_link(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("someone else's file\n")
    for name, target in (
        ("runs.jsonl", tmp_path / "created.txt"),  # a dangling link: would create its target
        ("runs.jsonl", victim),
        ("runs.csv", victim),
        ("settings.csv", victim),
        ("sweep.json", victim),
    ):
        out = tmp_path / f"s_{name}_{target.name}"
        out.mkdir()
        (out / name).symlink_to(target)
        with pytest.raises(SweepRefused, match="is a symbolic link"):
            run_sweep(_spec(), out, backend="inline")
        assert [p.name for p in out.iterdir()] == [name]
    # a finished sweep whose runs.jsonl was later replaced by a link (resume would truncate
    # and append to the link's target)
    out = tmp_path / "done"
    run_sweep(_spec(), out, backend="inline")
    (out / "runs.jsonl").rename(tmp_path / "moved.jsonl")
    (out / "runs.jsonl").symlink_to(victim)
    with pytest.raises(SweepRefused, match="is a symbolic link"):
        run_sweep(_spec(), out, backend="inline")
    assert victim.read_text() == "someone else's file\n"
    assert not (tmp_path / "created.txt").exists()


def test_an_out_that_cannot_be_made_is_refused_with_exit_2(tmp_path, capsys):
    """It exited 5 (a result could not be written) although nothing had run."""
    blocker = tmp_path / "file"
    blocker.write_text("")
    args = ["sweep", "paper", "--vary", "taught.z_low_mm=30,32", "--seeds", "1"]
    assert main([*args, "--seedlings", "1", "--out", str(blocker / "sub")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot be made" in err[0]


def test_an_out_in_a_missing_folder_is_refused_as_json_is(tmp_path, capsys, monkeypatch):
    """`sweep --out /missing/x/y` made the whole path, where --json refuses a file in a
    missing folder: sweep, compare, tune and calibrate refuse it in one line, exit 2, before
    anything runs, and create nothing (tune's and calibrate's default --out under results/
    is made as before)."""
    work = tmp_path / "work"  # the current folder: tune's default --storage lives there
    work.mkdir()
    monkeypatch.chdir(work)
    out = tmp_path / "missing" / "x" / "y"
    one = ["--seeds", "1", "--seedlings", "1"]
    fit = ["taught.z_low_mm=30..34", "--trials", "1", *one]
    for argv in (
        ["sweep", "paper", "--vary", "taught.z_low_mm=30,32", *one],
        ["compare", "paper", *one],
        ["tune", "paper", "--param", *fit],
        ["calibrate", "paper", "--observed", "38/40", "--fit", *fit],
    ):
        assert main([*argv, "--out", str(out)]) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert err == [
            f"{argv[0]} refused: --out {out}: {out.parent} does not exist; create it first"
        ]
    assert [p.name for p in tmp_path.iterdir()] == ["work"] and not any(work.iterdir())


@pytest.mark.parametrize(
    ("text", "kind"), [("null", "null"), ("[]", "a list"), ('"x"', "a string"), ("3", "a number")]
)
def test_a_manifest_that_is_not_an_object_is_refused_in_one_line(tmp_path, capsys, text, kind):
    """A sweep.json holding valid JSON that is not an object was an AttributeError."""
    out = tmp_path / "s"
    out.mkdir()
    (out / "sweep.json").write_text(text)
    args = ["sweep", "paper", "--vary", "taught.z_low_mm=61,70", "--seeds", "1"]
    assert main([*args, "--seedlings", "2", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert f"{out / 'sweep.json'} is not a sweep's manifest" in err[0]
    assert f"it holds {kind}" in err[0]
    assert [p.name for p in out.iterdir()] == ["sweep.json"]  # nothing written
    assert (out / "sweep.json").read_text() == text


def test_the_sweep_table_has_the_failures_by_kind_as_columns(tmp_path, capsys):
    # a bridge just over the rims crushes the shoots; the paper's 68 mm leaves them free
    args = ["sweep", "paper", "--vary", "gripper.bridge_clearance_mm=25,68", "--seeds", "1"]
    assert main([*args, "--seedlings", "3", "--out", str(tmp_path / "s"), "--quiet"]) == 0
    lines = capsys.readouterr().out.splitlines()
    head = next(line for line in lines if line.lstrip().startswith("gripper.bridge_clearance"))
    assert head.split()[-2:] == ["errors", "shoot_crushed"]  # only the kinds that occurred
    low = next(line for line in lines if line.split()[0] == "25")
    high = next(line for line in lines if line.split()[0] == "68")
    assert int(low.split()[-1]) >= 1 and high.split()[-1] == "0"
    assert "{" not in "\n".join(lines)


# --- the delta's jobs: the claws' bench as an L9 --------------------------------------------


def test_an_l9_sweep_of_the_bench_prints_and_writes_its_range_analysis(tmp_path, capsys):
    out = tmp_path / "l9"
    status = main(["sweep", "plug_bench", "--vary", "plugs.moisture_pct=65,75,85",
                   "--vary", "plugs.age_d=20,25,30",
                   "--vary", "plug_bench.extraction_accel_m_s2=20,30,40", "--design", "L9",
                   "--seeds", "1", "--seedlings", "1", "--out", str(out), "--quiet"])  # fmt: skip
    text = capsys.readouterr().out
    assert status == 0
    assert text.startswith("9 runs: 9 settings x 1 seeds, 1 seedlings each")
    assert "substrate_retention  leaf_damage_rate  moisture_pct_drawn" in text
    assert "range analysis over 9 settings" in text and "order: " in text
    assert (out / "range_analysis.txt").read_text().strip() in text
    head = (out / "runs.csv").read_text().splitlines()[0].split(",")
    assert head[-4:] == ["substrate_retention", "leaf_damage_rate", "dropped",
                         "moisture_pct_drawn"]  # fmt: skip
    ranges = (out / "range_analysis.csv").read_text().splitlines()
    assert ranges[0].startswith("response,factor,k1,k2,k3,R,rank,best_level,best_value")
    rows = [json.loads(line) for line in (out / "runs.jsonl").read_text().splitlines()]
    assert [r["error"] for r in rows] == [None] * 9
    # one seedling a run: the wet, young plug lifted at 40 m/s^2 (run 7) shears off its pins
    assert [r["successes"] for r in rows] == [1, 1, 1, 1, 1, 1, 0, 1, 1]


def test_a_study_that_photographs_is_refused_before_any_run_without_gl(monkeypatch, tmp_path):
    """Headless without MUJOCO_GL=egl a sweep of the delta's trays graded from pictures is
    refused in the parent, naming what to set, before a worker starts (a worker's second
    failed renderer aborted the pool); graded from the truth it is not asked."""
    from transplanter.scenario.schema import load_scenario
    from transplanter.scene import offscreen
    from transplanter.studies.grid import Axis, SweepRefused, SweepSpec
    from transplanter.studies.sweep import require_pictures, run_sweep

    monkeypatch.setattr(offscreen, "_FAILED", ["no OpenGL context could be made"])
    with pytest.raises(SweepRefused, match=r"MUJOCO_GL=egl .*delta_refill.vision=truth"):
        require_pictures(load_scenario("delta_refill"))
    truth = load_scenario("delta_refill", {"delta_refill.vision": "truth"})
    require_pictures(truth)
    with pytest.raises(SweepRefused, match="photographs the trays"):
        require_pictures(truth, {"delta_refill.vision": ("truth", "pipeline")})
    require_pictures(load_scenario("paper"))  # the five-bar takes no pictures
    spec = SweepSpec("delta_refill", (Axis("delta_refill.pose_judgement", (True, False)),), (1,), 1)
    with pytest.raises(SweepRefused, match="photographs the trays"):
        run_sweep(spec, tmp_path / "out", workers=2)
    assert (tmp_path / "out" / "runs.jsonl").read_text() == ""  # no run; a rerun resumes
