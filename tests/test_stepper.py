"""The hybrid stepper's torque law (transplanter.scene.stepper): against load angle, speed and
a MuJoCo rotor that holds or slips."""

import math

import mujoco
import numpy as np
import pytest
from scipy.optimize import brentq

from transplanter.scene.config import SceneConfig
from transplanter.scene.stepper import StepperDrives, StepperParams

NEMA17 = SceneConfig().stepper_params()[0]
FULL_STEP = 2 * math.pi / 200


def test_torque_is_sinusoidal_in_load_angle_peaking_one_full_step_behind():
    """One electrical cycle per 4 full steps: 0 at 0, the holding torque at 1 full step, 0
    again at 2 (the unstable equilibrium), negative past it (pulling to the next cycle)."""
    angles = np.array([0.0, 0.5, 1.0, 1.5, 2.0, 3.0]) * FULL_STEP
    torque = NEMA17.torque_nm(angles)
    expected = 0.45 * np.sin(np.array([0.0, 0.5, 1.0, 1.5, 2.0, 3.0]) * math.pi / 2)
    np.testing.assert_allclose(torque, expected, atol=1e-12)
    assert torque[2] == pytest.approx(0.45)
    assert torque[5] == pytest.approx(-0.45)
    # small-signal stiffness: holding torque x 50 rotor teeth
    assert NEMA17.stiffness_nm_rad == pytest.approx(22.5)
    slope = (NEMA17.torque_nm(1e-7) - NEMA17.torque_nm(-1e-7)) / 2e-7
    assert slope == pytest.approx(22.5, rel=1e-6)


def test_detent_torque_has_one_cycle_per_full_step():
    quarter = NEMA17.torque_nm(0.0, rotor_rad=FULL_STEP / 4)
    assert quarter == pytest.approx(-0.022)
    assert NEMA17.torque_nm(0.0, rotor_rad=FULL_STEP) == pytest.approx(0.0, abs=1e-12)


def test_pullout_torque_is_flat_to_the_corner_then_falls_as_one_over_speed():
    rev = 2 * math.pi
    assert NEMA17.pullout_nm(0.0) == 0.45
    assert NEMA17.pullout_nm(8.0 * rev) == pytest.approx(0.45)
    assert NEMA17.pullout_nm(16.0 * rev) == pytest.approx(0.225)
    assert NEMA17.pullout_nm(-16.0 * rev) == pytest.approx(0.225)  # either direction
    np.testing.assert_allclose(
        NEMA17.pullout_nm(np.array([4.0, 20.0, 40.0]) * rev), [0.45, 0.18, 0.09]
    )


def _rotor(dt: float):
    """A NEMA17 rotor alone (no load inertia) on a hinge with the stepper's actuator."""
    xml = f"""
    <mujoco><option timestep="{dt}" integrator="implicitfast" gravity="0 0 0"/>
      <worldbody><body><joint name="r" type="hinge" armature="5.4e-6"/>
        <inertial pos="0 0 0" mass="0.001" diaginertia="1e-12 1e-12 1e-12"/>
        </body></worldbody>
      <actuator><general name="m" joint="r" gaintype="fixed" gainprm="1" biastype="affine"
        biasprm="0 0 {-NEMA17.damping_nms_rad}"/></actuator>
    </mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    return model, mujoco.MjData(model), StepperDrives([NEMA17], [0], [0], [1.0], [0.0])


@pytest.mark.parametrize("load_fraction, slips", [(0.9, False), (1.1, True)])
def test_a_load_below_the_holding_torque_holds_and_one_above_slips(load_fraction, slips):
    """A constant load on the shaft: below the holding torque the rotor settles where the
    torque law (with the detent) balances it, within one full step; above it the rotor
    passes two full steps and runs on."""
    model, data, drive = _rotor(1e-4)
    for _ in range(20000):  # 2 s
        data.qfrc_applied[0] = -load_fraction * 0.45
        drive.hold(data, [0.0])
        mujoco.mj_step(model, data)
    lag = -data.qpos[0]
    if slips:
        assert lag > 2 * FULL_STEP
    else:
        expected = brentq(lambda x: NEMA17.torque_nm(x, rotor_rad=-x) - 0.9 * 0.45, 0.0, FULL_STEP)
        assert expected == pytest.approx(0.0249, abs=1e-4)  # asin(0.9) / 50 = 0.0224 without detent
        assert lag == pytest.approx(expected, rel=1e-3)
        assert lag < FULL_STEP


def test_the_lag_at_a_ramp_converges_as_the_step_shrinks():
    """The rotor follows a field that accelerates at 2000 rev/s^2 to 5 rev/s: its peak lag
    changes by less than 0.01 full step from 0.1 to 0.05 ms and by less than 0.05 from 0.2 ms
    (the command at each step's start: consistent in time at any step)."""
    peaks = {}
    for dt in (2e-4, 1e-4, 5e-5):
        model, data, drive = _rotor(dt)
        accel, top = 2000 * 2 * math.pi, 5 * 2 * math.pi
        peak = 0.0
        for k in range(int(0.02 / dt)):
            t = k * dt
            t_top = top / accel
            speed = min(accel * t, top)
            field = 0.5 * accel * t * t if t < t_top else 0.5 * accel * t_top**2 + top * (t - t_top)
            drive.hold(data, [field], [speed])
            mujoco.mj_step(model, data)
            t1 = t + dt
            field1 = (
                0.5 * accel * t1 * t1 if t1 < t_top else 0.5 * accel * t_top**2 + top * (t1 - t_top)
            )
            peak = max(peak, abs(field1 - data.qpos[0]) / FULL_STEP)
        peaks[dt] = peak
    assert 0.05 < peaks[5e-5] < 2.0  # it lags, and keeps up
    assert abs(peaks[1e-4] - peaks[5e-5]) < 0.01, peaks
    assert abs(peaks[2e-4] - peaks[5e-5]) < 0.05, peaks


def test_bad_drive_settings_are_refused():
    with pytest.raises(ValueError, match="detent_torque_nm must be below the holding torque"):
        SceneConfig(detent_torque_nm=0.5)
    with pytest.raises(ValueError, match="rotor_damping_ratio must be >= 0"):
        SceneConfig(rotor_damping_ratio=-0.1)


def test_stepper_params_carry_the_config():
    params = SceneConfig(holding_torque_nm=0.6, pullout_corner_rev_s=5.0).stepper_params()
    assert all(isinstance(p, StepperParams) for p in params)
    assert params[2].holding_torque_nm == 0.6 and params[2].corner_rev_s == 5.0
    damping = 2 * 0.2 * math.sqrt(0.6 * 50 * 5.4e-6)
    assert params[0].damping_nms_rad == pytest.approx(damping)
