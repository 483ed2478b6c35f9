"""The rotary delta's kinematics (transplanter.machine.kinematics.delta): the paper's IK
(Zhao et al. 2022, Eq. 3-4 with the lost signs restored) against the trilateration FK, the
Jacobian (Eq. 5-6) against finite differences, the two 128-cell trays of the replenishing
machine, typed refusals, the [delta] scenario section, the SGF and `transplanter ik`."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from conftest import PAPER_PATH
from transplanter import cli
from transplanter.errors import RefusalReason, TransplanterError
from transplanter.kinds import kinematics_class
from transplanter.machine.kinematics import UnreachableError
from transplanter.machine.kinematics.delta import (
    DeltaGeometry,
    DeltaKinematics,
    elbow_points,
    ik,
    ik_both,
    jacobian,
)
from transplanter.machine.planner import plan_program
from transplanter.scenario.assemble import machine_config
from transplanter.scenario.schema import ScenarioError, load_scenario

KIN = DeltaKinematics()
GEOM = KIN.geometry
MM = 1e-3

# The two standard trays (566 x 286 mm, 8 x 16 cells of 35.375 x 35.75 mm) side by side under
# the base, their long sides along X, centred at Y = -160 mm (supply) and +160 mm (planting),
# cell centres at the paper's working height Z = -800 mm (docs/delta.md).
TRAY_Y0_MM = (-160.0, 160.0)
TRAY_Z_MM = -800.0
CLEARANCE_MM = 150.0  # the paper's 100 mm lift plus the 50 mm arc


def paper_scenario(overrides):
    """The worktree's paper scenario with 'section.key' overrides."""
    return load_scenario(PAPER_PATH, overrides)


def tray_cells(z_mm: float = TRAY_Z_MM) -> np.ndarray:
    """(256, 3) cell centres of both trays in m."""
    xs = (np.arange(16) - 7.5) * 566.0 / 16
    ys = (np.arange(8) - 3.5) * 286.0 / 8
    cells = [(x, y0 + y, z_mm) for y0 in TRAY_Y0_MM for x in xs for y in ys]
    return np.array(cells) * MM


def workspace_grid() -> np.ndarray:
    """A 3-D grid over and past the working volume (m), 25 mm in X and Y, 25 mm in Z."""
    x = np.arange(-450.0, 450.1, 25.0)
    z = np.arange(-1100.0, -450.0, 25.0)
    return np.stack(np.meshgrid(x, x, z, indexing="ij"), axis=-1).reshape(-1, 3) * MM


def test_the_registry_makes_the_delta():
    assert kinematics_class("delta") is DeltaKinematics
    assert [a.name for a in KIN.axes] == ["q1", "q2", "q3"]
    assert not any(a.linear for a in KIN.axes)


def test_ik_and_fk_agree_to_a_nanometre_over_the_workspace():
    pts = workspace_grid()
    report = KIN.check(pts)
    good = pts[report.ok]
    # the grid reaches past the workspace on every side, and most of it is inside
    assert 0.35 * len(pts) < len(good) < 0.9 * len(pts)
    back = KIN.point(KIN.joints(good))
    err_mm = np.abs(back - good).max() / MM
    assert err_mm < 1e-6, err_mm
    # and FK -> IK gives the joints back over the whole joint window
    rng = np.random.default_rng(1)
    q = rng.uniform(math.radians(-40.0), math.radians(80.0), size=(2000, 3))
    p = KIN.point(q)
    closed = np.isfinite(p).all(axis=1)
    assert closed.mean() > 0.99
    np.testing.assert_allclose(KIN.joints(p[closed]), q[closed], atol=1e-11)


def test_eq4_as_printed_gives_the_same_knee_out_root():
    """q = 2 arctan[(a + sqrt(a^2 + b^2 - c^2)) / (b + c)] is the working branch wherever
    b + c is not near 0; the other root folds the elbow inwards (cos q < 0)."""
    pts = tray_cells()
    plus, minus = ik_both(GEOM, pts)
    np.testing.assert_allclose(plus, ik(GEOM, pts), atol=1e-12)
    assert (np.cos(minus) < 0.0).all()
    # the elbows of the working branch lie outside the joints (knee out)
    b = elbow_points(GEOM, ik(GEOM, pts))
    assert (np.hypot(b[..., 0], b[..., 1]) > GEOM.base_radius_m).all()


def test_each_follower_has_length_l2_at_the_ik_solution():
    pts = tray_cells()
    q = ik(GEOM, pts)
    phi = np.radians([0.0, 120.0, 240.0])
    e = np.stack([np.cos(phi), np.sin(phi), np.zeros(3)], axis=-1)
    c = pts[:, None, :] + GEOM.platform_radius_m * e
    lengths = np.linalg.norm(c - elbow_points(GEOM, q), axis=-1)
    np.testing.assert_allclose(lengths, GEOM.forearm_m, atol=1e-12)


