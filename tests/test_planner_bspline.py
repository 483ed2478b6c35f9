"""The quintic B-spline move planner (transplanter.machine.planner_bspline) after Zhao et al.
2022, Sec. 2.4: the spline through the joint nodes with the paper's end conditions, exact
peaks against dense sampling, the paper's example move under its limits, refusals, the delta's
Eq. 7-9 dynamics, TOPP-RA as the optimum along the path, determinism and `plan-move`."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from conftest import PAPER_PATH
from transplanter import cli
from transplanter.machine import planner_bspline as pb
from transplanter.machine.kinematics.delta import DeltaKinematics

KIN = DeltaKinematics()
MM = 1e-3
START = np.array([200.0, 200.0, -800.0]) * MM  # the paper's example, signs as docs/delta.md
END = np.array([250.0, -175.0, -800.0]) * MM
PAPER_INTERVALS = np.array([0.21, 0.15, 0.18, 0.17, 0.15, 0.19])
LIMITS = pb.MoveLimits.of(KIN)


@pytest.fixture(scope="module")
def plan():
    return pb.plan_move(KIN, START, END, LIMITS)


@pytest.fixture(scope="module")
def nodes():
    return pb.joint_nodes(KIN, pb.key_points(START, END))


def _dense(spline, per_interval=4000):
    tn = spline.t[5:-5]
    ts = np.concatenate(
        [np.linspace(a, b, per_interval + 1) for a, b in zip(tn[:-1], tn[1:], strict=True)]
    )
    return ts, spline(ts), spline(ts, nu=1), spline(ts, nu=2), spline(ts, nu=3)


def test_the_key_points_are_the_papers_lift_arc_top_arc_descent():
    q = pb.key_points(START, END)
    np.testing.assert_allclose(q[0], START)
    np.testing.assert_allclose(q[6], END)
    np.testing.assert_allclose(q[1] - q[0], [0, 0, 0.100], atol=1e-12)
    np.testing.assert_allclose(q[5] - q[6], [0, 0, 0.100], atol=1e-12)
    u = np.append((END - START)[:2] / np.hypot(*(END - START)[:2]), 0.0)
    np.testing.assert_allclose(q[2] - q[1], 0.050 * u + [0, 0, 0.050], atol=1e-12)
    np.testing.assert_allclose(q[5] - q[4], 0.050 * u - [0, 0, 0.050], atol=1e-12)
    np.testing.assert_allclose(q[3], 0.5 * (q[2] + q[4]))
    # close points: the arcs shrink to a third of the distance, the top stays 150 mm up
    near = pb.key_points(START, START + [0.060, 0, 0])
    assert near[2, 0] - near[1, 0] == pytest.approx(0.020)
    assert near[3, 2] == pytest.approx(START[2] + 0.150)


def test_the_spline_passes_through_the_nodes_and_starts_and_ends_at_rest(nodes):
    h = np.array([0.3, 0.1, 0.25, 0.15, 0.12, 0.2])
    spline = pb.quintic_spline(nodes, h)
    t = np.concatenate([[0.0], np.cumsum(h)])
    np.testing.assert_allclose(spline(t), nodes, atol=1e-12)
    for end in (t[0], t[-1]):
        np.testing.assert_allclose(spline(end, nu=1), 0.0, atol=1e-10)
        np.testing.assert_allclose(spline(end, nu=2), 0.0, atol=1e-8)
    assert spline.k == 5 and len(spline.c) == 11  # the paper's 11 control points
    np.testing.assert_allclose(spline.t, np.r_[[0.0] * 5, t, [t[-1]] * 5])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_exact_peaks_agree_with_dense_sampling_and_never_fall_under_it(nodes, seed):
    h = np.random.default_rng(seed).uniform(0.05, 0.4, 6)
    spline = pb.quintic_spline(nodes, h)
    peaks = pb.exact_peaks(spline)
    tn = spline.t[5:-5]
    for i in range(6):
        ts = np.linspace(tn[i], tn[i + 1], 40001)
        for name, nu in (("speed", 1), ("accel", 2), ("jerk", 3)):
            sampled = np.abs(spline(ts, nu=nu)).max(axis=0)
            exact = peaks[name][i]
            assert np.all(sampled <= exact * (1 + 1e-12) + 1e-12), (name, i)
            np.testing.assert_allclose(exact, sampled, rtol=1e-6, err_msg=f"{name} {i}")


def test_the_papers_intervals_on_the_default_delta(nodes):
    """What the end-effector limit is calibrated on: the paper's own 1.05 s plan peaks at
    8.7955 m/s^2 (29.87 of the printed 30 -> 8.83 m/s^2) and 10.1 N m (the paper: 10.23)."""
    spline = pb.quintic_spline(nodes, PAPER_INTERVALS)
    _, q, qd, qdd, _ = _dense(spline, 2000)
    ee = np.linalg.norm(KIN.platform_motion(q, qd, qdd)[2], axis=-1).max()
    tau = np.abs(KIN.inverse_dynamics(q, qd, qdd)).max()
    assert ee == pytest.approx(8.7955, abs=1e-3)
    assert ee * 30 / 29.87 == pytest.approx(pb.EE_ACCEL_LIMIT_M_S2, abs=0.01)
    assert tau == pytest.approx(10.11, abs=0.01)
    assert ee < LIMITS.ee_accel_m_s2 and tau < 12.0  # the paper's plan is feasible


def test_the_paper_example_plans_under_1_05_s_within_every_limit(plan):
    assert plan.total_s < 1.05
    assert plan.total_s == pytest.approx(0.8215, abs=1e-3)
    assert plan.binding == "end-effector accel"
    _, q, qd, qdd, _ = _dense(plan.spline())
    assert np.abs(qd).max() <= LIMITS.joint_speed_rad_s
    assert np.abs(qdd).max() <= LIMITS.joint_accel_rad_s2
    assert np.abs(KIN.inverse_dynamics(q, qd, qdd)).max() <= LIMITS.joint_torque_nm
    ee = np.linalg.norm(KIN.platform_motion(q, qd, qdd)[2], axis=-1).max()
    assert ee <= LIMITS.ee_accel_m_s2
    assert ee == pytest.approx(LIMITS.ee_accel_m_s2, rel=1e-6)  # it binds
    lo, hi = KIN.limits.q_min_rad, KIN.limits.q_max_rad
    assert lo <= q.min() and q.max() <= hi


def test_a_plan_that_cannot_meet_a_limit_is_refused_naming_it():
    weak = pb.MoveLimits(LIMITS.joint_speed_rad_s, LIMITS.joint_accel_rad_s2, 0.1, 8.83)
    with pytest.raises(pb.MoveRefused, match="joint torque limit 0.1 N m") as exc:
        pb.plan_move(KIN, START, END, weak)
    assert exc.value.limit == "joint torque"
    with pytest.raises(pb.MoveRefused, match="key point Q0") as exc:
        pb.plan_move(KIN, np.array([0.0, 0.7, -0.8]), END)
    assert exc.value.limit == "reach"


def test_toppra_is_no_slower_than_the_spline_along_its_own_path(plan):
    topp = pb.toppra_total(KIN, plan.nodes, plan.intervals_s, LIMITS)
    assert topp <= plan.total_s
    assert 1.0 < plan.total_s / topp < 1.3


def test_toppra_batched_coefficients_equal_toppras_point_by_point(plan, monkeypatch):
    """The delta's second-order constraints are evaluated over the whole grid in one call;
    their coefficients are those of toppra's own loop over the grid points, and so is the
    example's optimum."""
    import toppra

    spline = pb.quintic_spline(plan.nodes, plan.intervals_s)
    end = float(np.sum(plan.intervals_s))

    class Path(toppra.interpolator.AbstractGeometricPath):
        def __call__(self, s, order=0):
            return spline(np.asarray(s, dtype=np.float64), nu=order)

        @property
        def dof(self):
            return 3

        @property
        def path_interval(self):
            return np.array([0.0, end])

    grid = np.linspace(0.0, end, 41)
    tau = np.tile([-12.0, 12.0], (3, 1))
    loop = toppra.constraint.SecondOrderConstraint.joint_torque_constraint(
        KIN.inverse_dynamics, tau, np.zeros(3)
    )
    batched = pb._batched_second_order(toppra)(
        KIN.inverse_dynamics, loop.constraint_F, loop.constraint_g, 3
    )
    for a, b in zip(
        loop.compute_constraint_params(Path(), grid),
        batched.compute_constraint_params(Path(), grid),
        strict=True,
    ):
        if a is None:
            assert b is None
        else:
            np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12)
    fast = pb.toppra_total(KIN, plan.nodes, plan.intervals_s, LIMITS)
    monkeypatch.setattr(pb, "_batched_second_order", lambda t: t.constraint.SecondOrderConstraint)
    assert fast == pytest.approx(
        pb.toppra_total(KIN, plan.nodes, plan.intervals_s, LIMITS), abs=1e-12
    )
    assert fast == pytest.approx(0.7230, abs=2e-4)  # docs/planner.md


