"""Hobby PWM servos (transplanter.machine.servo) with their datasheet numbers: pulse widths per
angle at 50 Hz, the rated speed, the deadband, the gear backlash and the stall torque."""

from __future__ import annotations

import math

import numpy as np
import pytest

from transplanter.machine.servo import (
    FRAME_S,
    MG996R,
    SG90,
    HobbyServo,
    ServoMount,
    pulse_frames,
    servo_class,
)

DEG = math.radians(1.0)
DT = 0.001


def test_pulse_width_per_angle_in_whole_microseconds():
    us = SG90.pulse_us(np.radians([0, 90, 180, 45.04, 200, -5]))
    np.testing.assert_array_equal(us, [500, 1500, 2500, 1000, 2500, 500])  # clipped at the ends
    assert SG90.pulse_width(math.pi / 2) == pytest.approx(1500e-6, abs=1e-15)
    assert SG90.horn_angle(1500e-6) == pytest.approx(math.pi / 2)
    assert SG90.deadband_rad == pytest.approx(0.9 * DEG)  # 10 us of 2000 us per 180 deg
    assert MG996R.deadband_rad == pytest.approx(0.45 * DEG)
    assert SG90.counts_per_rev == 4000
    assert servo_class("mg996r") is MG996R
    with pytest.raises(ValueError, match="known: sg90, mg996r"):
        servo_class("ds3218")


def test_the_firmware_sends_one_pulse_per_20_ms_frame_holding_the_latest_command():
    mount = ServoMount(SG90, zero_rad=-math.pi / 2)  # joint -90..90 deg
    assert mount.window == pytest.approx((-math.pi / 2, math.pi / 2))
    # commands at 0, 30 and 45 ms: frames start at 0, 20, 40, 60, 80 ms
    frames = pulse_frames(mount, [0.0, 0.030, 0.045], np.radians([0, 9, 18]), 0.1)
    np.testing.assert_array_equal(frames, [1500, 1500, 1600, 1700, 1700])
    assert FRAME_S == 0.020


def test_the_rated_speed_limits_the_slew():
    """SG90: 60 deg in 0.1 s; MG996R: 60 deg in 0.17 s (4.8 V)."""
    for servo, t60 in ((SG90, 0.10), (MG996R, 0.17)):
        s = HobbyServo(servo, horn_rad=30 * DEG)
        angles = []  # the shaft (the link trails it by the backlash)
        for _frame in range(15):  # 0.3 s of frames
            s.command(servo.pulse_width(90 * DEG))
            for _ in range(round(FRAME_S / DT)):
                s.step(DT)
                angles.append(s.shaft_rad)
        angles = np.array(angles)
        t = (np.arange(angles.size) + 1) * DT
        # half-way (30 deg of 60) at half the rated time, there at the rated time
        assert np.interp(t60 / 2, t, angles) == pytest.approx(60 * DEG, abs=0.2 * DEG)
        arrived = t[np.argmax(np.abs(angles - 90 * DEG) < 1e-9)]
        assert arrived == pytest.approx(t60, abs=DT)
        assert np.all(np.diff(angles) <= servo.speed_rad_s * DT + 1e-12)


def test_the_deadband_ignores_small_corrections():
    """SG90: 10 us of dead band = 0.9 deg; a change of 4 us (0.36 deg) from where the servo
    rests does nothing, one of 6 us (0.54 deg) moves it (half the band each side)."""
    for change_us, moves in ((4, False), (6, True)):
        s = HobbyServo(SG90, horn_rad=math.pi / 2)
        s.run([(1500 + change_us) * 1e-6] * 5, DT)
        expected = math.pi / 2 + (change_us * 0.09 * DEG if moves else 0.0)
        assert s.shaft_rad == pytest.approx(expected, abs=1e-12)
    # the resting error can therefore be up to half the band: 0.45 deg for an SG90
    assert 0.5 * SG90.deadband_rad == pytest.approx(0.45 * DEG)


def test_backlash_leaves_the_link_on_the_side_it_was_pushed_from():
    """SG90: 1 deg of play (an estimate). Approached from below, the link trails the shaft
    by half the play; from above, it leads by half; reversing moves the shaft through the
    whole play before the link follows."""
    pulse = SG90.pulse_width(90 * DEG)
    up = HobbyServo(SG90, horn_rad=80 * DEG)
    up.link_rad = up.shaft_rad - 0.5 * SG90.backlash_rad  # resting after a move up
    up.run([pulse] * 10, DT)
    down = HobbyServo(SG90, horn_rad=100 * DEG)
    down.link_rad = down.shaft_rad + 0.5 * SG90.backlash_rad
    down.run([pulse] * 10, DT)
    assert up.shaft_rad == pytest.approx(down.shaft_rad)  # the potentiometer reads the same
    assert down.link_rad - up.link_rad == pytest.approx(1.0 * DEG)  # the link does not
    # reverse by 0.8 deg: the shaft turns, the link stays (inside the 1 deg play)
    before = up.link_rad
    up.run([SG90.pulse_width(89.2 * DEG)] * 5, DT)
    assert up.shaft_rad == pytest.approx(89.2 * DEG, abs=0.05 * DEG)
    assert up.link_rad == pytest.approx(before)
    # a load pushes the link to its side of the play whatever the motion
    up.step(DT, load_torque_nm=-0.05)
    assert up.link_rad == pytest.approx(up.shaft_rad - 0.5 * SG90.backlash_rad)


def test_load_slows_the_servo_and_the_stall_torque_stops_it():
    """MG996R: 9.4 kgf cm = 0.92 N m stall. Against half of it the slew halves; against
    more than it the shaft does not move."""
    pulse = MG996R.pulse_width(120 * DEG)
    free = HobbyServo(MG996R, horn_rad=60 * DEG)
    half = HobbyServo(MG996R, horn_rad=60 * DEG)
    stalled = HobbyServo(MG996R, horn_rad=60 * DEG)
    assert MG996R.stall_torque_nm == pytest.approx(0.9218, abs=1e-4)
    free.run([pulse] * 2, DT)
    half.run([pulse] * 2, DT, load_torque_nm=-0.5 * MG996R.stall_torque_nm)
    stalled.run([pulse] * 2, DT, load_torque_nm=-1.1 * MG996R.stall_torque_nm)
    assert free.shaft_rad - 60 * DEG == pytest.approx(MG996R.speed_rad_s * 0.040)
    assert half.shaft_rad - 60 * DEG == pytest.approx(0.5 * MG996R.speed_rad_s * 0.040)
    assert stalled.shaft_rad == pytest.approx(60 * DEG)
    # a load helping the motion does not speed it past its rated speed
    helped = HobbyServo(MG996R, horn_rad=60 * DEG)
    helped.run([pulse] * 2, DT, load_torque_nm=+2.0)
    assert helped.shaft_rad == pytest.approx(free.shaft_rad)


def test_the_mujoco_actuator_reaches_stall_torque_at_three_degrees():
    assert SG90.position_gain() * math.radians(3) == pytest.approx(SG90.stall_torque_nm)
    assert MG996R.position_gain() == pytest.approx(0.9218 / math.radians(3), rel=1e-4)
