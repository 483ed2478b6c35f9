"""A pick-and-place move executed as the controller runs it: the quintic B-spline of
:mod:`transplanter.machine.planner_bspline` sampled at the controller's point rate and turned
into step (pulse) events, the same :class:`~transplanter.machine.motion.PlannedMove` a
straight line becomes, so the SGF runs it like any other move (``motion.planner =
"bspline5"``: a ``G0`` is a transfer along the planned spline, ``G1`` stays a straight line).

The spline is planned in joint space through the key points of the move (lift, arc, top,
arc, descent; Zhao et al. 2022, Sec. 2.4) for the shortest time under the arm's joint speed,
acceleration and torque limits and the end effector's acceleration limit. The controller then
samples its time law every ``compute_time_per_point_s`` (the controller computes one point per
that period, as it solves one IK point per period on a line), checks every sample through the
arm's reach and conditioning check (FK of the sampled joints, then ``Kinematics.check``: the
same refusals as a line's points), and spreads each motor's steps between two samples evenly
inside that period. Nothing is emitted unless every point passes.

An arm with via transfers (the five-bar, ``transfer_path = "via"``) has no pick path: its
spline passes the points its host sent (:func:`plan_via_transfer`,
:mod:`transplanter.machine.planner_via`), timed under its per-joint limits.

Pure numpy/scipy (the firmware side).
"""

from __future__ import annotations

import math

import numpy as np

from transplanter.machine.kinematics import Kinematics, UnreachableError
from transplanter.machine.motion import (
    MAX_STEPS_PER_MOVE,
    MotionConfig,
    PlannedMove,
    step_events,
)
from transplanter.machine.planner_bspline import MoveLimits, MovePlan, PickPath, plan_move
from transplanter.machine.planner_via import JointLimits, plan_via_move
from transplanter.units import M_PER_MM, show

__all__ = [
    "PLAN_TOLERANCE_S",
    "plan_spline_move",
    "plan_via_transfer",
    "sample_plan",
    "spline_limits",
    "via_transfers",
]

PLAN_TOLERANCE_S = 1e-4
"""The search's tolerance on a transfer's total time (a tenth of a millisecond; the planner's
default 1e-7 s is for the benchmark against the paper, and costs half again the time)."""


def spline_limits(kinematics: Kinematics, config: MotionConfig) -> MoveLimits | JointLimits:
    """The limits a spline move is planned under: the arm's declared joint speed,
    acceleration (and torque, where it has inverse dynamics) and ``config``'s end-effector
    acceleration; per joint (``JointLimits``) for an arm with via transfers (the five-bar's
    ``joint_speed_limits``, ``joint_accel_limits``, its arm motors' ``arm_torque_limit_nm``
    where it declares one (ValueError if it has no ``masses`` to plan it with), and
    ``config.carry_accel_limit_m_s2`` for the end effector where it is given). ValueError
    naming what is missing when the arm declares no joint limits (a spline's time law is only
    defined against them)."""
    if via_transfers(kinematics):
        _check_step_rates(kinematics)
        carry = config.carry_accel_limit_m_s2
        torque = getattr(kinematics, "arm_torque_limit_nm", None)
        if torque is not None and getattr(kinematics, "masses", None) is None:
            raise ValueError(
                f"motion.planner = 'bspline5': the {kinematics.kind!r} arm's torque limit "
                f"({torque:g} N m, drives.arm_torque_limit_nm) needs its dynamics model, and "
                "this arm has none (its masses are None)"
            )
        return JointLimits(
            speed=tuple(kinematics.joint_speed_limits),
            accel=tuple(kinematics.joint_accel_limits),
            names=tuple(axis.name for axis in kinematics.axes),
            ee_accel_m_s2=config.ee_accel_limit_m_s2 if carry is None else carry,
            torque_nm=None if torque is None else (float(torque),) * 2,
        )
    missing = [
        name
        for name in ("max_joint_speed_rad_s", "max_joint_accel_rad_s2")
        if getattr(kinematics, name, None) is None
    ]
    if missing:
        raise ValueError(
            f"motion.planner = 'bspline5' times a move against the arm's joint limits, and "
            f"the {kinematics.kind!r} arm declares no {' or '.join(missing)}; use "
            "motion.planner = 'lines' for it"
        )
    return MoveLimits.of(kinematics, config.ee_accel_limit_m_s2)


def _check_step_rates(kinematics: Kinematics) -> None:
    """ValueError naming the joint whose declared speed limit is above what its drive can
    step at its ``max_step_rate_hz`` (a spline's pulses are not capped as a line's are)."""
    for axis, limit in zip(kinematics.axes, kinematics.joint_speed_limits, strict=True):
        drive = axis.drive
        cap = drive.max_step_rate_hz / drive.steps_per_unit
        unit, k = ("mm/s", 1e3) if drive.linear else ("deg/s", math.degrees(1.0))
        if limit > cap * (1.0 + 1e-12):
            raise ValueError(
                f"motion.planner = 'bspline5': the {axis.name} joint's speed limit "
                f"{limit * k:g} {unit} is above the {cap * k:.4g} {unit} its drive can step at "
                f"{drive.max_step_rate_hz:g} Hz; lower its speed limit to at most "
                f"{cap * k:.4g} {unit} (the five-bar's drives.arm_speed_limit_deg_s, "
                "drives.z_speed_limit_mm_s)"
            )