def test_same_inputs_give_the_same_plan(plan):
    again = pb.plan_move(KIN, START, END, LIMITS)
    np.testing.assert_array_equal(again.intervals_s, plan.intervals_s)
    a = pb.pso_search(KIN, plan.nodes, LIMITS, particles=6, iterations=3, seed=4)
    b = pb.pso_search(KIN, plan.nodes, LIMITS, particles=6, iterations=3, seed=4)
    np.testing.assert_array_equal(a[0], b[0])
    assert a[1] == b[1] and a[1] >= plan.total_s


def test_the_platform_acceleration_is_the_second_derivative_of_fk(nodes):
    spline = pb.quintic_spline(nodes, PAPER_INTERVALS)
    t = np.linspace(0.05, 1.0, 7)
    step = 1e-4
    x = [KIN.point(spline(t + k * step)) for k in (-1, 0, 1)]
    xdd_fd = (x[0] - 2 * x[1] + x[2]) / step**2
    xyz, xd, xdd = KIN.platform_motion(spline(t), spline(t, nu=1), spline(t, nu=2))
    np.testing.assert_allclose(xyz, x[1], atol=1e-12)
    np.testing.assert_allclose(xd, (x[2] - x[0]) / (2 * step), atol=1e-6)
    np.testing.assert_allclose(xdd, xdd_fd, atol=1e-4)


