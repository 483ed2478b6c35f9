"""Straight-line moves as step events (paper section 2.4).

A move from the current position to a G-code target is interpolated as a 3D Bresenham line on
a grid of ``resolution_m``; every point is checked against the arm's kinematic limits (any
:class:`~transplanter.machine.kinematics.Kinematics`) before anything is produced, then solved
by its IK all at once. Absolute target step counts per point come from
the drives, so steps never drift. A speed profile along the path (trapezoid or S-curve, with
acceleration at the start and deceleration at the end) gives every point a time, and each
motor's steps between two points are spread evenly inside that segment's time interval.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from transplanter.machine.kinematics import Kinematics, UnreachableError
from transplanter.machine.steppers import count_at, step_counts
from transplanter.units import M_PER_MM, show

PROFILES = ("trapezoid", "scurve")
PLANNERS = ("lines", "bspline5")
"""How G0 moves: ``lines`` straight (the five-bar paper's firmware), ``bspline5`` along the
quintic B-spline pick path (``machine.spline_motion``)."""

MAX_POINTS_PER_MOVE = 1_000_000
"""Most interpolated points one move may have (100 m at the 0.1 mm default grid): a move
needing more is refused before anything is built, so memory per move stays bounded."""
_TARGET_FIRST_POINTS = 4096
"""Moves of at least this many grid points get their target checked before interpolation."""
MAX_STEPS_PER_MOVE = 4_000_000
"""Most step pulses (all motors) one move may emit; each costs 9 bytes of event arrays and
a few temporaries, so this bounds a move's memory to well under a GiB."""


@dataclass(frozen=True)
class MotionConfig:
    """Interpolation and speed-profile settings of the SGF (SI units)."""

    resolution_m: float = 1e-4
    """Bresenham grid spacing: the straight line is approximated to within about this."""
    accel_m_s2: float = 2.0
    """Path acceleration (and deceleration); for 'scurve' the peak acceleration."""
    profile: str = "trapezoid"
    """'trapezoid': constant acceleration ramps. 'scurve': the velocity follows a cubic
    smoothstep in time, v = v0 + (v1 - v0)(3u^2 - 2u^3), u = t/T, with T = 1.5 (v1 - v0)/accel
    so the peak acceleration equals accel_m_s2 at mid-ramp and the acceleration starts and ends
    at zero (jerk 8/3 accel^2/(v1 - v0) at the ramp ends)."""
    compute_time_per_point_s: float = 198e-6
    """IK time per point (paper Table 3: 198 us ESP32 dual core, 276 us single core, 4027 us
    Arduino Mega): at most 1/this points per second, so path speed <= resolution / this."""
    min_speed_m_s: float = 0.002
    """Start and stop speed of every move."""
    planner: str = "lines"
    """``lines``: G0 and G1 are straight lines. ``bspline5``: a G0 is a pick-and-place transfer
    along the time-optimal quintic B-spline through the pick path's key points (the delta)
    or the ``M720`` via points before it (the five-bar) (``machine.spline_motion``); G1 stays
    a straight line."""
    ee_accel_limit_m_s2: float = 8.83
    """The end effector's acceleration limit of a ``bspline5`` move (an estimate:
    ``planner_bspline.EE_ACCEL_LIMIT_M_S2``)."""
    pick_lift_m: float = 0.100
    """A ``bspline5`` transfer's vertical lift and descent (the paper's 100 mm)."""
    pick_arc_m: float = 0.050
    """A ``bspline5`` transfer's arc radius at the top of the lift (the paper's 50 mm)."""
    pick_exit_m: float = 0.0
    """0: a ``bspline5`` transfer through the paper's seven key points; above 0, with a key
    point this high straight above each end (``planner_bspline.PickPath.exit_m``)."""
    carry_accel_limit_m_s2: float | None = None
    """The end effector's acceleration limit of a ``bspline5`` transfer on an arm with via
    transfers (the five-bar: its jaws carry the seedling; ``[gripper]
    carry_accel_limit_mm_s2``); None: ``ee_accel_limit_m_s2``."""

    def __post_init__(self) -> None:
        for name in (
            "resolution_m",
            "accel_m_s2",
            "compute_time_per_point_s",
            "ee_accel_limit_m_s2",
            "pick_lift_m",
            "pick_arc_m",
        ):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"MotionConfig.{name} must be a positive number, got {value!r}")
        if not (
            isinstance(self.min_speed_m_s, int | float)
            and math.isfinite(self.min_speed_m_s)
            and self.min_speed_m_s >= 0
        ):
            raise ValueError(f"MotionConfig.min_speed_m_s must be >= 0, got {self.min_speed_m_s!r}")
        carry = self.carry_accel_limit_m_s2
        if carry is not None and not (
            isinstance(carry, int | float) and math.isfinite(carry) and carry > 0
        ):
            raise ValueError(
                f"MotionConfig.carry_accel_limit_m_s2 must be a positive number or None, "
                f"got {carry!r}"
            )
        if not (math.isfinite(self.pick_exit_m) and 0.0 <= self.pick_exit_m < self.pick_lift_m):
            raise ValueError(
                f"MotionConfig.pick_exit_m must be in [0, pick_lift_m = {self.pick_lift_m:g}) m, "
                f"got {self.pick_exit_m!r}"
            )
        if self.planner not in PLANNERS:
            raise ValueError(
                f"MotionConfig.planner must be one of {PLANNERS}, got {self.planner!r}"
            )
        if self.profile not in PROFILES:
            raise ValueError(
                f"MotionConfig.profile must be one of {PROFILES}, got {self.profile!r}"
            )

    @property
    def point_rate_speed_cap_m_s(self) -> float:
        """Fastest path speed the IK compute time allows (one point per grid step)."""
        return self.resolution_m / self.compute_time_per_point_s


