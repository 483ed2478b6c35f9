"""G-code program planning through the SGF (the engine of `transplanter plan`)."""

from pathlib import Path

import numpy as np
import pytest

from transplanter.machine.planner import PlanError, plan_program
from transplanter.scenario.assemble import machine_config
from transplanter.scenario.schema import load_scenario

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def machine():
    return machine_config(load_scenario(ROOT / "scenarios" / "paper.toml"))


def test_example_program_durations_and_steps(machine):
    text = (ROOT / "scenarios" / "example.gcode").read_text().splitlines()
    rows = plan_program(machine, text)
    assert [r.line_no for r in rows][:3] == [3, 4, 5]  # comment lines 1-2 skipped
    by_text = {r.text.split(";")[0].strip(): r for r in rows}
    grip = by_text["G1 X0 Y215 Z34 S60"]
    # 35 mm at 60 mm/s with 1.5 m/s^2 ramps: 35/60 + 60/1500 s
    assert grip.duration_s == pytest.approx(35 / 60 + 0.060 / 1.5, abs=0.01)
    assert grip.steps[2] == 0 and grip.steps[0] == -grip.steps[1]  # symmetric, no Z
    lift = by_text["G1 X0 Y215 Z60 S60"]
    assert list(lift.steps) == [0, 0, 26 * 400]  # 26 mm at 400 steps/mm
    dwell = by_text["G4 P300"]
    assert dwell.duration_s == pytest.approx(0.3) and not dwell.steps.any()
    # the moves after homing bring the motors back to the same place: net zero for the
    # closed cycle approach -> grip -> lift -> retract (X/Y back at the approach point)
    retract = by_text["G1 X0 Y180 Z60 S150"]
    assert retract.steps[0] == -grip.steps[0]


def test_first_error_names_its_line(machine):
    program = ["G28", "G90", "G1 X0 Y200 Z50 S100", "G1 X0 Y400 Z50", "G1 X0 Y200 Z60"]
    with pytest.raises(PlanError) as err:
        plan_program(machine, program)
    assert err.value.line_no == 4
    assert str(err.value).startswith("error:33 target position not reachable")


def test_malformed_line_and_unhomed_move(machine):
    with pytest.raises(PlanError) as err:
        plan_program(machine, ["G28", "G1 X1..2"])
    assert err.value.line_no == 2 and str(err.value).startswith("error:2")
    with pytest.raises(PlanError, match="home first"):
        plan_program(machine, ["G1 X0 Y200 Z50"])


def test_homing_ends_at_the_switches(machine):
    rows = plan_program(machine, ["G28", "M114"])
    assert rows[0].duration_s > 0
    report = rows[1].replies[0]
    # switches 1-3 at theta1 = 200 deg, theta2 = -20 deg, Z = 160 mm, then the pull-off
    # (96 microsteps = 3.6 deg at the arm, 400 = 1 mm on Z) as grbl does
    assert report == "X:0.000 Y:78.988 Z:159.000 A:5237 B:-437 C:63600"
    assert np.array_equal(rows[1].steps, [0, 0, 0])


def test_program_text_splits_at_newlines_only(machine):
    # U+2028 and form feed do not end a line (str.splitlines would split at both)
    text = "G28\r\nG90\nG1 X0 Y200 Z50\fS100\nG1 X0 Y210 Z50\u2028G1 X0 Y220\n"
    with pytest.raises(PlanError) as err:
        plan_program(machine, text)
    assert err.value.line_no == 4
    assert str(err.value).startswith("error:1 non-ASCII character U+2028 (LINE SEPARATOR)")
    rows = plan_program(machine, "G28\nG90\n\nG1 X0 Y200 Z50\fS100\n")
    assert [r.line_no for r in rows] == [1, 2, 4]


@pytest.mark.parametrize("blank", ["\u00a0", "\u3000", "\u2028"])
def test_unicode_spaces_around_a_line_are_refused_not_stripped(machine, blank):
    with pytest.raises(PlanError) as err:
        plan_program(machine, ["G28", f"G90{blank}"])
    assert err.value.line_no == 2 and str(err.value).startswith("error:1 non-ASCII")


