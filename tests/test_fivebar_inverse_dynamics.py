"""MuJoCo's inverse dynamics of the five-bar's own model carrying the heaviest pot
(transplanter.scene.fivebar_inverse: mj_inverse on the closed chain, the arm motors' torques
by virtual work) against the lumped model the bspline5 planner holds to its torque limit
(FiveBarKinematics.inverse_dynamics), along the paper's first transfer. Measured
(scripts/fivebar_mj_inverse.py, 801 samples a transfer): gravity gives the arm motors no
torque in either model; in motion the lumped peak is 0.0579 N m at the motor against
mj_inverse's 0.0564, the largest difference 0.0029 N m (1.3 % of the 0.225 N m limit), of
which up to 0.001 N m is the passive hinges' damping and the rest the passive links' turning
(the lumped half-and-half puts m l2^2 / 4 where a rod has m l2^2 / 12) and the gripper's own
rotation."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from transplanter.machine.planner_via import plan_via_move
from transplanter.machine.spline_motion import spline_limits
from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario
from transplanter.scene.fivebar_inverse import FiveBarInverse

SCENARIO = load_scenario("paper", {"motion.planner": "bspline5"})
CONFIG = assemble(SCENARIO)
KIN = CONFIG.machine.sgf.kinematics
LIMITS = spline_limits(KIN, CONFIG.machine.sgf.motion)
Z_UP = CONFIG.machine.eeprom.z_up_m
POINTS = np.array([[-0.090, 0.215, Z_UP], [-0.090, 0.180, Z_UP], [0.0, 0.140, Z_UP]])
CARRIED = SCENARIO.pots.mass_max_kg + SCENARIO.pots.shoot_mass_kg


def _along(limits, samples: int = 121):
    plan = plan_via_move(KIN, POINTS, limits)
    spline = plan.spline()
    t = np.linspace(0.0, plan.total_s, samples)
    q, qd, qdd = (spline(t, nu=k)[:, :2] for k in range(3))
    inv = FiveBarInverse(CONFIG.scene, CARRIED, z_m=Z_UP)
    return plan, q, qd, qdd, inv.torques(q, qd, qdd)


@pytest.fixture(scope="module")
def paper_transfer():
    return _along(LIMITS)


def test_the_model_carries_what_the_lumped_model_puts_at_c():
    inv = FiveBarInverse(CONFIG.scene, CARRIED, z_m=Z_UP)
    m = inv.model
    gripper = m.body_subtreemass[m.body("gripper").id]
    assert gripper == pytest.approx(KIN.masses.end_effector_kg, abs=1e-12)
    np.testing.assert_array_equal(inv.gear, KIN.belt_ratios())


def test_the_chain_closes_and_gravity_leaves_the_arm_motors_alone(paper_transfer):
    *_, mj = paper_transfer
    assert mj.closure_m < 1e-12 and mj.closure_speed_m_s < 1e-12
    assert np.abs(mj.gravity).max() < 1e-12  # the arm plane is horizontal


def test_mj_inverse_and_the_lumped_model_agree_along_the_transfer(paper_transfer):
    plan, q, qd, qdd, mj = paper_transfer
    lumped = KIN.inverse_dynamics(q, qd, qdd)
    diff = mj.torque - lumped
    assert np.abs(lumped).max() == pytest.approx(0.0579, abs=2e-4)  # N m at the motor
    assert np.abs(mj.torque).max() == pytest.approx(0.0564, abs=2e-4)
    assert np.abs(diff).max() < 0.0035  # 1.6 % of the 0.225 N m limit
    assert np.abs(diff).max() > 0.001  # the models do differ
    assert np.abs(mj.damping).max() < 0.0012  # the passive hinges' damping
    assert np.abs(mj.torque).max() < np.abs(lumped).max()  # the lumping is on the safe side


def test_where_the_torque_limit_binds_mujoco_stays_under_it():
    free = dataclasses.replace(LIMITS, ee_accel_m_s2=None)  # the jaws' limit lifted
    plan, q, qd, qdd, mj = _along(free)
    assert plan.binding.startswith("joint torque")
    assert np.abs(KIN.inverse_dynamics(q, qd, qdd)).max() == pytest.approx(0.225, rel=1e-3)
    assert 0.215 < np.abs(mj.torque).max() < 0.225