def bresenham_3d(start_idx, end_idx) -> np.ndarray:
    """Grid points of the classic 3D Bresenham line, start and end included, shape (N, 3).

    The dominant axis (largest |delta|, first on ties) advances by one every point; another
    axis with |delta| = a after i points has moved floor((2 i a + d) / (2 d)) cells, d being
    the dominant |delta|: exactly what the error-accumulator loop (step when the error term
    2 i a - (2 k + 1) d >= 0) produces, computed in closed form with integers.
    """
    start = np.asarray(start_idx)
    end = np.asarray(end_idx)
    for name, arr in (("start_idx", start), ("end_idx", end)):
        if arr.shape != (3,) or not np.issubdtype(arr.dtype, np.integer):
            raise ValueError(f"bresenham_3d: {name} must be 3 integers, got {arr!r}")
    start = start.astype(np.int64)
    delta = end.astype(np.int64) - start
    length = np.abs(delta)
    major = int(length.max())
    if major == 0:
        return start[None, :].copy()
    i = np.arange(major + 1, dtype=np.int64)[:, None]
    offsets = (2 * i * length[None, :] + major) // (2 * major)
    return start[None, :] + np.sign(delta)[None, :] * offsets


@dataclass
class PlannedMove:
    """A planned move (a straight line, or a sampled spline transfer): points, joint targets and
    step events of the arm's motors."""

    start_xyz: np.ndarray
    """(3,) m, where the move starts."""
    end_xyz: np.ndarray
    """(3,) m, the target."""
    points_xyz: np.ndarray
    """(N, 3) m, interpolated points (first = start, last = target, exact)."""
    point_times_s: np.ndarray
    """(N,) s from move start at which each point is reached."""
    joint_positions: np.ndarray
    """(N, n_axes) joint positions at each point (the five-bar: theta1, theta2 in rad, z in m)."""
    point_steps: np.ndarray
    """(N, n_axes) int64 absolute motor steps at each point (to_steps of joint_positions)."""
    step_times: tuple[np.ndarray, ...]
    """Per motor, sorted float64 step pulse times (s from move start)."""
    step_dirs: tuple[np.ndarray, ...]
    """Per motor, int8 +1/-1 direction of each pulse."""
    start_steps: np.ndarray
    """(n_axes,) int64 step counters before the move."""
    end_steps: np.ndarray
    """(n_axes,) int64 step counters after the move (= point_steps[-1])."""
    duration_s: float
    peak_speed_m_s: float
    path_m: np.ndarray | None = None
    """(N,) m, distance along the straight line from the start at each point."""
    speed_limit: str = ""
    """Why the move cruises slower than it was asked to (a motor's top step rate, the IK's
    compute time per point); empty when it cruises at the requested speed."""
    cruise_speed_m_s: float = math.nan
    """The speed the move cruises at where it is long enough to reach it (m/s)."""
    spline_plan: object | None = None
    """The ``planner_bspline.MovePlan`` a ``bspline5`` transfer samples; None for a line."""

    _counts: tuple[np.ndarray, ...] | None = field(
        default=None, init=False, repr=False, compare=False
    )

    def steps_at(self, t) -> np.ndarray:
        """Step counters of the motors at times t (s from move start), shape (len(t), n_axes).

        A step counts once t >= its time. The cumulative counts are built on the first call,
        so calling this at every physics step costs one binary search per motor.
        """
        n = len(self.step_times)
        if self._counts is None:
            self._counts = tuple(
                step_counts(self.step_dirs[m], self.start_steps[m]) for m in range(n)
            )
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        return np.stack(
            [count_at(t, self.step_times[m], self._counts[m]) for m in range(n)], axis=-1
        )

    @property
    def num_steps(self) -> int:
        """Total number of step pulses of all motors."""
        return int(sum(times.size for times in self.step_times))