def via_transfers(kinematics: Kinematics) -> bool:
    """Whether the arm's ``bspline5`` transfer goes through via points the host sends
    (``M720``; the five-bar's taught points) rather than the delta's pick path."""
    return getattr(kinematics, "transfer_path", "pick") == "via"


def plan_spline_move(
    start_steps,
    start_xyz,
    end_xyz,
    kinematics: Kinematics,
    config: MotionConfig,
) -> PlannedMove:
    """Plan the spline transfer from ``start_xyz`` to ``end_xyz`` (m) and sample it into step
    events (module docstring; the plan kept: `_kept_plan`). Raises
    ``planner_bspline.MoveRefused`` (its ``limit`` named)
    when no timing meets a limit or a key point is out of reach, UnreachableError naming the
    first sampled point the arm's check refuses, ValueError for a move with too many steps.
    Steps needed to go from ``start_steps`` to the first sample are part of the first
    period."""
    limits = spline_limits(kinematics, config)
    start = np.asarray(start_xyz, dtype=np.float64)
    end = np.asarray(end_xyz, dtype=np.float64)
    path = PickPath(
        lift_m=config.pick_lift_m, radius_m=config.pick_arc_m, exit_m=config.pick_exit_m
    )
    key = ("pick", start.tobytes(), end.tobytes(), repr(path), repr(limits), repr(kinematics))
    plan = _kept_plan(
        key, lambda: plan_move(kinematics, start, end, limits, path=path, ftol=PLAN_TOLERANCE_S)
    )
    return sample_plan(plan, start_steps, start, end, kinematics, config)


_PLANS: dict[tuple, MovePlan] = {}
_CACHE_SIZE = 256


def _kept_plan(key: tuple, make) -> MovePlan:
    """The plan of `key` (every input of a plan: its points, path, limits and kinematics)
    made by `make()` once and kept, the last 256 distinct keys: a plan is a pure function of
    them, so a kept one is the same bits. The moves of a job repeat (the five-bar's taught
    transfers every cycle, the delta's pick-to-tube transfer of each pickup column every
    row), and a time-optimal plan costs about 0.3 s of SLSQP."""
    plan = _PLANS.get(key)
    if plan is None:
        plan = make()
        if len(_PLANS) >= _CACHE_SIZE:
            _PLANS.pop(next(iter(_PLANS)))
        _PLANS[key] = plan
    return plan


def plan_via_transfer(
    start_steps, points, kinematics: Kinematics, config: MotionConfig
) -> PlannedMove:
    """The spline through the (k, 3) ``points`` (m: where the arm is, the via points, the
    target), timed by :func:`planner_via.plan_via_move` under the arm's per-joint limits and
    the end effector's, sampled as :func:`plan_spline_move` samples (the plan kept:
    `_kept_plan`)."""
    limits = spline_limits(kinematics, config)
    pts = np.asarray(points, dtype=np.float64)
    key = ("via", pts.tobytes(), pts.shape, repr(limits), repr(kinematics))
    plan = _kept_plan(key, lambda: plan_via_move(kinematics, pts, limits))
    return sample_plan(plan, start_steps, pts[0], pts[-1], kinematics, config)


def sample_plan(
    plan: MovePlan, start_steps, start, end, kinematics: Kinematics, config: MotionConfig
) -> PlannedMove:
    """A plan's time law sampled every ``compute_time_per_point_s``, every sample through
    the arm's check, and turned into step events (module docstring)."""
    spline = plan.spline()
    duration = plan.total_s
    period = config.compute_time_per_point_s
    n = max(int(math.ceil(duration / period)), 1)
    t = np.minimum(np.arange(n + 1, dtype=np.float64) * period, duration)
    joints = np.asarray(spline(t), dtype=np.float64)
    joints[0], joints[-1] = plan.nodes[0], plan.nodes[-1]
    points = np.asarray(kinematics.point(joints), dtype=np.float64)
    points[0], points[-1] = start, end
    report = kinematics.check(points)
    if not report.ok.all():
        i = int(report.failing[0])
        shown = ", ".join(show(v / M_PER_MM) for v in points[i])
        raise UnreachableError(
            i,
            report.refusals[i],
            f"spline point {i} of {n + 1} at t = {t[i]:.4f} s, ({shown}) mm: {report.reasons[i]}",
        )
    drives = kinematics.drives
    point_steps = np.column_stack([d.to_steps(joints[:, m]) for m, d in enumerate(drives)])
    start_counts = np.asarray(start_steps, dtype=np.int64)
    deltas = np.diff(point_steps, axis=0)
    deltas[0] = point_steps[1] - start_counts
    if int(np.abs(deltas).sum()) > MAX_STEPS_PER_MOVE:
        raise ValueError(
            f"the spline move needs {int(np.abs(deltas).sum())} step pulses, more than "
            f"{MAX_STEPS_PER_MOVE} a move"
        )
    times, dirs = step_events(deltas, t)
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    speeds = seg / np.maximum(np.diff(t), 1e-12)
    return PlannedMove(
        start_xyz=start,
        end_xyz=end,
        points_xyz=points,
        point_times_s=t,
        joint_positions=joints,
        point_steps=point_steps,
        step_times=times,
        step_dirs=dirs,
        start_steps=start_counts,
        end_steps=point_steps[-1].copy(),
        duration_s=float(duration),
        peak_speed_m_s=float(speeds.max(initial=0.0)),
        path_m=np.concatenate([[0.0], np.cumsum(seg)]),
        spline_plan=plan,
    )
