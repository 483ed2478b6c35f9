"""The serial arm's servo outputs (transplanter.machine.servo_drives): the board's 50 Hz PWM
timer on the SGF's counts and the gripper's M280 angle, and the four hobby servos stepped
with the physics."""

from __future__ import annotations

import math

import numpy as np
import pytest

from transplanter.machine.kinematics.serial4 import Serial4Kinematics
from transplanter.machine.servo import MG996R, SG90, ServoMount
from transplanter.machine.servo_drives import ServoBank, ServoOutputs, frame_steps

DEG = math.radians(1.0)


def arm_outputs(gripper_deg=48.0):
    kin = Serial4Kinematics()
    q0 = np.array(kin.park_rad)
    per_count = [a.drive.unit_per_step for a in kin.axes]
    return kin, ServoOutputs(kin.mounts, ServoMount(SG90, 0.0), q0, per_count, gripper_deg)


def test_the_physics_step_must_divide_the_20_ms_frame():
    assert frame_steps(0.001) == 20
    assert frame_steps(0.0005) == 40
    with pytest.raises(ValueError, match="physics.timestep_ms must divide"):
        frame_steps(0.0003)


def test_a_frame_carries_the_counts_as_pulse_widths_and_the_gripper_angle():
    kin, out = arm_outputs()
    park = out.frame([0, 0, 0])
    np.testing.assert_array_equal(park[:3], kin.pulse_us(np.array(kin.park_rad)))
    assert park[3] == 500 + round(48.0 / 180.0 * 2000)  # 1033 us
    # one count is one microsecond of pulse width (0.09 deg)
    moved = out.frame([0, 100, -250])
    np.testing.assert_array_equal(moved[:3] - park[:3], [0, 100, -250])
    out.set_gripper(22.5)
    assert out.frame([0, 0, 0])[3] == 750
    out.set_gripper(300.0)  # past the servo's travel: the timer's widest pulse
    assert out.frame([0, 0, 0])[3] == 2500


def test_the_servos_slew_at_their_rated_speed_and_rest_within_dead_band_and_play():
    kin, out = arm_outputs()
    q0 = np.array(kin.park_rad)
    bank = ServoBank([*kin.mounts, ServoMount(SG90, 0.0)], [*q0, 48 * DEG])
    target = q0 + np.radians([30.0, -20.0, 20.0])
    counts = np.rint((target - q0) / np.array([a.drive.unit_per_step for a in kin.axes]))
    dt = 0.001
    trace = []
    for k in range(500):
        if k % 20 == 0:
            bank.command(out.frame(counts.astype(np.int64)))
        trace.append(bank.step(dt, [0.0, -0.2, 0.1, 0.0]))
    trace = np.array(trace)
    # the SG90 base turns 30 deg at 60 deg / 0.1 s: in 0.05 s (plus the first frame's wait)
    first = np.argmax(np.abs(trace[:, 0] - q0[0]) >= 29.0 * DEG)
    assert 0.045 <= first * dt <= 0.075
    # the MG996R shoulder under a load against it slews slower than unloaded
    slow = MG996R.speed_rad_s * (1 - 0.2 / MG996R.stall_torque_nm)
    t20 = np.argmax(np.abs(trace[:, 1] - q0[1]) >= 19.0 * DEG) * dt
    assert t20 == pytest.approx(19.0 * DEG / slow + 0.0, abs=0.025)
    # at rest: the links sit half the play from the shafts on the loads' sides
    shafts = bank.shafts()
    assert trace[-1, 1] == pytest.approx(shafts[1] - 0.25 * DEG)  # load pushes it down
    assert trace[-1, 2] == pytest.approx(shafts[2] + 0.25 * DEG)  # load pushes it up
    # and the shafts at the commanded angles to within half a microsecond of pulse width
    half_us = 0.5 * math.pi / 2000
    np.testing.assert_allclose(shafts[:3], q0 + counts * 2 * math.pi / 4000, atol=half_us)