def test_the_symmetric_point_gives_equal_angles():
    # q = 0: elbows at R + l1 = 550 mm, platform ends at r = 50 mm, so the platform hangs
    # sqrt(800^2 - 500^2) = 624.4998 mm below the base
    home = KIN.point([0.0, 0.0, 0.0])
    np.testing.assert_allclose(home, [0, 0, -math.sqrt(0.8**2 - 0.5**2)], atol=1e-15)
    assert home[2] / MM == pytest.approx(-624.4998, abs=1e-4)
    for z_mm in (-600.0, -700.0, -800.0, -1000.0):
        q = KIN.joints([0.0, 0.0, z_mm * MM])
        assert np.ptp(q) < 1e-13
    q800 = KIN.joints([0.0, 0.0, -0.8])
    # by hand: the follower spans R - r + l1 cos q horizontally, 800 - l1 sin q vertically
    q0 = q800[0]
    horizontal = 0.150 + 0.350 * math.cos(q0)
    vertical = 0.8 - 0.350 * math.sin(q0)
    assert math.hypot(horizontal, vertical) == pytest.approx(0.8, abs=1e-12)
    assert math.degrees(q0) == pytest.approx(25.3632, abs=1e-4)


def test_both_128_cell_trays_are_reachable_at_the_working_and_the_clearance_height():
    for z_mm in (TRAY_Z_MM, TRAY_Z_MM + CLEARANCE_MM):
        cells = tray_cells(z_mm)
        report = KIN.check(cells)
        assert report.ok.all(), report.reasons
        q = np.degrees(report.joints)
        assert -40.0 < q.min() and q.max() < 80.0
        assert report.diagnostics["condition"].max() < 3.0
    q = np.degrees(KIN.check(tray_cells()).joints)
    assert q.min() == pytest.approx(2.275, abs=1e-3)
    assert q.max() == pytest.approx(71.190, abs=1e-3)
    # the paper's example move (signs restored as docs/delta.md reads them)
    for point in ((200.0, 200.0, -800.0), (250.0, -175.0, -800.0)):
        assert KIN.check(np.array(point) * MM).ok.all()


def test_jacobian_matches_finite_differences_of_fk():
    rng = np.random.default_rng(7)
    q = rng.uniform(math.radians(-20.0), math.radians(70.0), size=(200, 3))
    p = KIN.point(q)
    keep = np.isfinite(p).all(axis=1)
    q, p = q[keep], p[keep]
    jac = jacobian(GEOM, q, p)
    h = 1e-6
    numeric = np.empty_like(jac)
    for j in range(3):
        dq = np.zeros(3)
        dq[j] = h
        numeric[..., j] = (KIN.point(q + dq) - KIN.point(q - dq)) / (2.0 * h)
    rel = np.abs(jac - numeric).max(axis=(1, 2)) / np.abs(numeric).max(axis=(1, 2))
    assert rel.max() < 1e-6, rel.max()
    np.testing.assert_allclose(KIN.jacobian(q), jac)


def test_jacobian_at_home_is_symmetric_about_z():
    """At the symmetric point every arm moves the platform down by the same amount."""
    q = KIN.joints([0.0, 0.0, -0.8])
    jac = KIN.jacobian(q)
    ones = jac @ np.ones(3)
    np.testing.assert_allclose(ones[:2], 0.0, atol=1e-14)
    assert ones[2] < 0.0  # all arms down: the platform goes down


def test_a_point_past_the_joint_window_is_refused_naming_the_joint():
    with pytest.raises(UnreachableError) as err:
        KIN.require(np.array([[0.0, 0.0, -800.0], [-300.0, 0.0, -1000.0]]) * MM)
    assert err.value.index == 1
    (refusal,) = err.value.refusals
    assert refusal.reason is RefusalReason.JOINT_LIMIT
    assert refusal.subject == "arm 1 angle q1"
    assert refusal.value == pytest.approx(87.4016, abs=1e-4)
    assert (refusal.low, refusal.high) == pytest.approx((-40.0, 80.0))
    assert "arm 1 angle q1 87.4 deg outside [-40, 80] deg" in str(err.value)
    assert isinstance(err.value, TransplanterError)
    # above: arm 1 would have to rise past q_min
    (refusal,) = KIN.check(np.array([300.0, 0.0, -550.0]) * MM).refusals[0]
    assert refusal.reason is RefusalReason.JOINT_LIMIT and refusal.value < -40.0


def test_a_point_out_of_reach_is_refused_with_each_arms_reach():
    report = KIN.check(np.array([[0.0, 700.0, -800.0], [0.0, 0.0, -300.0]]) * MM)
    assert not report.ok.any()
    far = report.refusals[0]
    assert [r.label for r in far] == ["arm 1", "arm 3"]
    assert all(r.reason is RefusalReason.OUT_OF_WORKSPACE and r.high == 800.0 for r in far)
    assert far[0].value == pytest.approx(839.8, abs=0.1)
    assert "distance from C1 to its elbow circle=839.8 mm > L2=800.0 mm" in report.reasons[0]
    # too close to the base: even the farthest elbow position is nearer than l2
    near = report.refusals[1]
    assert len(near) == 3 and all(r.low == 800.0 and r.value < 800.0 for r in near)
    assert np.isnan(report.joints[1]).all()
    assert np.isnan(report.joints[0, [0, 2]]).all() and np.isfinite(report.joints[0, 1])
    (nan,) = KIN.check([math.nan, 0.0, -0.8]).refusals[0]
    assert nan.reason is RefusalReason.NOT_FINITE