def test_the_inverse_dynamics_balance_the_energy_of_a_rest_to_rest_move(nodes):
    """Eq. 9 is Lagrange's equation of its lumped model: the work of the joint torques over a
    move from rest to rest is the change of potential energy."""
    spline = pb.quintic_spline(nodes, PAPER_INTERVALS)
    ts, q, qd, qdd, _ = _dense(spline, 4000)
    power = np.sum(KIN.inverse_dynamics(q, qd, qdd) * qd, axis=-1)
    work = np.trapezoid(power, ts)
    m, g, l1 = KIN.masses, 9.81, KIN.geometry.upper_arm_m
    z = KIN.point(q)[:, 2]
    arm = l1 * (0.5 * m.upper_arm_kg + m.elbow_kg + 0.5 * m.forearm_kg) * g
    potential = (m.platform_kg + 1.5 * m.forearm_kg) * g * z - arm * np.sin(q).sum(axis=-1)
    assert work == pytest.approx(potential[-1] - potential[0], abs=1e-6)
    np.testing.assert_allclose(
        KIN.inverse_dynamics(q[:5], 0 * q[:5], 0 * q[:5]), KIN.gravity_torques(q[:5])
    )


def test_plan_move_prints_the_plan_and_writes_the_json(tmp_path, capsys):
    out = tmp_path / "move.json"
    argv = ["plan-move", str(PAPER_PATH), "--from", "200,200,-800", "--to", "250,-175,-800",
            "--set", "robot.kind=delta", "--json", str(out)]  # fmt: skip
    assert cli.main(argv) == 0
    printed = capsys.readouterr().out
    assert "binding limit: end-effector accel" in printed
    assert "spline / TOPP-RA" in printed
    data = json.loads(out.read_text())
    assert np.shape(data["nodes_deg"]) == (7, 3)
    assert len(data["intervals_s"]) == 6
    assert data["total_s"] == pytest.approx(sum(data["intervals_s"]))
    assert data["total_s"] < 1.05
    assert data["toppra_total_s"] <= data["total_s"]
    assert data["nodes_deg"][0] == pytest.approx([13.525, 26.639, 56.861], abs=1e-3)
    assert f"total_s {data['total_s']:.4f}" in printed
    assert math.isclose(data["peaks"]["ee_accel_m_s2"], 8.83, rel_tol=1e-6)


