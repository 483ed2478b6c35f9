"""A quintic B-spline transfer through taught via points under per-joint limits: the
five-bar's ``motion.planner = "bspline5"`` (docs/planner.md, "The five-bar").

The delta's planner (:mod:`transplanter.machine.planner_bspline`) builds its key points
itself (lift, arc, top, arc, descent: :class:`~transplanter.machine.planner_bspline.PickPath`)
and holds every joint to one speed and one acceleration limit. The five-bar's key points are
its taught points (the PGF's Algorithm 2: the lifted grip point, the retract point, the drop
point), and its joints differ in kind: two rotary arms (rad) and the lead-screw Z (m), each
with its own speed and acceleration limit. This module times the same quintic spline (the
planner's :func:`~transplanter.machine.planner_bspline.quintic_spline`: zero speed and
acceleration at both ends, exact per-interval peaks from its polynomial pieces) through any
two or more points under per-joint limits and the end effector's acceleration.

The search is the delta's idea without its constraints machinery: stretching every interval
by s divides joint speeds by s and joint and end-effector accelerations by s^2, so a shape
(the intervals up to a common factor) has a closed-form smallest feasible scale; the shape is
searched by Nelder-Mead on the log-ratios of the intervals (one to a few of them: the
five-bar's transfer has two intervals), from the shape whose intervals follow each node
step's time at the joint speed limits. The end effector's acceleration (FK's second
derivative along the spline, by central differences of the FK in the joints' direction) is
sampled on each interval during the search and refined by 400 samples an interval at the end.
Deterministic: same inputs, same bits.

Pure numpy/scipy (the firmware side).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from transplanter.machine.kinematics.base import Kinematics
from transplanter.machine.planner_bspline import (
    MovePlan,
    MoveRefused,
    exact_peaks,
    joint_nodes,
    quintic_spline,
)

__all__ = ["JointLimits", "plan_via_move", "via_usage"]

_SEARCH_SAMPLES = 24  # end-effector samples per interval during the search
_FINAL_SAMPLES = 400  # ... for the final plan's peak
_FD_STEP = 1e-4  # the central differences' step in the joints (rad or m)


@dataclass(frozen=True)
class JointLimits:
    """Per-joint limits in each joint's SI unit (rad/s and rad/s^2 for a rotary joint, m/s
    and m/s^2 for a slide), the end effector's acceleration (m/s^2; None leaves it out) and
    the motor torque of the first ``len(torque_nm)`` joints (N m, as the kinematics'
    ``inverse_dynamics`` gives it for those joints: the five-bar's arm motors at their
    shafts; None leaves it out). ``names`` name the joints in refusals and in the binding
    limit."""

    speed: tuple[float, ...]
    accel: tuple[float, ...]
    names: tuple[str, ...]
    ee_accel_m_s2: float | None = None
    torque_nm: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        n = len(self.names)
        for label in ("speed", "accel"):
            values = getattr(self, label)
            if len(values) != n:
                raise ValueError(
                    f"JointLimits.{label} needs one limit per joint ({n}), got {values!r}"
                )
            for name, value in zip(self.names, values, strict=True):
                if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                    raise ValueError(
                        f"JointLimits.{label} of {name} must be a positive number, got {value!r}"
                    )
        e = self.ee_accel_m_s2
        if e is not None and not (isinstance(e, int | float) and math.isfinite(e) and e > 0):
            raise ValueError(f"JointLimits.ee_accel_m_s2 must be positive or None, got {e!r}")
        tau = self.torque_nm
        if tau is not None and not (
            0 < len(tau) <= n
            and all(isinstance(v, int | float) and math.isfinite(v) and v > 0 for v in tau)
        ):
            raise ValueError(
                f"JointLimits.torque_nm must be positive torques of the first 1-{n} joints or "
                f"None, got {tau!r}"
            )


def _ee_accel(kinematics: Kinematics, q, qd, qdd) -> np.ndarray:
    """(..., 3) end-effector acceleration at joint states: J qdd + qd^T H qd (H the FK's
    second derivative), both from central differences of the FK along qdd's direction and
    along qd's, each with a step of ``_FD_STEP`` in the joints."""

    def along(v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        norm = np.linalg.norm(v, axis=-1, keepdims=True)
        eps = _FD_STEP / np.where(norm > 0.0, norm, 1.0)
        plus, minus = kinematics.point(q + eps * v), kinematics.point(q - eps * v)
        return plus, minus, eps

    plus, minus, eps = along(qdd)
    first = (plus - minus) / (2.0 * eps)
    plus, minus, eps = along(qd)
    second = (plus - 2.0 * kinematics.point(q) + minus) / (eps * eps)
    return first + second


def _samples(spline, per_interval: int) -> np.ndarray:
    """(intervals, per_interval) sample times inside each interval, ends included."""
    tn = np.asarray(spline.t[5:-5], dtype=np.float64)
    u = np.linspace(0.0, 1.0, per_interval)
    return tn[:-1, None] + (tn[1:] - tn[:-1])[:, None] * u[None, :]


def _ee_peaks(kinematics: Kinematics, spline, per_interval: int) -> np.ndarray:
    """(intervals,) the largest sampled end-effector acceleration of each interval."""
    ts = _samples(spline, per_interval)
    xdd = _ee_accel(kinematics, spline(ts), spline(ts, nu=1), spline(ts, nu=2))
    return np.linalg.norm(xdd, axis=-1).max(axis=1)


def _torque_peaks(kinematics: Kinematics, spline, per_interval: int, joints: int) -> np.ndarray:
    """(intervals, joints) the largest sampled |torque| of each interval of the first
    ``joints`` joints (the kinematics' ``inverse_dynamics``)."""
    ts = _samples(spline, per_interval)
    q, qd, qdd = (spline(ts, nu=k)[..., :joints] for k in (0, 1, 2))
    return np.abs(kinematics.inverse_dynamics(q, qd, qdd)).max(axis=1)


def via_usage(kinematics: Kinematics, nodes, intervals, limits: JointLimits, samples: int):
    """(speed (intervals, n), accel (intervals, n), ee (intervals,), torque (intervals, k)):
    each interval's peak over its limit at the intervals as given (1 = at the limit; ee 0
    without its limit; torque (intervals, 0) without its limits)."""
    spline = quintic_spline(nodes, intervals)
    peaks = exact_peaks(spline)
    speed = peaks["speed"] / np.asarray(limits.speed)
    accel = peaks["accel"] / np.asarray(limits.accel)
    ee = np.zeros(len(intervals))
    if limits.ee_accel_m_s2 is not None:
        ee = _ee_peaks(kinematics, spline, samples) / limits.ee_accel_m_s2
    torque = np.zeros((len(intervals), 0))
    if limits.torque_nm is not None:
        k = len(limits.torque_nm)
        torque = _torque_peaks(kinematics, spline, samples, k) / np.asarray(limits.torque_nm)
    return speed, accel, ee, torque


def _scale(kinematics, nodes, h, limits, samples) -> tuple[str, float]:
    """(binding limit, smallest scale s) of the shape h: the joint speed usage scales as
    1/s, the accelerations' and the torques' as 1/s^2 (the torque has no static part: the
    five-bar's arms turn in a horizontal plane). A torque that is not finite (a sample at a
    singular pose) is refused naming the joint torque."""
    speed, accel, ee, torque = via_usage(kinematics, nodes, h, limits, samples)
    candidates = []
    for j, name in enumerate(limits.names):
        candidates.append((f"joint speed ({name})", float(speed[:, j].max())))
        candidates.append((f"joint acceleration ({name})", math.sqrt(float(accel[:, j].max()))))
    if limits.ee_accel_m_s2 is not None:
        candidates.append(("end-effector acceleration", math.sqrt(float(ee.max()))))
    for j in range(torque.shape[1]):
        usage = float(torque[:, j].max())
        if not math.isfinite(usage):
            raise MoveRefused(
                "joint torque",
                f"the {limits.names[j]} motor's torque along the spline is not finite (a "
                "sample at a singular pose); move the via points away from the singularity",
            )
        candidates.append((f"joint torque ({limits.names[j]})", math.sqrt(usage)))
    return max(candidates, key=lambda c: c[1])


def _check_windows(kinematics: Kinematics, nodes, intervals) -> None:
    """MoveRefused naming the joint when the spline leaves an axis's window between the
    nodes by more than half a step of its drive (200 samples an interval)."""
    spline = quintic_spline(nodes, intervals)
    q = spline(_samples(spline, 200).ravel())
    for i, axis in enumerate(kinematics.axes):
        lo, hi = axis.window
        low, high = float(q[:, i].min()), float(q[:, i].max())
        tolerance = 0.5 * axis.drive.unit_per_step
        if low < lo - tolerance or high > hi + tolerance:
            worst = low if low < lo else high
            unit, k = ("mm", 1e3) if axis.linear else ("deg", math.degrees(1.0))
            raise MoveRefused(
                "joint window",
                f"the spline takes {axis.name} to {worst * k:.3f} {unit}, outside "
                f"[{lo * k:g}, {hi * k:g}] {unit}, between the via points; move the taught "
                "points away from the axis's limit or use motion.planner = 'lines'",
            )


def plan_via_move(
    kinematics: Kinematics,
    points,
    limits: JointLimits,
    xatol: float = 1e-4,
    max_evaluations: int = 400,
) -> MovePlan:
    """The shortest quintic-spline move through the (k, 3) ``points`` (m; k >= 2, the first
    the start, the last the target) under ``limits`` (module docstring). ``xatol``: the
    search's tolerance on the log-ratios of the intervals. MoveRefused when a point is out
    of reach (``reach``), two consecutive points coincide (``path``) or the spline leaves an
    axis's window (``joint window``)."""
    started = time.perf_counter()
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3 or pts.shape[0] < 2 or not np.isfinite(pts).all():
        raise ValueError(f"a via move needs two or more finite (x, y, z) points, got {points!r}")
    steps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if (steps < 1e-6).any():
        i = int(np.flatnonzero(steps < 1e-6)[0])
        raise MoveRefused(
            "path", f"via points {i} and {i + 1} are less than 1 um apart: drop one of them"
        )
    nodes = joint_nodes(kinematics, pts)
    count = nodes.shape[0] - 1
    # the start shape: each node step's time at the joint speed limits (the slowest joint)
    dq = np.abs(np.diff(nodes, axis=0)) / np.asarray(limits.speed)
    h0 = np.maximum(dq.max(axis=1), 1e-3 * max(float(dq.max()), 1e-9))
    evaluations = [0]
    history: list[tuple[int, float]] = []

    def total(h: np.ndarray) -> float:
        evaluations[0] += 1
        value = float(h.sum()) * _scale(kinematics, nodes, h, limits, _SEARCH_SAMPLES)[1]
        best = min(value, history[-1][1]) if history else value
        history.append((evaluations[0], best))
        return value

    def shape(x: np.ndarray) -> np.ndarray:
        return h0 * np.exp(np.append(x, 0.0))

    if count > 1:
        x0 = np.zeros(count - 1)
        res = minimize(
            lambda x: total(shape(x)), x0, method="Nelder-Mead",
            options={"xatol": xatol, "fatol": 1e-7, "maxfev": max_evaluations,
                     "initial_simplex": np.vstack([x0, x0 + 0.3 * np.eye(count - 1)])},
        )  # fmt: skip
        h = shape(np.asarray(res.x))
        if total(h) > total(h0):  # never worse than the start
            h = h0
    else:
        h = h0
    binding, s = _scale(kinematics, nodes, h, limits, _FINAL_SAMPLES)
    intervals = h * s * (1.0 + 1e-9)
    _check_windows(kinematics, nodes, intervals)
    history.append((evaluations[0], float(intervals.sum())))
    spline = quintic_spline(nodes, intervals)
    peaks = exact_peaks(spline)
    if limits.ee_accel_m_s2 is not None:
        peaks["ee_accel"] = _ee_peaks(kinematics, spline, _FINAL_SAMPLES)
    if limits.torque_nm is not None:
        peaks["torque"] = _torque_peaks(kinematics, spline, _FINAL_SAMPLES, len(limits.torque_nm))
    return MovePlan(
        points_m=pts,
        nodes=nodes,
        intervals_s=intervals,
        binding=binding,
        peaks=peaks,
        evaluations=evaluations[0],
        history=np.asarray(history),
        planning_s=time.perf_counter() - started,
    )