def test_z_outside_the_machine_range_is_refused_before_a_move():
    assert KIN.limit_target(np.array([0.0, 0.0, -0.8])) is None
    refusal = KIN.limit_target(np.array([0.0, 0.0, -1.1]))
    assert refusal.reason is RefusalReason.AXIS_RANGE
    assert refusal.text() == "Z -1100.000 mm outside [-1050, -500] mm"


def test_pulse_counters_round_trip_within_a_pulse():
    """2000 pulses per motor revolution through 25:1: 50000 per arm revolution, so a pulse
    is 0.0072 deg at the joint and moves the platform by well under 0.1 mm."""
    drive = KIN.drives[0]
    assert drive.steps_per_unit == pytest.approx(50000 / (2 * math.pi))
    assert drive.max_step_rate_hz / drive.steps_per_unit == pytest.approx(math.radians(720.0))
    cells = tray_cells()
    steps = KIN.steps_of_point(cells)
    back = KIN.point_of_steps(steps)
    assert np.abs(back - cells).max() < 0.05 * MM


def test_the_scenario_section_makes_the_delta_and_is_read_in_its_units():
    machine = machine_config(paper_scenario({"robot.kind": "delta"}))
    kin = machine.kinematics
    default = DeltaKinematics()  # the [delta] defaults are the class's
    for part in ("geometry", "limits", "masses"):
        ours, theirs = (
            dataclasses.astuple(getattr(kin, part)),
            dataclasses.astuple(getattr(default, part)),
        )
        np.testing.assert_allclose(ours, theirs, rtol=1e-15)
    assert kin.drives == default.drives
    assert kin.home_q_rad == pytest.approx(default.home_q_rad, rel=1e-15)
    other = machine_config(
        paper_scenario({"robot.kind": "delta", "delta.forearm_mm": 900, "delta.q_max_deg": 60,
             "delta.gear_ratio": 5, "delta.max_joint_speed_deg_s": 360},
        )
    ).kinematics  # fmt: skip
    assert other.geometry.forearm_m == pytest.approx(0.9, rel=1e-15)
    assert other.geometry.base_radius_m == pytest.approx(DeltaGeometry().base_radius_m)
    assert other.limits.q_max_rad == pytest.approx(math.radians(60.0))
    assert other.drives[0].ratio == 5.0
    assert other.drives[0].max_step_rate_hz == pytest.approx(360 / 360 * 5 * 2000)
    assert other.drives[0].holding_torque_nm == pytest.approx(12.0 / 5)
    with pytest.raises(ScenarioError, match="delta.forearm_m: wrong unit.*'forearm_mm'"):
        paper_scenario({"robot.kind": "delta", "delta.forearm_m": 0.9})
    with pytest.raises(ScenarioError, match="homing angle -50 deg lies outside"):
        machine_config(paper_scenario({"robot.kind": "delta", "delta.home_q_deg": -50}))


def test_the_sgf_homes_and_moves_the_delta():
    machine = machine_config(paper_scenario({"robot.kind": "delta"}))
    program = "G28\nG90\nG1 X200 Y200 Z-800 S200\nG1 X250 Y-175 Z-800 S200\nM114\n"
    rows = plan_program(machine, program)
    assert rows[-1].replies[0].startswith("X:250.000 Y:-175.000 Z:-800.000 A:")
    # net pulses of the example move: the joint change at 50000 pulses per arm revolution
    q0, q1 = KIN.joints(np.array([[200.0, 200.0, -800.0], [250.0, -175.0, -800.0]]) * MM)
    expected = np.rint(q1 * 50000 / (2 * math.pi)) - np.rint(q0 * 50000 / (2 * math.pi))
    np.testing.assert_array_equal(rows[3].steps, expected)


def test_transplanter_ik_prints_the_three_arm_angles(capsys):
    status = cli.main(
        ["ik", "250", "-175", "-800", "--set", "robot.kind=delta", "--scenario", str(PAPER_PATH)]
    )
    out = capsys.readouterr().out.splitlines()
    assert status == 0
    assert out[:3] == ["q1 = 9.6758 deg", "q2 = 58.4607 deg", "q3 = 32.7377 deg"]
    status = cli.main(
        ["ik", "-300", "0", "-1000", "--set", "robot.kind=delta", "--scenario", str(PAPER_PATH)]
    )
    assert status == 1
    assert "arm 1 angle q1 87.4 deg outside [-40, 80] deg" in capsys.readouterr().out
