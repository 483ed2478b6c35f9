import math

import numpy as np
import pytest

from transplanter.machine import steppers
from transplanter.machine.steppers import StepperDrive


def test_arm_drive_has_9600_steps_per_arm_revolution():
    drive = steppers.arm_drive("arm1")
    assert not drive.linear
    assert drive.steps_per_unit * 2 * math.pi == pytest.approx(9600, rel=1e-15)
    assert drive.to_steps(2 * math.pi) == 9600
    assert drive.to_steps(-math.pi) == -4800
    assert drive.to_steps(np.pi / 2) == 2400
    assert drive.unit_per_step == pytest.approx(2 * math.pi / 9600, rel=1e-15)
    # motor turns 3 times per arm turn
    assert drive.motor_angle(2 * math.pi) == pytest.approx(6 * math.pi)


def test_z_drive_has_400_steps_per_mm():
    drive = steppers.z_drive()
    assert drive.linear
    assert drive.steps_per_unit == 400_000.0
    assert drive.to_steps(0.001) == 400
    assert drive.to_steps([0.1, -0.0125]).tolist() == [40_000, -5_000]
    assert drive.to_position(np.int64(400)) == pytest.approx(0.001, rel=1e-15)
    # one motor revolution per 8 mm
    assert drive.motor_angle(0.008) == pytest.approx(2 * math.pi)


def test_round_trip_is_within_half_a_step_and_exact_on_steps():
    rng = np.random.default_rng(0)
    for drive in steppers.default_drives():
        position = rng.uniform(-3, 3, 10000) * (0.05 if drive.linear else 1.0)
        steps = drive.to_steps(position)
        assert steps.dtype == np.int64
        back = drive.to_position(steps)
        assert np.abs(back - position).max() <= 0.5 * drive.unit_per_step * (1 + 1e-9)
        np.testing.assert_array_equal(drive.to_steps(back), steps)


def test_validation():
    with pytest.raises(ValueError, match="microsteps"):
        StepperDrive("a", microsteps=0)
    with pytest.raises(ValueError, match="ratio"):
        StepperDrive("a", ratio=-3.0)
    with pytest.raises(ValueError, match="set ratio=1.0"):
        StepperDrive("z", lead_m=0.008)
    with pytest.raises(ValueError, match="lead_m"):
        StepperDrive("z", ratio=1.0, lead_m=0.0)
    with pytest.raises(ValueError, match="max_step_rate_hz"):
        StepperDrive("a", max_step_rate_hz=float("inf"))
    with pytest.raises(ValueError, match="finite"):
        steppers.arm_drive("a").to_steps([0.0, float("nan")])
    with pytest.raises(ValueError, match="integers"):
        steppers.arm_drive("a").to_position([1.5])


def _slow_steps_at(times, step_times, step_dirs, start):
    out = []
    for t in times:
        count = start
        for te, d in zip(step_times, step_dirs, strict=True):
            if t >= te:
                count += int(d)
        out.append(count)
    return np.array(out, dtype=np.int64)


def test_steps_at_matches_reference_loop():
    rng = np.random.default_rng(1)
    for trial in range(20):
        n = int(rng.integers(0, 60))
        step_times = np.sort(rng.uniform(0.0, 1.0, n))
        if n > 4:
            step_times[3] = step_times[2]  # simultaneous events
        step_dirs = rng.choice(np.array([-1, 1], dtype=np.int8), n)
        start = int(rng.integers(-1000, 1000))
        times = np.concatenate([rng.uniform(-0.5, 1.5, 200), step_times, [-1.0, 2.0]])
        expected = _slow_steps_at(times, step_times, step_dirs, start)
        got = steppers.steps_at(times, step_times, step_dirs, start)
        np.testing.assert_array_equal(got, expected, err_msg=f"trial {trial}")


def test_steps_at_clamps_outside_the_move():
    step_times = np.array([0.1, 0.2, 0.3])
    step_dirs = np.array([1, 1, -1], dtype=np.int8)
    got = steppers.steps_at([-5.0, 0.0, 0.1, 0.25, 0.3, 99.0], step_times, step_dirs, 10)
    assert got.tolist() == [10, 10, 11, 12, 11, 11]


def test_steps_at_rejects_bad_events():
    with pytest.raises(ValueError, match="sorted"):
        steppers.steps_at([0.0], [0.2, 0.1], [1, 1], 0)
    with pytest.raises(ValueError, match=r"\+1 and -1"):
        steppers.steps_at([0.0], [0.1, 0.2], [1, 2], 0)
    with pytest.raises(ValueError, match="equal length"):
        steppers.steps_at([0.0], [0.1, 0.2], [1], 0)


def test_step_count_table_is_what_both_step_counters_look_up():
    counts = steppers.step_counts(np.array([1, 1, -1], dtype=np.int8), 10)
    assert counts.dtype == np.int64 and counts.tolist() == [10, 11, 12, 11]
    times = [-1.0, 0.1, 0.15, 0.2, 0.3, 5.0]
    got = steppers.count_at(times, [0.1, 0.2, 0.3], counts)
    assert got.tolist() == [10, 11, 11, 12, 11, 11]
    assert steppers.step_counts([], -7).tolist() == [-7]
    # int8 directions do not wrap: 300 steps up from a large start
    counts = steppers.step_counts(np.ones(300, dtype=np.int8), 2**40)
    assert counts[-1] == 2**40 + 300