def _vector3(value, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (3,) or not np.isfinite(arr).all():
        raise ValueError(f"plan_line: {name} must be 3 finite coordinates in m, got {value!r}")
    return arr


def _start_steps(value, n: int) -> np.ndarray:
    arr = np.asarray(value)
    if arr.shape != (n,) or not (
        np.issubdtype(arr.dtype, np.integer)
        or (np.issubdtype(arr.dtype, np.floating) and np.all(arr == np.round(arr)))
    ):
        raise ValueError(f"plan_line: start_steps must be {n} integer step counts, got {value!r}")
    return arr.astype(np.int64)


def _ramp(v0: float, v1: float, accel: float, profile: str) -> tuple[float, float]:
    """Duration and distance of a speed ramp from v0 up to v1."""
    if v1 <= v0:
        return 0.0, 0.0
    if profile == "trapezoid":
        duration = (v1 - v0) / accel
    else:
        duration = 1.5 * (v1 - v0) / accel
    return duration, 0.5 * (v0 + v1) * duration


def _ramp_time(s: np.ndarray, v0: float, v1: float, accel: float, profile: str) -> np.ndarray:
    """Time to cover distance s (0 <= s <= ramp distance) on the ramp from v0 to v1."""
    if profile == "trapezoid":
        root = np.sqrt(v0 * v0 + 2.0 * accel * s)
        with np.errstate(invalid="ignore", divide="ignore"):
            t = 2.0 * s / (v0 + root)  # (root - v0)/a without cancellation
        return np.where(s > 0.0, t, 0.0)
    duration, _ = _ramp(v0, v1, accel, profile)
    dv = v1 - v0
    lo = np.zeros_like(s)
    hi = np.full_like(s, duration)
    for _ in range(64):  # bisection: s(tau) is increasing; 64 halvings reach float precision
        mid = 0.5 * (lo + hi)
        u = mid / duration
        s_mid = v0 * mid + dv * duration * u**3 * (1.0 - 0.5 * u)
        below = s_mid < s
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
    return 0.5 * (lo + hi)


def _profile_times(
    s: np.ndarray, v_edge: float, v_cruise: float, config: MotionConfig
) -> tuple[np.ndarray, float]:
    """Time of each arc-length s (s[0] = 0, s[-1] = total); returns (times, peak speed)."""
    total = float(s[-1])
    accel, profile = config.accel_m_s2, config.profile
    ramp_t, ramp_s = _ramp(v_edge, v_cruise, accel, profile)
    v_peak = v_cruise
    if 2.0 * ramp_s > total:  # too short to reach cruise: triangular profile
        gain = 1.0 if profile == "trapezoid" else 1.0 / 1.5
        v_peak = min(v_cruise, math.sqrt(v_edge * v_edge + gain * accel * total))
        ramp_t, _ = _ramp(v_edge, v_peak, accel, profile)
        ramp_s = 0.5 * total
    duration = 2.0 * ramp_t + (total - 2.0 * ramp_s) / v_peak
    t = ramp_t + (s - ramp_s) / v_peak
    if ramp_s > 0.0:
        accel_part = np.flatnonzero(s <= ramp_s)
        decel_part = np.flatnonzero(s >= total - ramp_s)
        t[accel_part] = _ramp_time(s[accel_part], v_edge, v_peak, accel, profile)
        from_end = np.minimum(total - s[decel_part], ramp_s)
        t[decel_part] = duration - _ramp_time(from_end, v_edge, v_peak, accel, profile)
    t[0] = 0.0
    t[-1] = duration
    return t, v_peak


def step_events(
    deltas: np.ndarray, t: np.ndarray
) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]:
    """Spread each segment's |delta| steps evenly in its interval; the last lands on its end."""
    times, dirs = [], []
    dt = np.diff(t)
    seg_ids = np.arange(deltas.shape[0])
    for m in range(deltas.shape[1]):
        count = np.abs(deltas[:, m])
        seg = np.repeat(seg_ids, count)
        first = np.cumsum(count) - count
        j = np.arange(seg.size, dtype=np.int64) - np.repeat(first, count) + 1
        n = count[seg]
        t_end = t[seg + 1]
        step_t = np.minimum(t[seg] + dt[seg] * (j / n), t_end)
        step_t = np.where(j == n, t_end, step_t)
        times.append(step_t)
        dirs.append(np.repeat(np.sign(deltas[:, m]).astype(np.int8), count))
    return tuple(times), tuple(dirs)