def test_plan_move_refuses_an_arm_without_limits_and_a_bad_point(capsys):
    argv = ["plan-move", str(PAPER_PATH), "--from", "200,200,-800", "--to", "250,-175,-800"]
    assert cli.main(argv) == 1
    assert "robot.kind=delta" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli.main(["plan-move", str(PAPER_PATH), "--from", "1,2", "--to", "250,-175,-800"])


def test_plan_move_with_exit_points_plans_nine_key_points(tmp_path, capsys):
    out = tmp_path / "move.json"
    argv = ["plan-move", "delta_refill", "--from", "200,200,-800", "--to", "250,-175,-800",
            "--exit-mm", "10", "--no-toppra", "--json", str(out)]  # fmt: skip
    assert cli.main(argv) == 0
    data = json.loads(out.read_text())
    assert np.shape(data["nodes_deg"]) == (9, 3) and len(data["intervals_s"]) == 8
    assert data["nodes_deg"][1][0] != data["nodes_deg"][0][0]  # 10 mm up: other joints
    assert 0.80 < data["total_s"] < 0.8215  # one more interval to use: a little shorter
    argv[argv.index("10")] = "200"
    assert cli.main(argv) == 1
    assert "--exit-mm" in capsys.readouterr().err


@pytest.mark.parametrize("count", [6, 8])
def test_the_batched_search_evaluations_are_the_reference_ones(count):
    """The search's vectorised evaluations (Hermite pieces, DeltaKinematics.torque_split, a
    batch of interval vectors at once) give what quintic_spline, exact_peaks, interval_usage
    and evaluate_intervals give, one vector at a time."""
    path = pb.PickPath(exit_m=0.01) if count == 8 else None
    nodes = pb.joint_nodes(KIN, pb.key_points(START, END, path))
    h = np.random.default_rng(count).uniform(0.05, 0.3, (5, count))
    coef, half = pb._hermite_pieces(nodes, h)
    usage, totals = pb._Evaluator(KIN, nodes, LIMITS)(h)
    for k in range(len(h)):
        ref, _, ref_half = pb._pieces(pb.quintic_spline(nodes, h[k]))
        np.testing.assert_allclose(coef[k], ref, rtol=0, atol=1e-12 * np.abs(ref).max())
        np.testing.assert_allclose(half[k], ref_half, rtol=1e-15)
        ref_usage = pb.interval_usage(KIN, nodes, h[k], LIMITS)
        np.testing.assert_allclose(usage[k], ref_usage, rtol=1e-9)
        assert totals[k] == pytest.approx(pb.evaluate_intervals(KIN, nodes, h[k], LIMITS), 1e-12)
    rng = np.random.default_rng(5)
    q, qd, qdd = (
        rng.uniform(0.1, 0.8, (50, 3)),
        rng.normal(0, 3, (50, 3)),
        rng.normal(0, 30, (50, 3)),
    )
    dyn, grav, xdd = KIN.torque_split(q, qd, qdd)
    np.testing.assert_allclose(dyn + grav, KIN.inverse_dynamics(q, qd, qdd), atol=1e-12)
    np.testing.assert_allclose(grav, KIN.gravity_torques(q), atol=1e-12)
    np.testing.assert_allclose(xdd, KIN.platform_motion(q, qd, qdd)[2], atol=1e-12)


def test_the_fast_peaks_are_the_exact_peaks():
    rng = np.random.default_rng(3)
    for m in (4, 5):  # acceleration (cubic) and speed (quartic) pieces
        p = rng.normal(size=(4000, m))
        p[:50, -1] *= 1e-9  # a vanishing leading coefficient
        np.testing.assert_allclose(pb._abs_peak_fast(p), pb._abs_peak(p), rtol=1e-13)