def test_huge_target_is_refused_at_once_under_a_memory_cap(tmp_path):
    """Issue row 4: G1 X100000000 built a 10^12-point Bresenham line (7.45 GiB) before any
    check. Under a 1.5 GiB address-space cap it must answer error:33 within seconds."""
    import subprocess
    import sys
    import textwrap

    script = textwrap.dedent(
        f"""
        import resource, time
        from pathlib import Path
        from transplanter.scenario.assemble import machine_config
        from transplanter.machine.planner import PlanError, plan_program
        from transplanter.scenario.schema import load_scenario
        machine = machine_config(load_scenario(Path({str(ROOT)!r}) / "scenarios" / "paper.toml"))
        cap = 1536 * 2**20
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
        for target in ("X100000000 Y140 Z60", "X0 Y" + "9" * 70 + " Z60"):
            t0 = time.perf_counter()
            try:
                plan_program(machine, ["G28", "G1 X0 Y180 Z60", "G1 " + target])
            except PlanError as error:
                print(error.line_no, round(time.perf_counter() - t0, 3), error)
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr[-2000:]
    out = done.stdout.splitlines()
    assert len(out) == 2, done.stdout
    for line in out:
        line_no, seconds, message = line.split(" ", 2)
        assert line_no == "3" and message.startswith("error:33 ")
        assert float(seconds) < 10.0  # homing included
        assert len(message) < 400 and "9" * 20 not in message  # no 70-digit numbers


def test_planner_keeps_constant_history_per_move(machine, monkeypatch):
    """Issue row 10: the SGF's pulses_at history of earlier moves was kept for the whole
    program (about 6 KB a move, quadratic time). The planner drops what it cannot query."""
    import transplanter.machine.planner as planner

    made = []

    class Recording(planner.SGF):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            made.append(self)

    monkeypatch.setattr(planner, "SGF", Recording)
    program = ["G28", "G1 X0 Y180 Z60 S100"]
    program += [f"G1 X{(i % 20) - 10} Y{180 + (i % 7)} Z60" for i in range(300)]
    rows = plan_program(machine, program)
    assert len(rows) == 302
    (sgf,) = made
    assert len(sgf._segments) <= 2


def test_forget_before_keeps_later_pulses(machine):
    from transplanter.machine.sgf import SGF

    rows = plan_program(machine, ["G28", "G1 X0 Y180 Z60 S100", "G1 X20 Y190 Z70"])
    assert len(rows) == 3
    sgf = SGF(machine.sgf)
    sgf.homed = True
    sgf._logical = machine.sgf.homed_steps
    sgf._position = machine.sgf.kinematics.point_of_steps(sgf._logical)
    sgf.receive("G1 X0 Y180 Z60", 0.0)
    sgf.receive("G1 X20 Y190 Z70", 0.0)
    times = np.linspace(0.0, 3.0, 301)
    while sgf.busy:
        t = sgf.next_event_time()
        sgf.poll(t)
    before = sgf.pulses_at(times)
    t_mid = float(sgf._segment_starts[-1]) + 0.01
    assert sgf.forget_before(t_mid) == 1
    later = times >= t_mid
    assert np.array_equal(sgf.pulses_at(times[later]), before[later])


def test_relative_steps_reach_the_z_limit_and_the_next_is_refused_with_its_digits(machine):
    """154 relative 1 mm steps down from the homed Z (159 mm) end on the 5 mm limit, a hair
    below it in floating point: within half a microstep the target is on the limit and runs;
    the 155th is refused, showing the value that lies outside (no 'Z 5.000 outside [5.000')."""
    rows = plan_program(machine, "G28\nG91\n" + "G1 Z-1 S20\n" * 154)
    assert len(rows) == 156
    with pytest.raises(PlanError) as info:
        plan_program(machine, "G28\nG91\n" + "G1 Z-1 S20\n" * 155)
    assert info.value.line_no == 157
    assert "error:33 Z 4.000 mm outside [5, 160] mm" in str(info.value)
    with pytest.raises(PlanError) as info:
        plan_program(machine, "G28\nG90\nG1 X0 Y200 Z4.998 S20\n")
    assert "Z 4.998 mm outside [5, 160] mm" in str(info.value)


@pytest.mark.parametrize(
    ("line", "shown"),
    [("G4 P1000000000000", "3600000 ms"), ("G1 X0 Y200 Z60 F0.0000001", "3600 s")],
)
def test_an_endless_dwell_or_move_is_refused_not_timed_out(machine, line, shown):
    """The firmware refuses these itself (error 63): `plan` no longer needs its hour of
    machine time to give up on them, and `serve` answers them at once."""
    with pytest.raises(PlanError) as err:
        plan_program(machine, ["G28", line])
    assert err.value.line_no == 2
    assert str(err.value).startswith("error:63 ") and shown in str(err.value)