def _refusal(start, end, index: int, count: int, point, reason: str) -> str:
    a, b, p = (", ".join(show(v / M_PER_MM) for v in xyz) for xyz in (start, end, point))
    return (
        f"move from ({a}) mm to ({b}) mm rejected before any step: point {index} of {count} "
        f"at ({p}) mm is not reachable: {reason}"
    )


def plan_line(
    start_steps,
    start_xyz,
    end_xyz,
    speed_m_s: float,
    kinematics: Kinematics,
    config: MotionConfig,
) -> PlannedMove:
    """Plan a straight 3D move of ``kinematics``' arm from start_xyz to end_xyz (m) at up to
    speed_m_s.

    Raises UnreachableError (naming the point, its coordinates in mm and its typed refusals)
    if any interpolated point violates a limit; nothing is planned then. Steps needed to go from
    start_steps to the first point (start_xyz's IK) are part of the first segment.
    Cruise speed = min(speed_m_s, the speed at which the busiest motor reaches its
    max_step_rate_hz, resolution / compute_time_per_point_s).
    """
    if not isinstance(kinematics, Kinematics):
        raise ValueError(f"plan_line: kinematics must be a Kinematics, got {kinematics!r}")
    drives = kinematics.drives
    n = len(drives)
    start_counts = _start_steps(start_steps, n)
    start = _vector3(start_xyz, "start_xyz")
    end = _vector3(end_xyz, "end_xyz")
    if not (isinstance(speed_m_s, int | float | np.floating) and math.isfinite(speed_m_s)):
        raise ValueError(f"plan_line: speed_m_s must be a finite number, got {speed_m_s!r}")
    if speed_m_s <= 0:
        raise ValueError(f"plan_line: speed_m_s must be > 0, got {speed_m_s!r}")
    res = config.resolution_m

    # A long move's target first, before any interpolation: a far-away target is refused
    # at once (no Bresenham line of 10^9 points is built to find its first bad point).
    # A short move is checked point by point below, which names its first bad point.
    start_idx = np.rint(start / res)
    end_idx = np.rint(end / res)
    major = float(np.max(np.abs(end_idx - start_idx)))
    if major >= _TARGET_FIRST_POINTS:
        try:
            kinematics.require(end[None, :])
        except UnreachableError as err:
            last = int(min(major, 2.0**62))
            raise UnreachableError(
                last, err.refusals, _refusal(start, end, last, last + 1, end, err.reason)
            ) from None
    if major + 1 > MAX_POINTS_PER_MOVE:
        raise ValueError(
            f"plan_line: the move needs {show(major + 1, 0)} interpolated points at "
            f"{res / M_PER_MM:g} mm, more than {MAX_POINTS_PER_MOVE}; split it or coarsen "
            "the resolution"
        )

    if np.array_equal(start, end):
        points = start[None, :].copy()
        line_param = np.zeros(1)
    else:
        grid = bresenham_3d(start_idx.astype(np.int64), end_idx.astype(np.int64))
        if grid.shape[0] < 2:
            points = np.stack([start, end])
            line_param = np.array([0.0, 1.0])
        else:
            points = grid * res
            # The dominant axis advances one cell per point: its progress is the point's
            # parameter along the ideal line.
            dom = int(np.argmax(np.abs(grid[-1] - grid[0])))
            line_param = (grid[:, dom] - grid[0, dom]) / (grid[-1, dom] - grid[0, dom])
            # Z follows the exact line height (on the five-bar its lead screw needs no IK),
            # so its steps (400 per mm) are spread evenly instead of bunching 40 at a time at
            # each grid step.
            points[:, 2] = start[2] + line_param * (end[2] - start[2])
            points[0] = start
            points[-1] = end

    try:
        joints = kinematics.require(points)
    except UnreachableError as err:
        message = _refusal(start, end, err.index, points.shape[0], points[err.index], err.reason)
        raise UnreachableError(err.index, err.refusals, message) from None

    point_steps = np.column_stack([drives[m].to_steps(joints[:, m]) for m in range(n)])
    steps_needed = int(np.abs(np.diff(point_steps, axis=0)).sum()) + int(
        np.abs(point_steps[0] - start_counts).sum()
    )
    if steps_needed > MAX_STEPS_PER_MOVE:
        raise ValueError(
            f"plan_line: the move needs {steps_needed} step pulses, more than "
            f"{MAX_STEPS_PER_MOVE} a move; split it or use fewer microsteps per unit"
        )
    rates = np.array([d.max_step_rate_hz for d in drives])

    if points.shape[0] == 1:
        correction = point_steps[0] - start_counts
        if not correction.any():
            empty_t = tuple(np.empty(0) for _ in range(n))
            empty_d = tuple(np.empty(0, dtype=np.int8) for _ in range(n))
            return PlannedMove(
                start, end, points, np.zeros(1), joints, point_steps, empty_t, empty_d,
                start_counts, point_steps[0].copy(), 0.0, 0.0, np.zeros(1),
            )  # fmt: skip
        # the machine is not where its counters say: step there at the motors' top rates
        duration = float(np.max(np.abs(correction) / rates))
        t = np.array([0.0, duration])
        times, dirs = step_events(correction[None, :], t)
        return PlannedMove(
            start, end, np.stack([start, start]), t, np.stack([joints[0], joints[0]]),
            np.stack([point_steps[0], point_steps[0]]), times, dirs, start_counts,
            point_steps[0].copy(), duration, 0.0, np.zeros(2),
        )  # fmt: skip

    # Speed is measured along the straight line, not along the grid's staircase.
    seg_len = np.diff(line_param) * float(np.linalg.norm(end - start))
    deltas = np.diff(point_steps, axis=0)
    deltas[0] = point_steps[1] - start_counts
    steps_per_m = np.max(np.abs(deltas) / seg_len[:, None], axis=0)
    with np.errstate(divide="ignore"):
        step_speed_caps = np.where(steps_per_m > 0, rates / steps_per_m, np.inf)
    v_cruise = min(float(speed_m_s), float(step_speed_caps.min()), config.point_rate_speed_cap_m_s)
    limit = ""
    if v_cruise < speed_m_s:
        busiest = int(np.argmin(step_speed_caps))
        if step_speed_caps[busiest] <= config.point_rate_speed_cap_m_s:
            limit = (
                f"motor {busiest + 1} reaches its top step rate, "
                f"{rates[busiest]:g} steps/s (drives.max_step_rate_hz)"
            )
        else:
            limit = (
                f"the kinematics take {config.compute_time_per_point_s * 1e6:g} us per "
                f"{config.resolution_m * 1e3:g} mm point (motion.compute_time_per_point_us)"
            )
    v_edge = min(config.min_speed_m_s, v_cruise)
    arc = line_param * float(np.linalg.norm(end - start))
    t, v_peak = _profile_times(arc, v_edge, v_cruise, config)
    dt = np.diff(t)
    if np.any(dt < config.compute_time_per_point_s):
        # only short end segments at extreme accelerations: give IK its time per point
        dt = np.maximum(dt, config.compute_time_per_point_s)
        t = np.concatenate([[0.0], np.cumsum(dt)])
    times, dirs = step_events(deltas, t)
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
        duration_s=float(t[-1]),
        peak_speed_m_s=float(v_peak),
        path_m=arc,
        speed_limit=limit,
        cruise_speed_m_s=v_cruise,
    )
