"""MuJoCo's inverse dynamics of the delta model (transplanter.scene.delta_inverse: mj_inverse on
the closed chain, the actuated joints' torques by virtual work) against the lumped model of
Eq. 9 (DeltaKinematics.inverse_dynamics), along the planner's example move of Zhao et al.
2022. Measured (scripts/planner_mj_inverse.py, 801 samples): at rest they agree to 1e-12 N m
(the lumped statics are exact: uniform arms and rods, half of each rod's weight at each
end); in motion MuJoCo needs up to 0.19 N m more or less, of which up to 0.15 N m is the
joints' viscous damping (0.05 N m s/rad in the model, none in Eq. 9) and up to 0.08 N m the
inertia that the lumping misplaces (the rods' own rotation and where their mass sits)."""

from __future__ import annotations

import numpy as np
import pytest

from transplanter.machine import planner_bspline as pb
from transplanter.machine.kinematics.delta import DeltaKinematics
from transplanter.scene.delta_inverse import DeltaInverse

KIN = DeltaKinematics()
MM = 1e-3
START = np.array([200.0, 200.0, -800.0]) * MM
END = np.array([250.0, -175.0, -800.0]) * MM
ARM_DAMPING = 0.05  # N m s/rad, the arm hinges' damping in models/delta/delta.xml


@pytest.fixture(scope="module")
def along_the_example():
    plan = pb.plan_move(KIN, START, END, pb.MoveLimits.of(KIN))
    spline = plan.spline()
    t = np.linspace(0.0, plan.total_s, 61)
    q, qd, qdd = spline(t), spline(t, nu=1), spline(t, nu=2)
    inv = DeltaInverse()
    return q, qd, qdd, inv.torques(q, qd, qdd)


def test_the_closed_chain_state_satisfies_the_equalities(along_the_example):
    *_, mj = along_the_example
    assert mj.closure_m < 1e-10 and mj.closure_speed_m_s < 1e-10
    assert mj.residual < 1e-9  # tau and the equalities' forces balance the full equations


def test_at_rest_mj_inverse_is_the_static_part_of_eq_9(along_the_example):
    q, _, _, mj = along_the_example
    np.testing.assert_allclose(mj.gravity, KIN.gravity_torques(q), atol=1e-9)
    assert np.abs(mj.gravity).max() > 2.0  # real torques, not zeros


def test_in_motion_mj_inverse_and_eq_9_agree_within_the_damping_and_the_lumping(
    along_the_example,
):
    q, qd, qdd, mj = along_the_example
    eq9 = KIN.inverse_dynamics(q, qd, qdd)
    diff = mj.torque - eq9
    assert np.abs(eq9).max() == pytest.approx(10.0, abs=0.1)  # the example's ~10 N m peak
    assert np.abs(diff).max() < 0.20  # N m: 2 % of the peak
    assert np.abs(diff).max() > 0.05  # the models do differ
    # the damping part is the arm hinges' 0.05 N m s/rad (the rods' 0.001 adds a little)
    np.testing.assert_allclose(mj.damping, ARM_DAMPING * qd, atol=0.01)
    # what is left is the inertia the lumped model misplaces
    assert np.abs(diff - mj.damping).max() < 0.09
