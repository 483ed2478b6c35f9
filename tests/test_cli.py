"""The `transplanter` command line: ik, plan and trial (replay is tested with recording)."""

import json
import os
import re
import signal
import subprocess
import sys

import pytest

from conftest import ROOT, variant
from transplanter.cli import main


def test_ik_prints_angles(capsys):
    assert main(["ik", "0", "200"]) == 0
    out = capsys.readouterr().out
    assert "theta1 = 145.9911 deg" in out
    assert "theta2 = 34.0089 deg" in out
    assert "passive-link (transmission) angle = 96.7263 deg" in out


def test_ik_unreachable_says_why(capsys):
    assert main(["ik", "0", "400"]) == 1
    assert "cannot be reached: outside workspace" in capsys.readouterr().out
    assert main(["ik", "-100", "90"]) == 1  # inside the reach, outside the limits
    assert "cannot be reached" in capsys.readouterr().out


def test_plan_prints_every_line_and_total(capsys):
    assert main(["plan", str(ROOT / "scenarios" / "example.gcode")]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[:2] == ["line", "duration_s"]
    assert out[-1].startswith("total")
    assert len(out) == 1 + 18 + 1  # header, 18 G-code lines, total


def test_plan_error_has_line_number(tmp_path, capsys):
    bad = tmp_path / "bad.gcode"
    bad.write_text("G28\nG90\nG1 X0 Y500 Z50 S100\n")
    assert main(["plan", str(bad)]) == 1
    err = capsys.readouterr().err
    assert f"{bad}:3: error:33" in err
    assert main(["plan", str(tmp_path / "missing.gcode")]) == 1


def test_ik_and_plan_refuse_a_missing_scenario(tmp_path, capsys):
    assert main(["ik", "0", "200", "--scenario", str(tmp_path / "none.toml")]) == 2
    assert "scenario refused" in capsys.readouterr().err
    binary = tmp_path / "bin.gcode"
    binary.write_bytes(bytes(range(256)))
    assert main(["plan", str(binary)]) == 1
    assert "not a text file" in capsys.readouterr().err


def test_trial_refuses_an_unknown_key_before_simulating(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[scenario]\nbase = "paper.toml"\n[taught]\nspeed_high = 3\n')
    assert main(["trial", str(bad), "--quiet"]) == 2
    assert "taught.speed_high: unknown key" in capsys.readouterr().err


def test_trial_refuses_an_unreachable_taught_point_naming_the_key(tmp_path, capsys):
    bad = variant(tmp_path, {"grip_mm = [90.0, 215.0]": "grip_mm = [90.0, 340.0]"})
    assert main(["trial", str(bad), "--quiet"]) == 2
    assert "taught.pickup[4].grip_mm = [90, 340] mm cannot be reached" in capsys.readouterr().err


def test_trial_exit_status_for_a_firmware_fault(tmp_path, capsys):
    path = variant(tmp_path, {"grip_mm = [-45.0, 215.0]": "grip_mm = [-45.0, 330.0]"})
    assert main(["trial", str(path), "--seedlings", "3", "--quiet"]) == 2  # preflight refuses
    capsys.readouterr()
    args = ["trial", str(path), "--seedlings", "3", "--quiet", "--no-preflight"]
    assert main(args) == 4  # the SGF refuses the move itself
    out = capsys.readouterr().out
    assert "firmware fault" in out and "failures: move_rejected    1" in out


def test_trial_refuses_bad_output_paths_before_simulating(tmp_path, capsys):
    base = ["trial", "paper", "--seedlings", "1", "--quiet"]
    assert main([*base, "--json", str(tmp_path)]) == 2
    assert "is a directory" in capsys.readouterr().err
    assert main([*base, "--record", str(tmp_path / "x.txt")]) == 2
    assert "must end in .rrd" in capsys.readouterr().err
    assert main([*base, "--json", str(tmp_path / "missing" / "r.json")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main([*base, "--record", str(tmp_path / "r.rrd"), "--record-rate", "0"]) == 2
    assert main(["trial", str(ROOT / "scenarios"), "--quiet"]) == 2
    assert "is a directory" in capsys.readouterr().err
    assert main(["trial", "paper", "--seedlings", "41", "--quiet"]) == 2
    assert "more than the conveyor holds" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())  # nothing was written


def _cli(args, **kwargs):
    return subprocess.Popen(
        [sys.executable, "-m", "transplanter.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kwargs,
    )


def test_trial_refuses_a_non_finite_record_rate(tmp_path, capsys):
    for rate in ("inf", "nan", "-1"):
        args = ["trial", "paper", "--quiet", "--record", str(tmp_path / "r.rrd")]
        assert main([*args, "--record-rate", rate]) == 2
        assert "--record-rate must be a finite number of Hz > 0" in capsys.readouterr().err


def test_trial_refuses_endless_scenario_inputs(tmp_path, capsys):
    assert main(["trial", "/dev/zero", "--quiet"]) == 2
    assert "/dev/zero is a character device" in capsys.readouterr().err
    fifo = tmp_path / "s.toml"
    os.mkfifo(fifo)
    assert main(["trial", str(fifo), "--quiet"]) == 2  # refused, not a hang
    assert "named pipe" in capsys.readouterr().err


@pytest.mark.slow
def test_a_recording_that_cannot_be_written_loses_no_results(tmp_path):
    """The disk fills while the recording is written (a 200 kB file-size limit on the child
    process): the summary and the JSON are still written, the failure is one line, exit 5."""
    script = (
        "import resource, signal, sys\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, 200_000))\n"
        "from transplanter.cli import main\n"
        "sys.exit(main(sys.argv[1:]))\n"
    )
    rrd, out = tmp_path / "r.rrd", tmp_path / "r.json"
    args = ["trial", "paper", "--seedlings", "1", "--quiet", "--record", str(rrd)]
    run = subprocess.run(
        [sys.executable, "-c", script, *args, "--json", str(out)],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 5, run.stderr
    assert "success rate               100.0 % (1/1)" in run.stdout
    assert json.loads(out.read_text())["successes"] == 1
    assert run.stderr.count("\n") == 1 and "could not be written" in run.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]  # no .rrd, no temp


@pytest.mark.slow
def test_ctrl_c_stops_cleanly_and_never_replaces_a_complete_recording(tmp_path):
    rrd, out = tmp_path / "r.rrd", tmp_path / "r.json"
    rrd.write_text("a complete earlier recording")
    child = _cli_with_progress(
        ["trial", "paper", "--quiet", "--record", str(rrd), "--json", str(out)]
    )
    _wait_for_progress(child)  # the 40-seedling trial (~150 s simulated) runs
    child.send_signal(signal.SIGINT)
    stdout, stderr = child.communicate(timeout=60)
    assert child.returncode == 130, stderr
    assert "Traceback" not in stderr
    done = int(re.search(r"interrupted after (\d+) seedlings", stderr).group(1))
    assert 0 <= done < 40
    result = json.loads(out.read_text())
    assert result["interrupted"] is True
    judged = [s for s in result["per_seedling"] if s["outcome"] != "not_run"]
    assert len(judged) == done and all(s["outcome"] == "success" for s in judged)
    assert rrd.read_text() == "a complete earlier recording"
    assert (tmp_path / "r.partial.rrd").stat().st_size > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json", "r.partial.rrd", "r.rrd"]


def test_numbers_on_the_command_line_are_ascii(capsys):
    for argv in (["ik", "١٠", "200"], ["ik", "0", "２００"], ["trial", "paper", "--seed", "٣"]):
        with pytest.raises(SystemExit) as stop:
            main(argv)
        assert stop.value.code == 2
        assert "ASCII digits 0-9" in capsys.readouterr().err
    assert main(["ik", "0", "2e2"]) == 0  # exponent notation is an ordinary number here


@pytest.mark.slow
def test_trial_seeds_prints_and_writes_the_pooled_rate(tmp_path, capsys):
    """trial --seeds: a line per trial as it finishes, then the rate pooled over the trials
    with its interval, in the summary and in the JSON under `pooled`."""
    path = tmp_path / "pooled.json"
    args = ["trial", "paper", "--seeds", "1-2", "--seedlings", "2", "--json", str(path)]
    assert main(args) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert lines[0].split() == ["seed", "success", "rate", "clustered", "failures"]
    assert lines[1].split() == ["1", "2/2", "100.0", "%", "no", "-"]
    assert lines[2].split() == ["2", "2/2", "100.0", "%", "no", "-"]
    assert "failures by kind" not in out  # nothing failed
    assert "{" not in out and "}" not in out  # no Python dict for people to read
    assert "pooled over 2 trials: 100.0 % (4/4), 95 % CI 51.0-100.0 %" in out
    d = json.loads(path.read_text())
    assert [t["seed"] for t in d["trials"]] == [1, 2]
    assert [t["successes"] for t in d["trials"]] == [2, 2]
    pooled = d["pooled"]
    assert (pooled["successes"], pooled["seedlings"], pooled["trials"]) == (4, 4, 2)
    assert pooled["success_rate"] == 1.0
    assert pooled["ci95"] == pytest.approx([0.5101, 1.0], abs=1e-4)  # Wilson 4/4 at least
    assert d["interrupted"] is False


@pytest.mark.slow
def test_trial_seeds_says_when_a_trials_failures_cluster(tmp_path, capsys):
    # At Z_low 20 mm the jaw tips strike the belt on the first pick: every later pick starts
    # off position, a cascade, not independent failures.
    args = ["trial", "paper", "--seeds", "3", "--seedlings", "3", "--set", "taught.z_low_mm=20"]
    assert main(args) == 0
    out = capsys.readouterr().out
    row = out.splitlines()[1]
    assert row.split()[:5] == ["3", "0/3", "0.0", "%", "yes"]  # the failures cluster
    assert "position_lost" in row and "{" not in out
    table = out.split("failures by kind:\n")[1].split("pooled over")[0].splitlines()
    kinds = table[0].split()[1:]
    assert "position_lost" in kinds
    assert sum(int(n) for n in table[-1].split()[1:]) == 3  # the 'all' row: three failures
    assert "pooled over 1 trial: 0.0 % (0/3)" in out


# -- hmi and trial --eeprom ------------------------------------------------------------------

TEACH_PAPER_KEYS = ROOT / "tests" / "hmi" / "teach_paper.keys"


def _teach_paper(tmp_path, capsys):
    out = tmp_path / "paper.eeprom"
    assert main(["hmi", "paper", "--out", str(out), "--keys-file", str(TEACH_PAPER_KEYS)]) == 0
    return out, capsys.readouterr().out


def test_hmi_keys_file_writes_the_paper_image_and_prints_the_lcd(tmp_path, capsys):
    from transplanter.scenario.assemble import machine_config
    from transplanter.scenario.schema import load_scenario

    out, printed = _teach_paper(tmp_path, capsys)
    assert out.read_bytes() == machine_config(load_scenario("paper")).eeprom.to_bytes()
    assert "|WRITE EEPROM        |" in printed and "|Written CRC " in printed
    assert f"transplanter trial paper --eeprom {out}" in printed


def test_hmi_show_screens_prints_every_screen(tmp_path, capsys):
    out = tmp_path / "x.eeprom"
    assert main(["hmi", "paper", "--out", str(out), "--keys", "1 0", "--show-screens"]) == 1
    captured = capsys.readouterr()
    assert "power-on (homed at t = " in captured.out
    assert "key 1: 1\n+----" in captured.out and "key 2: 0\n+----" in captured.out
    assert "|Pickups M_pp        |" in captured.out
    assert "ended without writing the EEPROM image" in captured.err
    assert not out.exists()


def test_hmi_prints_the_full_reason_of_a_refused_jog(tmp_path, capsys):
    assert main(["hmi", "paper", "--out", str(tmp_path / "x.eeprom"), "--keys", "2 1 4"]) == 1
    out = capsys.readouterr().out
    assert "|NO elbow B 14.98<15 |" in out
    assert "refused: elbow angle at B 14.98 deg outside [15, 165] deg" in out


def test_hmi_refuses_bad_keys_and_options(tmp_path, capsys):
    out = str(tmp_path / "x.eeprom")
    assert main(["hmi", "paper", "--out", out, "--keys", "1 0 5# 6!"]) == 2
    err = capsys.readouterr().err
    assert "--keys: '!' at position 9 is not a key" in err and "0-9 A B C D * #" in err
    keys_file = tmp_path / "k.keys"
    keys_file.write_text("1 0 5#\n; fine\n 6 q\n")
    assert main(["hmi", "paper", "--out", out, "--keys-file", str(keys_file)]) == 2
    assert f"{keys_file}: 'q' at line 3, column 4 is not a key" in capsys.readouterr().err
    assert main(["hmi", "paper", "--out", out, "--keys", "1", "--keys-file", str(keys_file)]) == 2
    assert "not both" in capsys.readouterr().err
    assert main(["hmi", "paper", "--out", str(tmp_path / "x.bin"), "--keys", "1"]) == 2
    assert "must end in .eeprom" in capsys.readouterr().err
    assert main(["hmi", "paper", "--out", out, "--from", str(keys_file), "--keys", "1"]) == 2
    assert "--from refused" in capsys.readouterr().err


def test_hmi_without_keys_needs_a_terminal(tmp_path):
    out = str(tmp_path / "x.eeprom")
    done = subprocess.run(
        [sys.executable, "-m", "transplanter.cli", "hmi", "paper", "--out", out],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2
    assert "no terminal for the interactive keypad" in done.stderr


def test_trial_refuses_a_corrupt_or_missing_eeprom_image(tmp_path, capsys):
    out, _ = _teach_paper(tmp_path, capsys)
    corrupt = tmp_path / "corrupt.eeprom"
    data = bytearray(out.read_bytes())
    data[40] ^= 0x01
    corrupt.write_bytes(bytes(data))
    assert main(["trial", "paper", "--eeprom", str(corrupt)]) == 2
    err = capsys.readouterr().err
    assert "--eeprom refused" in err and "CRC mismatch" in err
    assert main(["trial", "paper", "--eeprom", str(tmp_path / "none.eeprom")]) == 2
    assert "cannot open EEPROM image" in capsys.readouterr().err
    args = ["trial", "paper", "--eeprom", str(out), "--set", "taught.z_low_mm=30"]
    assert main(args) == 2
    assert "both set the taught data" in capsys.readouterr().err


@pytest.mark.slow
def test_trial_from_the_taught_image_gives_the_paper_results(tmp_path, capsys):
    out, _ = _teach_paper(tmp_path, capsys)
    results = {}
    for name, extra in (("paper", []), ("image", ["--eeprom", str(out)])):
        path = tmp_path / f"{name}.json"
        args = ["trial", "paper", "--seedlings", "5", "--quiet", "--json", str(path), *extra]
        assert main(args) == 0
        results[name] = json.loads(path.read_text())
    capsys.readouterr()
    paper, image = results["paper"], results["image"]
    assert image["overrides"]["eeprom"].startswith(f"{out} (M_pp 5, CRC-32 0x")
    assert "eeprom" not in paper["overrides"]
    assert image["per_seedling"] == paper["per_seedling"]
    for key in ("successes", "failures", "cycle_time_s", "sim_time_s", "lost_step_events"):
        assert image[key] == paper[key], key


def test_serve_and_pgf_refuse_bad_options_before_opening_anything(tmp_path, capsys):
    assert main(["serve", "paper", "--inject-errors", "1.5"]) == 2
    assert "--inject-errors is the share of lines" in capsys.readouterr().err
    assert main(["serve", "paper", "--keepalive-s", "-1"]) == 2
    assert "--keepalive-s must be >= 0" in capsys.readouterr().err
    assert main(["serve", "paper", "--set", "taught.z_low_mm=2"]) == 2
    assert "scenario refused" in capsys.readouterr().err
    missing = tmp_path / "ttyUSB9"
    assert main(["serve", "paper", "--port", str(missing)]) == 2
    assert f"cannot open {missing}" in capsys.readouterr().err
    assert main(["pgf", "paper", "--port", str(missing)]) == 2
    assert f"cannot open {missing}" in capsys.readouterr().err


# -- nothing finished is lost; no write over an input or through a derived link ------------

# Runs the command line with a progress callback that says, on stderr, how many seedlings are
# done: the readiness line a test waits for before it sends a signal (never a fixed sleep).
_WITH_PROGRESS = (
    "import sys\n"
    "from transplanter.twin import report\n"
    "def bar(total, enabled):\n"
    "    def update(done, t):\n"
    "        print(f'progress {done}', file=sys.stderr, flush=True)\n"
    "    return None, update\n"
    "report.progress_bar = bar\n"
    "from transplanter.cli import main\n"
    "sys.exit(main(sys.argv[1:]))\n"
)


def _cli_with_progress(args):
    return subprocess.Popen(
        [sys.executable, "-c", _WITH_PROGRESS, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait_for_progress(child, done=1):
    """Read the child's stderr until it says `done` seedlings are finished."""
    seen = []
    for line in child.stderr:
        seen.append(line)
        m = re.fullmatch(r"progress (\d+)\n", line)
        if m and int(m.group(1)) >= done:
            return "".join(seen)
    child.kill()
    raise AssertionError("the trial ended before it was ready: " + "".join(seen))


def test_trial_refuses_to_write_an_output_over_an_input(tmp_path, capsys):
    scenario = variant(tmp_path, {}, "my.toml")
    base = variant(tmp_path, {}, "base.toml")
    child = tmp_path / "child.toml"
    child.write_text('[scenario]\nbase = "base.toml"\n')
    image = tmp_path / "img.eeprom"
    image.write_bytes(b"not read: refused before")
    (tmp_path / "link.json").symlink_to(scenario)
    os.link(scenario, tmp_path / "hard.json")
    before = {p: p.read_bytes() for p in (scenario, base, child, image)}
    quick = ["--seedlings", "1", "--quiet"]
    for argv, named in (
        (["trial", str(scenario), *quick, "--json", str(scenario)], ("--json", "my.toml")),
        (["trial", str(scenario), *quick, "--json", str(tmp_path / "link.json")], ("link.json",)),
        (["trial", str(scenario), *quick, "--json", str(tmp_path / "hard.json")], ("hard.json",)),
        (["trial", str(child), *quick, "--json", str(base)], ("--json", "base.toml")),
        (["trial", "paper", *quick, "--eeprom", str(image), "--json", str(image)], ("img",)),
    ):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "an output never replaces an input" in err, err
        assert all(n in err for n in named), err
    assert {p: p.read_bytes() for p in before} == before
    assert main(["export", str(scenario), str(scenario)]) == 2  # .xml checked first
    capsys.readouterr()
    xml = tmp_path / "scene.xml"
    xml.write_text(scenario.read_text())
    assert main(["export", str(xml), str(xml)]) == 2
    assert "an output never replaces an input" in capsys.readouterr().err


def test_two_outputs_naming_one_file_are_refused(tmp_path, capsys):
    rrd = tmp_path / "r.rrd"
    (tmp_path / "r.json").symlink_to(rrd)
    quick = ["trial", "paper", "--seedlings", "1", "--quiet"]
    for json_path in (rrd, tmp_path / "r.json"):
        assert main([*quick, "--json", str(json_path), "--record", str(rrd)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "--json" in err and "--record" in err
        assert "name the same file" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]  # the link only


def _signal_when(monkeypatch, where, name, signum=signal.SIGINT):
    """Patch `where.name` to send this process `signum` and then do its work: a Ctrl-C at
    exactly that point, driven by the code, not by a clock."""
    original = getattr(where, name)

    def interrupted(*args, **kwargs):
        os.kill(os.getpid(), signum)
        return original(*args, **kwargs)

    monkeypatch.setattr(where, name, interrupted)


@pytest.mark.slow
@pytest.mark.parametrize("point", ["judge", "recording", "json"])
def test_ctrl_c_after_the_last_seedling_loses_nothing(tmp_path, capsys, monkeypatch, point):
    """Ctrl-C while the judge gives its last verdicts, the recording closes or the JSON is
    written: the finished trial is printed and written whole, the recording at its own name,
    no temporary file left; the exit status says it was interrupted."""
    from transplanter import fileio
    from transplanter.twin.judge import Judge
    from transplanter.viewing.recording import TrialRecorder

    where, name = {
        "judge": (Judge, "finish"),
        "recording": (TrialRecorder, "close"),
        "json": (fileio, "write_json_atomic"),
    }[point]
    _signal_when(monkeypatch, where, name)
    rrd, out = tmp_path / "r.rrd", tmp_path / "r.json"
    args = ["trial", "paper", "--seedlings", "1", "--quiet", "--record", str(rrd)]
    assert main([*args, "--json", str(out)]) == 130
    captured = capsys.readouterr()
    assert "success rate               100.0 % (1/1)" in captured.out
    assert f"recording written to {rrd}" in captured.out
    assert "the results are complete" in captured.err
    result = json.loads(out.read_text())
    assert result["successes"] == 1 and result["interrupted"] is False
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json", "r.rrd"]


@pytest.mark.slow
def test_sigterm_stops_a_trial_as_ctrl_c_does_with_exit_143(tmp_path):
    rrd, out = tmp_path / "r.rrd", tmp_path / "r.json"
    child = _cli_with_progress(
        ["trial", "paper", "--quiet", "--record", str(rrd), "--json", str(out)]
    )
    _wait_for_progress(child, done=2)  # the first seedling judged (the second released)
    child.send_signal(signal.SIGTERM)
    stdout, stderr = child.communicate(timeout=120)
    assert child.returncode == 143, stderr
    assert "Traceback" not in stderr
    done = int(re.search(r"interrupted after (\d+) seedlings", stderr).group(1))
    assert 1 <= done < 40
    result = json.loads(out.read_text())
    assert result["interrupted"] is True
    assert sum(s["outcome"] != "not_run" for s in result["per_seedling"]) == done
    assert (tmp_path / "r.partial.rrd").stat().st_size > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json", "r.partial.rrd"]


@pytest.mark.slow
def test_ctrl_c_never_writes_the_partial_recording_through_a_planted_link(
    tmp_path, capsys, monkeypatch
):
    """NAME.partial.rrd is a name the program derives: a link planted there is replaced by
    the partial recording itself, its target left as it was."""
    from transplanter.twin import report

    victim = tmp_path / "victim.txt"
    victim.write_text("someone else's file")
    (tmp_path / "r.partial.rrd").symlink_to(victim)
    (tmp_path / "gone.partial.rrd").symlink_to(tmp_path / "created.txt")

    def bar(total, enabled):
        def update(done, t):
            if t > 2.0:
                os.kill(os.getpid(), signal.SIGINT)

        return None, update

    monkeypatch.setattr(report, "progress_bar", bar)
    for name in ("r", "gone"):
        args = ["trial", "paper", "--quiet", "--record", str(tmp_path / f"{name}.rrd")]
        assert main(args) == 130
    capsys.readouterr()
    assert victim.read_text() == "someone else's file"
    assert not (tmp_path / "created.txt").exists()
    for name in ("r", "gone"):
        partial = tmp_path / f"{name}.partial.rrd"
        assert not partial.is_symlink() and partial.stat().st_size > 0


def test_trial_seeds_assembles_each_seed_when_its_turn_comes(monkeypatch, capsys):
    """--seeds 0-9999 assembled 10,000 configurations before its first line."""
    from transplanter.cli import trials
    from transplanter.scenario import assemble as assembly

    made = []
    real = assembly.assemble

    def counting(*args, **kwargs):
        made.append(1)
        return real(*args, **kwargs)

    def stop(config, *args, **kwargs):
        raise KeyboardInterrupt  # the user stops during the first trial

    monkeypatch.setattr(assembly, "assemble", counting)
    monkeypatch.setattr(trials, "_run", stop)
    assert main(["trial", "paper", "--seeds", "0-9999", "--seedlings", "2", "--quiet"]) == 130
    assert len(made) == 1
    capsys.readouterr()


def test_every_command_refuses_a_deeply_nested_scenario_or_a_nul_in_base_in_one_line(
    tmp_path, capsys
):
    """5,000 or 100,000 nested '[' were a RecursionError in trial and export (the check that
    no output replaces an input read the file again without the loader's guard), a NUL byte
    in `base` a ValueError traceback in trial, ik and export."""
    files = []
    for depth in (5000, 100_000):
        deep = tmp_path / f"deep{depth}.toml"
        deep.write_text('[scenario]\nbase = "paper"\n[pots]\nmass_g = ' + "[" * depth + "]" * depth)
        files.append((deep, "nested too deeply for a scenario"))
    nul = tmp_path / "nul.toml"
    nul.write_text('[scenario]\nbase = "pa\\u0000per"\n')
    files.append((nul, "holds a NUL byte"))
    child = tmp_path / "child.toml"  # the deep file as another scenario's base
    child.write_text('[scenario]\nbase = "deep5000.toml"\n')
    files.append((child, "nested too deeply for a scenario"))
    out = tmp_path / "out"
    out.mkdir()
    for path, why in files:
        for argv in (
            ["trial", str(path), "--quiet", "--json", str(out / "r.json")],
            ["export", str(path), str(out / "scene.xml")],
            ["ik", "0", "0", "-800", "--scenario", str(path)],
        ):
            assert main(argv) == 2, argv
            err = capsys.readouterr().err
            assert err.count("\n") == 1 and why in err, (argv, err)
    assert not list(out.iterdir())


def test_a_mistyped_name_is_refused_naming_the_nearest_and_whole_bounds(capsys):
    """`trial papr`, a mistyped key or section named no near one; --seed -1 printed the
    bound as 9.22337e+18."""
    quick = ["--seedlings", "1", "--quiet"]
    for argv, hint in (
        (["trial", "papr", *quick], "no packaged scenario of that name; did you mean paper?"),
        (["trial", "paper", "--set", "taught.z_lwo_mm=30", *quick],
         "taught.z_lwo_mm: unknown key; did you mean taught.z_low_mm?"),
        (["trial", "paper", "--set", "taugth.z_low_mm=30", *quick],
         "unknown section [taugth]; did you mean [taught]?"),
        (["trial", "paper", "--seed", "-1", *quick],
         "scenario.seed: -1 is outside the allowed range [0, 9223372036854775807]."),
    ):  # fmt: skip
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and hint in err, err


def test_trial_record_on_a_full_disk_still_prints_and_writes_the_results(
    tmp_path, capsys, monkeypatch
):
    """A disk full when the recording started was a RuntimeError traceback from rerun's
    save, no summary, no JSON, and a .rrd.*.tmp file left; now the trial runs without a
    recording, the JSON holds the recording's error, one line says so, exit 5."""
    import rerun as rr

    def full_disk(self, path, *args, **kwargs):  # what rerun raises when it cannot write
        raise RuntimeError("Failed to encode LogMsg: Failed to write: No space left on device")

    monkeypatch.setattr(rr.RecordingStream, "save", full_disk)
    rrd, out = tmp_path / "r.rrd", tmp_path / "r.json"
    args = ["trial", "paper", "--seedlings", "1", "--quiet", "--record", str(rrd)]
    assert main([*args, "--json", str(out)]) == 5
    captured = capsys.readouterr()
    assert "success rate               100.0 % (1/1)" in captured.out
    assert f"results written to {out}" in captured.out
    assert captured.err.count("\n") == 1 and "--record: " in captured.err
    assert "No space left on device" in captured.err
    result = json.loads(out.read_text())
    assert result["successes"] == 1 and "No space left on device" in result["recording_error"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]  # no recording, no temp


@pytest.mark.parametrize("point", ["scenario", "twin"])
def test_a_stop_while_the_trial_is_set_up_writes_the_json_interrupted(
    tmp_path, capsys, monkeypatch, point
):
    """SIGTERM while the trial was still being set up (its scenario assembled, its twin
    built: before the loop) exited 143 without --json, though `trial --help` promises the
    JSON says interrupted. Now the trial stops as its loop starts: nothing judged."""
    from transplanter.scenario import assemble as assembly
    from transplanter.twin.sim import Twin

    where, name = {"scenario": (assembly, "assemble"), "twin": (Twin, "__post_init__")}[point]
    original, sent = getattr(where, name), []

    def stopped(*args, **kwargs):  # SIGTERM once, at exactly this point
        if not sent:
            sent.append(name)
            os.kill(os.getpid(), signal.SIGTERM)
        return original(*args, **kwargs)

    monkeypatch.setattr(where, name, stopped)
    out = tmp_path / "r.json"
    args = ["trial", "paper", "--set", "conveyor.rows=400", "--quiet", "--json", str(out)]
    assert main(args) == 143
    assert sent == [name]
    captured = capsys.readouterr()
    assert "interrupted after 0 seedlings" in captured.err and "Traceback" not in captured.err
    result = json.loads(out.read_text())
    assert result["interrupted"] is True and result["seedlings"] == 40
    assert {s["outcome"] for s in result["per_seedling"]} == {"not_run"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]


def test_trial_records_a_windowed_conveyor_with_a_body_per_pot(tmp_path, capsys):
    """With more rows than live ones (conveyor.rows = 20, live_rows = 12) the recording was
    given the drawn model (a body per pot) and the physics' data: an IndexError traceback at
    its first frame, and a .rrd.*.tmp file left. Each pot is recorded where the window puts
    it (Scene.render_data)."""
    from transplanter.viewing.playback import read_summary

    rrd = tmp_path / "r.rrd"
    args = ["trial", "paper", "--set", "conveyor.rows=20", "--seedlings", "1", "--quiet"]
    assert main([*args, "--record", str(rrd)]) == 0
    assert "recording written to" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.rrd"]
    rows = read_summary(rrd)["rows_on_sim_time"]
    pots = {e: n for e, n in rows.items() if re.fullmatch(r"world/bodies/pot_\d+_\d", e)}
    assert len(pots) == 20 * 5  # every pot of the 20 rows, not only the 12 live ones
    assert set(pots.values()) == {rows["world/bodies/conveyor"]}  # a pose every frame


@pytest.mark.parametrize(
    "argv",
    [
        ["trial", "paper", "--set", "taught.bogus_mm=1"],  # no such key
        ["trial", "papr"],  # no such scenario
        ["trial", "delta_pots", "--set", "taught.z_low_mm=20"],  # a key its kinds do not read
        ["trial", "paper", "--set", "taught.z_low_mm=abc"],  # not a number
    ],
)
def test_a_refusal_comes_before_mujoco_is_imported(argv):
    """A bad key or scenario is refused from the scenario's text and the kinds' declarations
    alone: the process never imports MuJoCo or builds a scene, so the answer comes in a
    fraction of a second (about 0.3 s here, the interpreter's start included)."""
    code = (
        "import sys\nfrom transplanter import cli\nstatus = cli.main(sys.argv[1:])\n"
        "print('status', status, 'mujoco' in sys.modules)\n"
    )
    run = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True,
                         cwd=ROOT, timeout=120)  # fmt: skip
    assert run.stdout.split() == ["status", "2", "False"], run.stdout + run.stderr
    assert "refused" in run.stderr
