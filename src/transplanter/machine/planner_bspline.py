"""Time-optimal pick-and-place moves on a quintic B-spline in joint space, after Zhao, Cheng,
Dong, Ma, Xiong and Tong, "Research on the End Effector and Optimal Motion Control Strategy for
a Plug Seedling Transplanting Parallel Robot" (Agriculture 2022, 12(10), 1661), Sec. 2.4.

A move from a pick point to a place point goes through seven key points Q0..Q6 (Fig. 7): a
vertical lift, a quarter arc turning towards the target, a horizontal top segment (Q3 its
midpoint), a quarter arc and a vertical descent. The arm's inverse kinematics turns them into
seven joint nodes; one quintic (k = 5) B-spline in time passes through them with zero speed and
acceleration at both ends (11 control points, the clamped knot vector {t0 x6, t1..t5, t6 x6}:
what ``scipy.interpolate.make_interp_spline(t, P, k=5, bc_type=([(1, 0), (2, 0)],
[(1, 0), (2, 0)]))`` builds). The six interval lengths t_{i+1} - t_i are chosen for the shortest
total time under the limits of the paper's Eq. 14: joint speed, joint acceleration, joint torque
(the arm's inverse dynamics, the delta's Eq. 7-9) and the end effector's acceleration.

What makes the search cheap: scaling every interval by s turns the spline q(t) into q(t / s),
so joint speeds scale as 1/s, accelerations, the end effector's acceleration and the dynamic
part of the torque as 1/s^2, and gravity does not change. For any *shape* (the intervals up to
a common factor) the smallest feasible scale is therefore closed form (:func:`minimal_scale`).
:func:`plan_move` scales the uniform shape to its binding limit, then runs SLSQP on the six
intervals (minimise their sum, every interval's peak / limit <= 1) twice, the second run from
the first's result, then refines the result's sampled peaks and rescales it; the search's
evaluations are batched and vectorised (the spline's pieces from the quintic Hermite form, the
seven points of a finite-difference gradient at once: :class:`_Evaluator`); a Nelder-Mead
search over the shape alone and a plain particle swarm (:func:`pso_search`) are kept for
comparison (docs/planner.md). The joint speed,
acceleration and jerk peaks are exact: on every interval each joint's spline is a quintic
polynomial, and its derivatives' extrema are at the interval's ends or at the real roots of the
next derivative (:func:`exact_peaks`). Torque and the end effector's acceleration are not
polynomials in time: they are sampled on every interval during the search (the largest sample
raised to the vertex of the parabola through its neighbours) and the final plan's peaks are
refined by a zooming grid search around the largest sample. The yardstick
:func:`toppra_total` is TOPP-RA (Pham and Pham 2018) along the same path.

Pure numpy/scipy (the firmware side); written against the :class:`Kinematics` interface
(``joints``/``check`` for the nodes, ``jacobian``, and ``inverse_dynamics``/``platform_motion``
where the kind has them).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import BSpline, make_interp_spline
from scipy.optimize import minimize

from transplanter.errors import TransplanterError
from transplanter.machine.kinematics.base import Kinematics

__all__ = [
    "EE_ACCEL_LIMIT_M_S2",
    "MoveLimits",
    "MovePlan",
    "MoveRefused",
    "PickPath",
    "evaluate_intervals",
    "exact_peaks",
    "interval_usage",
    "joint_nodes",
    "key_points",
    "minimal_scale",
    "plan_move",
    "pso_search",
    "quintic_spline",
    "toppra_total",
]

EE_ACCEL_LIMIT_M_S2 = 8.83
"""The end effector's acceleration limit (m/s^2), an estimate. The paper prints "30 mm/s^2",
which cannot be right (a 100 mm lift alone would take 3.7 s), and reports its 1.05 s optimum
reaching 29.87 of that 30. On the default delta the paper's own intervals (0.21, 0.15, 0.18,
0.17, 0.15, 0.19 s) peak at 8.7955 m/s^2, so the limit the paper's optimum sits at 29.87/30 of
is 8.7955 x 30 / 29.87 = 8.83 m/s^2: with it the paper's plan is feasible and end-effector
bound, as the paper reports (its torque then peaks at 10.1 N m, the paper's 10.23 N m).
docs/planner.md also gives the 5.4 m/s^2 reading (the limit at which 1.05 s is the optimum)."""

N_INTERVALS = 6
START_SHAPE = (1.0,) * N_INTERVALS
"""The shape the search starts from (scaled to its binding limit first)."""
_SAMPLES = 24  # torque / end-effector samples per interval during the search
_PEAK_SAMPLES = 400  # per interval for the final plan's scale and its reported peaks


class MoveRefused(TransplanterError, ValueError):
    """No timing of the move's path meets a limit (``limit`` names it), or a key point is out
    of reach."""

    def __init__(self, limit: str, message: str):
        self.limit = limit
        super().__init__(message)


@dataclass(frozen=True)
class MoveLimits:
    """The limits of the paper's Eq. 14, in SI (rad/s, rad/s^2, N m, m/s^2). ``None`` leaves a
    limit out."""

    joint_speed_rad_s: float
    joint_accel_rad_s2: float
    joint_torque_nm: float | None = None
    ee_accel_m_s2: float | None = EE_ACCEL_LIMIT_M_S2

    def __post_init__(self) -> None:
        for name, value in self.__dict__.items():
            if value is None and name in ("joint_torque_nm", "ee_accel_m_s2"):
                continue
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"MoveLimits.{name} must be a positive number, got {value!r}")

    @classmethod
    def of(cls, kinematics: Kinematics, ee_accel_m_s2: float | None = EE_ACCEL_LIMIT_M_S2):
        """The limits an arm declares (``max_joint_speed_rad_s``, ``max_joint_accel_rad_s2``,
        ``joint_torque_limit_nm``; the torque limit only where the arm has inverse
        dynamics) and the end effector's."""
        torque = getattr(kinematics, "joint_torque_limit_nm", None)
        if not hasattr(kinematics, "inverse_dynamics"):
            torque = None
        return cls(
            joint_speed_rad_s=float(kinematics.max_joint_speed_rad_s),
            joint_accel_rad_s2=float(kinematics.max_joint_accel_rad_s2),
            joint_torque_nm=None if torque is None else float(torque),
            ee_accel_m_s2=ee_accel_m_s2,
        )


@dataclass(frozen=True)
class PickPath:
    """The shape of the Cartesian path of Fig. 7: ``lift_m`` straight up from the pick point,
    a quarter arc of ``radius_m`` towards the target, the top segment, a quarter arc and
    ``lift_m`` straight down. Where the two points are less than 3 radii apart horizontally the
    arcs shrink to a third of the distance and the lifts grow by as much (the top stays
    lift + radius above the higher end)."""

    lift_m: float = 0.100
    radius_m: float = 0.050
    exit_m: float = 0.0
    """0: the paper's seven key points. Above 0: one more key point straight above the pick
    point and one straight above the place point at this height (nine points, eight
    intervals), so that the joint-space spline leaves and enters a cell nearly vertically:
    through seven points it strays 7-11 mm sideways within the first 45 mm of the lift
    (docs/planner.md, "Executed")."""

    def __post_init__(self) -> None:
        for name in ("lift_m", "radius_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"PickPath.{name} must be positive, got {value!r}")
        if not (math.isfinite(self.exit_m) and 0.0 <= self.exit_m < self.lift_m):
            raise ValueError(
                f"PickPath.exit_m must be in [0, lift_m = {self.lift_m:g}) m, got {self.exit_m!r}"
            )


def key_points(start, end, path: PickPath | None = None) -> np.ndarray:
    """(7, 3) key points Q0..Q6 (m) of a move from ``start`` to ``end`` (m, Z up); (9, 3) with
    the exit points of ``path.exit_m`` after Q0 and before Q6."""
    path = path or PickPath()
    p0, p6 = np.asarray(start, dtype=np.float64), np.asarray(end, dtype=np.float64)
    if p0.shape != (3,) or p6.shape != (3,) or not np.isfinite(np.append(p0, p6)).all():
        raise ValueError("a move's start and end must be finite (x, y, z) points")
    horizontal = p6[:2] - p0[:2]
    dist = float(np.hypot(*horizontal))
    if dist < 1e-6:
        raise MoveRefused(
            "path", "the start and end are less than 1 um apart horizontally: a pick path needs "
            "a horizontal move (the arcs turn towards the target)"
        )  # fmt: skip
    u = np.append(horizontal / dist, 0.0)
    r = min(path.radius_m, dist / 3.0)
    top = max(p0[2], p6[2]) + path.lift_m + path.radius_m
    q1 = np.array([p0[0], p0[1], top - r])
    q2 = np.array([p0[0], p0[1], top]) + r * u
    q5 = np.array([p6[0], p6[1], top - r])
    q4 = np.array([p6[0], p6[1], top]) - r * u
    q3 = 0.5 * (q2 + q4)
    if path.exit_m > 0.0 and min(q1[2] - p0[2], q5[2] - p6[2]) <= path.exit_m:
        raise MoveRefused(
            "path", f"the exit points {path.exit_m * 1e3:g} mm above the ends are not below "
            "the lifts' tops"
        )  # fmt: skip
    if path.exit_m > 0.0:
        e0, e6 = p0 + [0.0, 0.0, path.exit_m], p6 + [0.0, 0.0, path.exit_m]
        return np.stack([p0, e0, q1, q2, q3, q4, q5, e6, p6])
    return np.stack([p0, q1, q2, q3, q4, q5, p6])


def joint_nodes(kinematics: Kinematics, points) -> np.ndarray:
    """(7, n) joint positions of the key points; MoveRefused naming the first refused point and
    why (the arm's own typed refusals)."""
    pts = np.asarray(points, dtype=np.float64)
    report = kinematics.check(pts)
    for i in report.failing:
        raise MoveRefused(
            "reach", f"key point Q{int(i)} {np.round(pts[i] * 1e3, 3).tolist()} mm: "
            f"{report.reasons[int(i)]}"
        )  # fmt: skip
    for i, p in enumerate(pts):
        refusal = kinematics.limit_target(p)
        if refusal is not None:
            raise MoveRefused("reach", f"key point Q{i}: {refusal.text()}")
    return np.asarray(report.joints, dtype=np.float64)


def quintic_spline(nodes, intervals) -> BSpline:
    """The quintic B-spline through the (7, n) joint nodes (or any k >= 2 nodes) at times 0,
    cumsum(intervals), with zero speed and acceleration at both ends (Eq. 9-13 of the
    paper)."""
    h = np.asarray(intervals, dtype=np.float64)
    nodes = np.asarray(nodes, dtype=np.float64)
    count = nodes.shape[0] - 1
    if h.shape != (count,) or not (np.isfinite(h).all() and (h > 0).all()):
        raise ValueError(f"a move needs {count} positive interval lengths, got {intervals!r}")
    t = np.concatenate([[0.0], np.cumsum(h)])
    zero = np.zeros(nodes.shape[1:])
    ends = [(1, zero), (2, zero)]
    return make_interp_spline(t, nodes, k=5, bc_type=(ends, ends))


def _node_times(spline: BSpline) -> np.ndarray:
    return np.asarray(spline.t[5:-5], dtype=np.float64)


def _pieces(spline: BSpline) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each interval's polynomial in u = (t - mid) / half on [-1, 1]: (coefficients (6, n, 6),
    ascending in u, of q; mid (6,); half (6,))."""
    tn = _node_times(spline)
    mid, half = 0.5 * (tn[1:] + tn[:-1]), 0.5 * (tn[1:] - tn[:-1])
    coef = np.stack(
        [spline(mid, nu=k) * (half[:, None] ** k) / math.factorial(k) for k in range(6)], axis=-1
    )
    return coef, mid, half


def _deriv(coef: np.ndarray) -> np.ndarray:
    """Derivative in u of ascending coefficients (..., m) -> (..., m - 1)."""
    m = coef.shape[-1]
    return coef[..., 1:] * np.arange(1, m)


def _polyval(coef: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Evaluate ascending coefficients (..., m) at u (..., k) -> (..., k) (Horner)."""
    out = np.zeros(np.broadcast_shapes(coef.shape[:-1] + (1,), u.shape))
    for k in range(coef.shape[-1] - 1, -1, -1):
        out = out * u + coef[..., k : k + 1]
    return out


def _real_roots(c: np.ndarray) -> np.ndarray:
    """Real roots of one polynomial with ascending coefficients (vanishing leading ones
    dropped); empty when constant."""
    scale = np.max(np.abs(c))
    deg = len(c) - 1
    while deg > 0 and abs(c[deg]) <= 1e-13 * scale:
        deg -= 1
    if deg == 0 or scale == 0.0:
        return np.empty(0)
    r = np.roots(c[deg::-1])
    return r[np.abs(r.imag) <= 1e-9 * (1.0 + np.abs(r.real))].real


def _roots_in_unit(coef: np.ndarray) -> np.ndarray:
    """Real roots in [-1, 1] of polynomials with ascending coefficients (..., m), as
    (..., m - 1) with NaN where there is none; batched through the companion matrices'
    eigenvalues where the leading coefficient is well away from zero, one by one elsewhere;
    polished by two Newton steps."""
    m = coef.shape[-1]
    shape = coef.shape[:-1]
    flat = coef.reshape(-1, m)
    deg = m - 1
    roots = np.full((flat.shape[0], deg), np.nan + 0j)
    scale = np.max(np.abs(flat), axis=1)
    lead = flat[:, -1]
    good = np.abs(lead) > 1e-6 * scale
    if good.any():
        comp = np.zeros((int(good.sum()), deg, deg))
        comp[:, 0, :] = -flat[good, -2::-1] / lead[good, None]
        if deg > 1:
            comp[:, np.arange(1, deg), np.arange(deg - 1)] = 1.0
        roots[good] = np.linalg.eigvals(comp)
    for row in np.flatnonzero(~good):
        r = _real_roots(flat[row])
        roots[row, : len(r)] = r
    real = np.abs(roots.imag) <= 1e-7 * (1.0 + np.abs(roots.real))
    out = np.where(real, roots.real, np.nan)
    out = np.where((out >= -1.0 - 1e-9) & (out <= 1.0 + 1e-9), out, np.nan)
    out = np.clip(out, -1.0, 1.0)
    d = _deriv(flat)
    for _ in range(2):
        z = np.nan_to_num(out)
        f = _polyval(flat, z)
        fp = _polyval(d, z)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(np.abs(fp) > 0.0, f / fp, 0.0)
        out = np.clip(out - np.where(np.abs(step) < 1e-3, step, 0.0), -1.0, 1.0)
    return out.reshape(shape + (deg,))


def _abs_peak(poly: np.ndarray) -> np.ndarray:
    """max |p(u)| on [-1, 1] of ascending coefficients (..., m): at the ends or at the real
    roots of p' inside."""
    ends = np.abs(_polyval(poly, np.array([-1.0, 1.0])))
    best = ends.max(axis=-1)
    if poly.shape[-1] > 1:
        crit = _roots_in_unit(_deriv(poly))
        vals = np.abs(_polyval(poly, np.nan_to_num(crit)))
        vals = np.where(np.isnan(crit), 0.0, vals)
        best = np.maximum(best, vals.max(axis=-1))
    return best


def exact_peaks(spline: BSpline) -> dict[str, np.ndarray]:
    """The exact per-interval, per-joint peaks (6, n) of |speed|, |acceleration| and |jerk| of
    a quintic spline: each interval's polynomial's derivative at the interval's ends and at the
    real roots of the next derivative."""
    coef, _, half = _pieces(spline)
    out = {}
    d = coef
    for name, order in (("speed", 1), ("accel", 2), ("jerk", 3)):
        d = _deriv(d)
        out[name] = _abs_peak(d) / half[:, None] ** order
    return out


def _dynamics(kinematics: Kinematics, q, qd, qdd):
    """(dynamic torque (..., n) or None, gravity torque (..., n) or None, end-effector
    acceleration (..., 3)) at joint states; the torque splits exactly as
    tau = dynamic + gravity with dynamic scaling as 1/s^2."""
    if hasattr(kinematics, "torque_split"):  # the same, in one pass (the delta)
        return kinematics.torque_split(q, qd, qdd)
    if hasattr(kinematics, "inverse_dynamics"):
        tau = kinematics.inverse_dynamics(q, qd, qdd)
        if hasattr(kinematics, "gravity_torques"):
            grav = kinematics.gravity_torques(q)
        else:
            grav = kinematics.inverse_dynamics(q, np.zeros_like(qd), np.zeros_like(qdd))
        dyn = tau - grav
    else:
        dyn = grav = None
    if hasattr(kinematics, "platform_motion"):
        xdd = kinematics.platform_motion(q, qd, qdd)[2]
    else:  # J qdd + (dJ/dt) qd, dJ/dt along qd by a central difference
        eps = 1e-6
        jac = kinematics.jacobian(q)
        dj = (kinematics.jacobian(q + eps * qd) - kinematics.jacobian(q - eps * qd)) / (2 * eps)
        xdd = np.einsum("...ij,...j->...i", jac, qdd) + np.einsum("...ij,...j->...i", dj, qd)
    return dyn, grav, xdd


def _required_scale(dyn, grav, xdd, limits: MoveLimits):
    """Per sample, the smallest scale s (>= 0) that keeps the torque (per joint) and the end
    effector's acceleration in their limits: (torque scale (..., n) or None, ee scale (...)).
    inf where gravity alone breaks the torque limit."""
    s_tau = None
    if dyn is not None and limits.joint_torque_nm is not None:
        lim = limits.joint_torque_nm
        room = np.where(dyn >= 0.0, lim - grav, lim + grav)  # |G + D u| <= lim, u = 1/s^2
        with np.errstate(divide="ignore", invalid="ignore"):
            s_tau = np.where(
                room > 0.0, np.sqrt(np.abs(dyn) / np.where(room > 0.0, room, 1.0)), np.inf
            )
    s_ee = None
    if limits.ee_accel_m_s2 is not None:
        s_ee = np.sqrt(np.linalg.norm(xdd, axis=-1) / limits.ee_accel_m_s2)
    return s_tau, s_ee


def _samples(spline: BSpline, per_interval: int) -> tuple[np.ndarray, np.ndarray]:
    tn = _node_times(spline)
    u = np.linspace(0.0, 1.0, per_interval + 1)
    ts = tn[:-1, None] + (tn[1:] - tn[:-1])[:, None] * u[None, :]
    return ts, u


def _sampled_peak(values: np.ndarray) -> np.ndarray:
    """(...,) the peak of evenly spaced samples (..., k) along the last axis: the largest
    sample, raised to the vertex of the parabola through it and its two neighbours where it
    is an interior maximum (smooth in the data, so a local search cannot hide a peak between
    two samples as easily as with the bare maximum)."""
    j = np.argmax(values, axis=-1)
    top = np.take_along_axis(values, j[..., None], axis=-1)[..., 0]
    inner = (j > 0) & (j < values.shape[-1] - 1)
    jl, jr = np.clip(j - 1, 0, None), np.clip(j + 1, None, values.shape[-1] - 1)
    left = np.take_along_axis(values, jl[..., None], axis=-1)[..., 0]
    right = np.take_along_axis(values, jr[..., None], axis=-1)[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):  # inf where a shape is refused
        curve = left - 2.0 * top + right
        lift = np.where(inner & (curve < 0.0), (right - left) ** 2 / (-8.0 * curve), 0.0)
    return top + np.where(np.isfinite(lift), lift, 0.0)


@dataclass(frozen=True)
class _Scales:
    """The smallest feasible common scale of a shape, per limit (each a float, 0 when the
    limit is absent)."""

    speed: float
    accel: float
    torque: float
    ee_accel: float

    @property
    def limiting(self) -> tuple[str, float]:
        items = {
            "joint speed": self.speed,
            "joint accel": self.accel,
            "joint torque": self.torque,
            "end-effector accel": self.ee_accel,
        }
        name = max(items, key=items.get)
        return name, items[name]


def minimal_scale(
    kinematics: Kinematics, nodes, intervals, limits: MoveLimits, refine: bool = False
) -> _Scales:
    """For intervals h, the smallest s such that the spline on s h meets each limit: speed
    max|q'| / V, accel sqrt(max|q''| / A) (exact peaks), end effector sqrt(max|X''| / a),
    torque from |G + D / s^2| <= tau at every sample: ``_SAMPLES`` per interval, or with
    ``refine`` (the final plan's scale) the ``_PEAK_SAMPLES`` of its reported peaks, each
    interval's largest refined by a zooming grid search (:func:`_refine_batch`): on the
    coarse grid the largest sample can sit by another local maximum than the true peak's, and
    the plan came out up to 1e-5 over the end-effector limit on 50 of 800 tray moves."""
    spline = quintic_spline(nodes, intervals)
    peaks = exact_peaks(spline)
    s_v = float(peaks["speed"].max()) / limits.joint_speed_rad_s
    s_a = math.sqrt(float(peaks["accel"].max()) / limits.joint_accel_rad_s2)
    s_tau = s_e = 0.0
    if limits.joint_torque_nm is None and limits.ee_accel_m_s2 is None:
        return _Scales(s_v, s_a, 0.0, 0.0)
    ts, _ = _samples(spline, _PEAK_SAMPLES if refine else _SAMPLES)
    d1, d2 = spline.derivative(1), spline.derivative(2)

    def at(t):
        t = np.asarray(t, dtype=np.float64)
        return _required_scale(*_dynamics(kinematics, spline(t), d1(t), d2(t)), limits)

    tau_req, ee_req = at(ts)
    if ee_req is not None and not np.isfinite(ee_req).all():
        raise MoveRefused("reach", "the spline leaves the workspace between the key points")
    if tau_req is not None:
        if np.isnan(tau_req).any():
            raise MoveRefused("reach", "the spline leaves the workspace between the key points")
        if not np.isfinite(tau_req).all():
            q = spline(ts)
            grav = kinematics.inverse_dynamics(q, np.zeros_like(q), np.zeros_like(q))
            worst = np.unravel_index(np.argmax(np.abs(grav)), grav.shape)
            raise MoveRefused(
                "joint torque",
                f"joint torque limit {limits.joint_torque_nm:g} N m cannot be met at any speed: "
                f"gravity alone needs {abs(float(grav[worst])):.3f} N m on joint {worst[-1] + 1} "
                f"at t/T = {float(ts[worst[:-1]] / ts[-1, -1]):.3f}",
            )
        s_tau = float(_sampled_peak(np.moveaxis(tau_req, -1, 0)).max())
    if ee_req is not None:
        s_e = float(_sampled_peak(ee_req).max())
    if refine:
        if tau_req is not None:
            s_tau = _refine(lambda t: at(t)[0].max(axis=-1), ts, tau_req.max(axis=-1), s_tau)
        if ee_req is not None:
            s_e = _refine(lambda t: at(t)[1], ts, ee_req, s_e)
    return _Scales(s_v, s_a, s_tau, s_e)


def _refine(fun, ts: np.ndarray, values: np.ndarray, best: float) -> float:
    """The maximum of fun near each interval's largest sample (:func:`_refine_batch` on the
    samples either side, every interval at once), never below ``best`` (the sampled
    maximum). fun is vectorised: times (k, p) -> values (k, p)."""
    rows = np.arange(ts.shape[0])
    j = np.argmax(values, axis=1)
    lo = ts[rows, np.maximum(j - 1, 0)]
    hi = ts[rows, np.minimum(j + 1, ts.shape[1] - 1)]
    keep = hi > lo
    if keep.any():
        best = max(best, float(_refine_batch(fun, lo[keep], hi[keep]).max()))
    return best


def evaluate_intervals(kinematics: Kinematics, nodes, intervals, limits: MoveLimits) -> float:
    """The total time of the shape of ``intervals`` scaled to its binding limit (seconds): the
    objective the searches share."""
    h = np.asarray(intervals, dtype=np.float64)
    scales = minimal_scale(kinematics, nodes, h, limits)
    return float(h.sum()) * scales.limiting[1]


def interval_usage(kinematics: Kinematics, nodes, intervals, limits: MoveLimits) -> np.ndarray:
    """(6, 4) how much of each limit each interval uses at the intervals as given (peak /
    limit, 1 = at the limit): joint speed and acceleration (exact peaks, the largest joint),
    joint torque and the end effector's acceleration (sampled; 0 where the limit is absent)."""
    spline = quintic_spline(nodes, intervals)
    peaks = exact_peaks(spline)
    out = np.zeros((len(intervals), 4))
    out[:, 0] = peaks["speed"].max(axis=1) / limits.joint_speed_rad_s
    out[:, 1] = peaks["accel"].max(axis=1) / limits.joint_accel_rad_s2
    if limits.joint_torque_nm is None and limits.ee_accel_m_s2 is None:
        return out
    ts, _ = _samples(spline, _SAMPLES)
    dyn, grav, xdd = _dynamics(kinematics, spline(ts), spline(ts, nu=1), spline(ts, nu=2))
    if dyn is not None and limits.joint_torque_nm is not None:
        tau = np.moveaxis(np.abs(dyn + grav), -1, 0)  # (joint, interval, sample)
        out[:, 2] = _sampled_peak(tau).max(axis=0) / limits.joint_torque_nm
    if limits.ee_accel_m_s2 is not None:
        out[:, 3] = _sampled_peak(np.linalg.norm(xdd, axis=-1)) / limits.ee_accel_m_s2
    return out


# -- the search's vectorised evaluations ---------------------------------------------------
# The same quantities as quintic_spline + exact_peaks + interval_usage / minimal_scale, for a
# batch of interval vectors at once and without building scipy splines: the spline's pieces
# come from the quintic Hermite form (the unknown speeds and accelerations at the interior
# nodes from the C3 and C4 continuity there, one small linear system per interval vector).

_BINOMIAL = np.array([[math.comb(j, k) for k in range(6)] for j in range(6)], dtype=np.float64)


def _hermite_pieces(nodes: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For interval vectors h (m, K) and nodes (K + 1, n): each interval's quintic in
    u = (t - mid) / half on [-1, 1] as ascending coefficients (m, K, n, 6), and half (m, K):
    the spline of :func:`quintic_spline` (zero speed and acceleration at both ends, C4 at the
    interior nodes), the coefficients of :func:`_pieces` up to rounding."""
    m, count = h.shape
    n = nodes.shape[1]
    inner = count - 1
    delta = np.diff(nodes, axis=0)  # (K, n)
    hl, hr = h[:, :-1], h[:, 1:]  # the intervals left and right of interior node k
    # continuity of the third (rows 2k) and fourth (rows 2k + 1) derivatives at interior node
    # k in the unknowns v_k (column 2k) and a_k (column 2k + 1), from the quintic Hermite
    # form's end derivatives; the nodes' differences on the right-hand side
    mat = np.zeros((m, 2 * inner, 2 * inner))
    rhs = np.zeros((m, 2 * inner, n))
    rows = np.arange(inner)
    r3, r4 = 2 * rows, 2 * rows + 1
    cv, ca = 2 * rows, 2 * rows + 1
    mat[:, r3, cv] = -36.0 / hl**2 + 36.0 / hr**2
    mat[:, r3, ca] = 9.0 / hl + 9.0 / hr
    mat[:, r4, cv] = -192.0 / hl**3 - 192.0 / hr**3
    mat[:, r4, ca] = 36.0 / hl**2 - 36.0 / hr**2
    if inner > 1:
        left, right = rows[1:], rows[:-1]  # node k's neighbours k - 1 and k + 1
        mat[:, r3[left], cv[left] - 2] = -24.0 / hl[:, left] ** 2
        mat[:, r3[left], ca[left] - 2] = -3.0 / hl[:, left]
        mat[:, r4[left], cv[left] - 2] = -168.0 / hl[:, left] ** 3
        mat[:, r4[left], ca[left] - 2] = -24.0 / hl[:, left] ** 2
        mat[:, r3[right], cv[right] + 2] = 24.0 / hr[:, right] ** 2
        mat[:, r3[right], ca[right] + 2] = -3.0 / hr[:, right]
        mat[:, r4[right], cv[right] + 2] = -168.0 / hr[:, right] ** 3
        mat[:, r4[right], ca[right] + 2] = 24.0 / hr[:, right] ** 2
    rhs[:, r3] = -(60.0 * delta[None, :-1] / hl[..., None] ** 3
                   - 60.0 * delta[None, 1:] / hr[..., None] ** 3)  # fmt: skip
    rhs[:, r4] = -(360.0 * delta[None, :-1] / hl[..., None] ** 4
                   + 360.0 * delta[None, 1:] / hr[..., None] ** 4)  # fmt: skip
    x = np.linalg.solve(mat, rhs)  # (m, 2 inner, n)
    zero = np.zeros((m, 1, n))
    v = np.concatenate([zero, x[:, 0::2], zero], axis=1)  # (m, K + 1, n)
    a = np.concatenate([zero, x[:, 1::2], zero], axis=1)
    hh = h[..., None]
    d0 = delta[None] - v[:, :-1] * hh - 0.5 * a[:, :-1] * hh**2
    d1 = v[:, 1:] - v[:, :-1] - a[:, :-1] * hh
    d2 = a[:, 1:] - a[:, :-1]
    c3 = 10.0 * d0 / hh**3 - 4.0 * d1 / hh**2 + 0.5 * d2 / hh
    c4 = -15.0 * d0 / hh**4 + 7.0 * d1 / hh**3 - d2 / hh**2
    c5 = 6.0 * d0 / hh**5 - 3.0 * d1 / hh**4 + 0.5 * d2 / hh**3
    y0 = np.broadcast_to(nodes[None, :-1], (m, count, n))
    local = np.stack([y0, v[:, :-1], 0.5 * a[:, :-1], c3, c4, c5], axis=-1)  # in t - t_i
    half = 0.5 * h
    powers = half[..., None, None] ** np.arange(6)
    return (local * powers) @ _BINOMIAL, half  # t - t_i = half (u + 1)


def _quadratic_roots(c: np.ndarray) -> np.ndarray:
    """Real roots (..., 2) of c0 + c1 u + c2 u^2 (ascending (..., 3)), NaN where there is
    none; one root where c2 vanishes against the others (the linear equation)."""
    c0, c1, c2 = c[..., 0], c[..., 1], c[..., 2]
    scale = np.maximum(np.maximum(np.abs(c0), np.abs(c1)), np.abs(c2))
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = c1 * c1 - 4.0 * c2 * c0
        root = np.sqrt(np.where(disc >= 0.0, disc, np.nan))
        q = -0.5 * (c1 + np.where(c1 >= 0.0, root, -root))
        quad = np.abs(c2) > 1e-12 * scale
        first = np.where(quad, q / c2, -c0 / c1)
        second = np.where(quad, c0 / q, np.nan)
    out = np.stack([first, second], axis=-1)
    return np.where(np.isfinite(out), out, np.nan)


def _abs_peak_fast(poly: np.ndarray) -> np.ndarray:
    """:func:`_abs_peak` for cubics and quartics (acceleration and speed pieces) with less
    overhead: the critical points of a cubic in closed form, of a quartic from the
    companion matrices' eigenvalues (the quadratic's closed form where the leading
    coefficient vanishes), both polished by two Newton steps; the ends always count."""
    d = _deriv(poly)
    if d.shape[-1] == 3:
        crit = _quadratic_roots(d)
    elif d.shape[-1] == 4:
        flat = d.reshape(-1, 4)
        lead = flat[:, 3]
        good = np.abs(lead) > 1e-6 * np.max(np.abs(flat), axis=1)
        crit = np.full((flat.shape[0], 3), np.nan)
        crit[~good, :2] = _quadratic_roots(flat[~good, :3])
        if good.any():
            comp = np.zeros((int(good.sum()), 3, 3))
            comp[:, 0, :] = -flat[good, 2::-1] / lead[good, None]
            comp[:, 1, 0] = comp[:, 2, 1] = 1.0
            roots = np.linalg.eigvals(comp)
            real = np.abs(roots.imag) <= 1e-7 * (1.0 + np.abs(roots.real))
            crit[good] = np.where(real, roots.real, np.nan)
        crit = crit.reshape(d.shape[:-1] + (3,))
    else:
        return _abs_peak(poly)
    crit = np.where((crit >= -1.0 - 1e-9) & (crit <= 1.0 + 1e-9), crit, np.nan)
    crit = np.clip(crit, -1.0, 1.0)
    dd = _deriv(d)
    for _ in range(2):
        z = np.nan_to_num(crit)
        f, fp = _polyval(d, z), _polyval(dd, z)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(np.abs(fp) > 0.0, f / fp, 0.0)
        crit = np.clip(crit - np.where(np.abs(step) < 1e-3, step, 0.0), -1.0, 1.0)
    ends = np.abs(_polyval(poly, np.array([-1.0, 1.0]))).max(axis=-1)
    vals = np.where(np.isnan(crit), 0.0, np.abs(_polyval(poly, np.nan_to_num(crit))))
    return np.maximum(ends, vals.max(axis=-1))


class _Evaluator:
    """The search's evaluations of one move's nodes for a batch of interval vectors (m, K) at
    once: each interval's use of each limit (:func:`interval_usage`) and the shape's total
    scaled to its binding limit (:func:`evaluate_intervals`, inf where the shape is refused),
    from the Hermite pieces, the exact speed and acceleration peaks and ``samples`` samples
    of the dynamics per interval. The last few batches are kept, so that SLSQP's repeated
    points are not evaluated twice."""

    def __init__(self, kinematics: Kinematics, nodes, limits: MoveLimits, samples: int = _SAMPLES):
        self.kinematics = kinematics
        self.nodes = np.asarray(nodes, dtype=np.float64)
        self.limits = limits
        self.u = np.linspace(-1.0, 1.0, samples + 1)  # _samples' points on [-1, 1]
        self.calls = 0
        self._cache: dict[bytes, tuple[np.ndarray, float]] = {}

    def __call__(self, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(usage (m, K, 4), scaled totals (m,)) of interval vectors (m, K)."""
        h = np.atleast_2d(np.asarray(h, dtype=np.float64))
        keys = [row.tobytes() for row in h]
        found = {key: self._cache[key] for key in keys if key in self._cache}
        todo = [i for i, key in enumerate(keys) if key not in found]
        if todo:
            usage, totals = self._evaluate(h[todo])
            for k, i in enumerate(todo):
                found[keys[i]] = (usage[k], float(totals[k]))
        if len(self._cache) > 64:
            self._cache.clear()
        self._cache.update(found)
        usage = np.stack([found[key][0] for key in keys])
        totals = np.array([found[key][1] for key in keys])
        return usage, totals

    def _evaluate(self, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self.calls += h.shape[0]
        lim = self.limits
        coef, half = _hermite_pieces(self.nodes, h)
        d1 = _deriv(coef)
        d2 = _deriv(d1)
        speed = _abs_peak_fast(d1).max(axis=-1) / half  # (m, K): the largest joint
        accel = _abs_peak_fast(d2).max(axis=-1) / half**2
        usage = np.zeros(h.shape + (4,))
        usage[..., 0] = speed / lim.joint_speed_rad_s
        usage[..., 1] = accel / lim.joint_accel_rad_s2
        scale = np.maximum(
            speed.max(axis=-1) / lim.joint_speed_rad_s,
            np.sqrt(accel.max(axis=-1) / lim.joint_accel_rad_s2),
        )
        if lim.joint_torque_nm is not None or lim.ee_accel_m_s2 is not None:
            hs = half[..., None, None]
            q = np.swapaxes(_polyval(coef, self.u), -1, -2)  # (m, K, samples + 1, n)
            qd = np.swapaxes(_polyval(d1, self.u), -1, -2) / hs
            qdd = np.swapaxes(_polyval(d2, self.u), -1, -2) / hs**2
            dyn, grav, xdd = _dynamics(self.kinematics, q, qd, qdd)
            tau_req, ee_req = _required_scale(dyn, grav, xdd, lim)
            bad = np.zeros(h.shape[0], dtype=bool)
            if dyn is not None and lim.joint_torque_nm is not None:
                tau = np.moveaxis(np.abs(dyn + grav), -1, 0)  # (n, m, K, samples + 1)
                usage[..., 2] = _sampled_peak(tau).max(axis=0) / lim.joint_torque_nm
                bad |= ~np.isfinite(tau_req).all(axis=(1, 2, 3))
                scale = np.maximum(scale, _sampled_peak(np.moveaxis(tau_req, -1, 0)).max(
                    axis=(0, 2)))  # fmt: skip
            if ee_req is not None:
                usage[..., 3] = _sampled_peak(np.linalg.norm(xdd, axis=-1)) / lim.ee_accel_m_s2
                bad |= ~np.isfinite(ee_req).all(axis=(1, 2))
                scale = np.maximum(scale, _sampled_peak(ee_req).max(axis=-1))
            scale = np.where(bad, np.inf, scale)
        return usage, h.sum(axis=-1) * scale


def _refine_batch(fun, lo: np.ndarray, hi: np.ndarray, rounds: int = 7, points: int = 17):
    """The maxima (k,) of a vectorised fun on k brackets [lo, hi] at once: ``points`` evenly
    spaced samples per bracket, the bracket narrowed to the best sample's neighbours,
    ``rounds`` times (the bracket shrinks 8-fold a round: about 1e-7 of its width after 7,
    a peak's value then exact to rounding). fun maps times (k, p) to values (k, p); NaN is
    taken as no value."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    best = np.full(lo.shape, -np.inf)
    grid = np.linspace(0.0, 1.0, points)
    for _ in range(rounds):
        ts = lo[:, None] + (hi - lo)[:, None] * grid
        vals = np.nan_to_num(np.asarray(fun(ts), dtype=np.float64), nan=-np.inf)
        j = np.argmax(vals, axis=1)
        best = np.maximum(best, vals[np.arange(len(j)), j])
        new_lo = ts[np.arange(len(j)), np.clip(j - 1, 0, points - 1)]
        hi = ts[np.arange(len(j)), np.clip(j + 1, 0, points - 1)]
        lo = new_lo
    return best


@dataclass(frozen=True)
class MovePlan:
    """A planned move: key points, joint nodes, intervals and the peaks of the result."""

    points_m: np.ndarray
    """(7, 3) key points Q0..Q6."""
    nodes: np.ndarray
    """(7, n) joint nodes (rad)."""
    intervals_s: np.ndarray
    """(6,) interval lengths."""
    binding: str
    """The limit the plan is scaled to."""
    peaks: dict[str, np.ndarray]
    """Per interval and joint (6, n): exact ``speed``, ``accel``, ``jerk``; refined ``torque``
    (absolute, N m) where the arm has dynamics; ``ee_accel`` (6,) in m/s^2."""
    evaluations: int
    """Spline evaluations the search took (objective and constraint calls)."""
    history: np.ndarray = field(repr=False)
    """(k, 2) rows (evaluations so far, best scaled total time so far), the last the plan's."""
    planning_s: float = 0.0
    """Wall time of the search."""

    @property
    def total_s(self) -> float:
        return float(self.intervals_s.sum())

    def spline(self) -> BSpline:
        return quintic_spline(self.nodes, self.intervals_s)


def _check_joint_windows(kinematics: Kinematics, nodes, intervals) -> None:
    """MoveRefused naming the joint when the spline leaves an axis's window between the
    nodes (dense samples)."""
    spline = quintic_spline(nodes, intervals)
    ts, _ = _samples(spline, 200)
    q = spline(ts.ravel())
    for i, axis in enumerate(kinematics.axes):
        lo, hi = axis.window
        if q[:, i].min() < lo - 1e-9 or q[:, i].max() > hi + 1e-9:
            worst = q[:, i].min() if q[:, i].min() < lo else q[:, i].max()
            raise MoveRefused(
                "joint window",
                f"the spline takes {axis.name} to {math.degrees(worst):.3f} deg, outside "
                f"[{math.degrees(lo):g}, {math.degrees(hi):g}] deg, between the key points",
            )


def _peaks_of(kinematics, nodes, h, limits) -> dict[str, np.ndarray]:
    """Exact speed, accel and jerk peaks; torque and end-effector peaks per interval from 400
    samples each, refined by a zooming grid search around the largest."""
    spline = quintic_spline(nodes, h)
    out = exact_peaks(spline)
    d1, d2 = spline.derivative(1), spline.derivative(2)

    def at(t):
        dyn, grav, xdd = _dynamics(kinematics, spline(t), d1(t), d2(t))
        tau = None if dyn is None else np.abs(dyn + grav)
        return tau, np.linalg.norm(xdd, axis=-1)

    ts, _ = _samples(spline, _PEAK_SAMPLES)
    tau, ee = at(ts)
    count, last = len(h), ts.shape[1] - 1
    rows = np.arange(count)

    def brackets(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        j = np.argmax(values, axis=1)
        return ts[rows, np.maximum(j - 1, 0)], ts[rows, np.minimum(j + 1, last)]

    out["ee_accel"] = np.maximum(ee.max(axis=1), _refine_batch(lambda t: at(t)[1], *brackets(ee)))
    if tau is not None:
        n = tau.shape[-1]
        lo, hi = zip(*(brackets(tau[:, :, j]) for j in range(n)), strict=True)
        joint = np.repeat(np.arange(n), count)[:, None, None]  # brackets joint-major

        def joint_tau(t: np.ndarray) -> np.ndarray:
            return np.take_along_axis(at(t)[0], joint, axis=-1)[..., 0]

        refined = _refine_batch(joint_tau, np.concatenate(lo), np.concatenate(hi))
        out["torque"] = np.maximum(tau.max(axis=1), refined.reshape(n, count).T)
    return out


def plan_move(
    kinematics: Kinematics,
    start,
    end,
    limits: MoveLimits | None = None,
    path: PickPath | None = None,
    method: str = "slsqp",
    max_iterations: int = 40,
    start_shape=None,
    ftol: float = 1e-7,
) -> MovePlan:
    """The shortest quintic-spline move from ``start`` to ``end`` (m): key points, IK, then
    the scale-then-local search. Scale: ``start_shape`` (default uniform) stretched to its
    binding limit. Local (``method="slsqp"``): SLSQP on the six intervals, minimising their sum
    subject to every interval's peak / limit <= 1 (exact speed and acceleration peaks, sampled
    torque and end-effector acceleration; 24 constraints; ``ftol`` its tolerance on the total
    in seconds), then a second SLSQP run from the first's result (a fresh quasi-Newton model;
    the best shape of both kept). ``"nelder-mead"``: Nelder-Mead on the five
    log-ratios of the intervals, each shape scaled exactly to its binding limit (slower; kept
    for comparison). Last, the result's torque and end-effector peaks are refined and the
    plan rescaled to its binding limit. Deterministic (no random numbers). MoveRefused when a
    key point is out of reach or no scale meets a limit."""
    started = time.perf_counter()
    limits = limits or MoveLimits.of(kinematics)
    points = key_points(start, end, path)
    nodes = joint_nodes(kinematics, points)
    evaluations = [0]
    history: list[tuple[int, float]] = []
    best_shape: list[np.ndarray] = [np.empty(0)]  # the shape of the best scaled total

    evaluator = _Evaluator(kinematics, nodes, limits)

    def scaled_total(h: np.ndarray, first: bool = False) -> float:
        if first:  # the refusals' reasons
            evaluations[0] += 1
            total = evaluate_intervals(kinematics, nodes, h, limits)
        else:
            total = float(evaluator(h)[1][0])
        if not history or total < history[-1][1]:
            best_shape[0] = np.array(h, dtype=np.float64)
        best = min(total, history[-1][1]) if history else total
        history.append((evaluations[0] + evaluator.calls, best))
        return total

    count = nodes.shape[0] - 1
    h0 = np.ones(count) if start_shape is None else np.asarray(start_shape, dtype=np.float64)
    h0 = h0 * scaled_total(h0, first=True) / h0.sum()  # the start shape, at its limit
    if method == "slsqp":
        floor = 1e-4 * h0[0]

        def margins(h: np.ndarray) -> np.ndarray:
            usage = evaluator(h)[0]
            return (1.0 - np.where(np.isfinite(usage), usage, 1e3)).reshape(len(usage), -1)

        def margins_jac(h: np.ndarray) -> np.ndarray:
            # SLSQP's own forward differences (step sqrt(eps)), the seven points in one batch
            h = np.maximum(np.asarray(h, dtype=np.float64), floor)
            step = np.sqrt(np.finfo(np.float64).eps)
            batch = h + np.vstack([np.zeros(count), step * np.eye(count)])
            m = margins(batch)
            dx = np.diag(batch[1:]) - h
            return ((m[1:] - m[0]) / dx[:, None]).T

        def slsqp(start: np.ndarray) -> np.ndarray:
            res = minimize(
                np.sum, start, jac=lambda h: np.ones_like(h), method="SLSQP",
                bounds=[(floor, None)] * count,
                constraints=[{"type": "ineq", "fun": lambda h: margins(h)[0],
                              "jac": margins_jac}],
                callback=lambda h: scaled_total(np.asarray(h)),
                options={"ftol": ftol, "maxiter": max_iterations},
            )  # fmt: skip
            # SLSQP's last iterate can sit a little above its best one where the sampled
            # peaks switch intervals: keep the better of the two, scaled
            h = np.asarray(res.x, dtype=np.float64)
            if not (np.all(h > 0) and scaled_total(h) <= history[-1][1]):
                h = best_shape[0]
            return h

        h = slsqp(h0)
        # a second run from the first's result at its limit, with a fresh quasi-Newton
        # model: where the first stalled on the peaks' kinks it often goes on a little
        # (never worse: the best scaled shape of both runs is kept)
        h = slsqp(h * history[-1][1] / h.sum())
    elif method == "nelder-mead":
        x0 = np.zeros(count - 1)
        res = minimize(
            lambda x: scaled_total(np.exp(np.append(x, 0.0))), x0, method="Nelder-Mead",
            options={"xatol": 1e-6, "fatol": 1e-9, "maxfev": 40 * max_iterations,
                     "initial_simplex": np.vstack([x0, x0 + 0.3 * np.eye(count - 1)])},
        )  # fmt: skip
        h = np.exp(np.append(res.x, 0.0))
    else:
        raise ValueError(f"method must be 'slsqp' or 'nelder-mead', got {method!r}")
    evaluations[0] += evaluator.calls
    scales = minimal_scale(kinematics, nodes, h, limits, refine=True)
    _check_joint_windows(kinematics, nodes, h)
    binding, s = scales.limiting
    intervals = h * s * (1.0 + 1e-9)
    history.append((evaluations[0], float(intervals.sum())))
    return MovePlan(
        points_m=points,
        nodes=nodes,
        intervals_s=intervals,
        binding=binding,
        peaks=_peaks_of(kinematics, nodes, intervals, limits),
        evaluations=evaluations[0],
        history=np.asarray(history),
        planning_s=time.perf_counter() - started,
    )


def pso_search(
    kinematics: Kinematics,
    nodes,
    limits: MoveLimits,
    particles: int = 20,
    iterations: int = 120,
    inertia: float = 0.6,
    c1: float = 2.0,
    c2: float = 2.0,
    bounds_s: tuple[float, float] = (0.02, 0.6),
    seed: int = 0,
) -> tuple[np.ndarray, float, np.ndarray]:
    """A plain particle swarm on the six intervals as the paper runs it (Eq. 16: v <- w v +
    c1 r1 (pbest - x) + c2 r2 (gbest - x), x <- x + v; fitness the total time, a particle
    breaking a limit rejected), for comparison with :func:`plan_move`. Seeded. Returns (best
    intervals, best total (inf if no particle was ever feasible), (evaluations,) best total
    after each evaluation)."""
    rng = np.random.default_rng(seed)
    lo, hi = bounds_s
    x = rng.uniform(lo, hi, size=(particles, N_INTERVALS))
    v = np.zeros_like(x)
    history: list[float] = []
    gbest, gval = x[0].copy(), math.inf

    def fitness(h: np.ndarray) -> float:
        try:
            scales = minimal_scale(kinematics, nodes, h, limits)
        except MoveRefused:
            return math.inf
        return float(h.sum()) if scales.limiting[1] <= 1.0 else math.inf

    pval = np.full(particles, math.inf)
    pbest = x.copy()
    for _ in range(iterations):
        for i in range(particles):
            f = fitness(x[i])
            if f < pval[i]:
                pval[i], pbest[i] = f, x[i].copy()
            if f < gval:
                gval, gbest = f, x[i].copy()
            history.append(gval)
        r1, r2 = rng.random(x.shape), rng.random(x.shape)
        v = inertia * v + c1 * r1 * (pbest - x) + c2 * r2 * (gbest - x)
        x = np.clip(x + v, lo, hi)
    return gbest, gval, np.asarray(history)


def _sphere_directions(count: int) -> np.ndarray:
    """(count, 3) unit vectors spread over the upper half of the sphere (a Fibonacci
    lattice); with their negatives they cover every direction."""
    k = np.arange(count) + 0.5
    z = k / count
    phi = math.pi * (3.0 - math.sqrt(5.0)) * k
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def _batched_second_order(toppra):
    """A subclass of toppra's ``SecondOrderConstraint`` whose ``inv_dyn`` takes (n, dof)
    arrays of points: ``compute_constraint_params`` makes the three calls toppra makes per
    grid point (w at rest, w(q, 0, q_s), w(q, q_s, q_ss), less the first) once over the
    whole grid, then discretises as toppra does. The same coefficients as the point-by-point
    loop (the functions are the same numpy formulas), about 20 times faster; no custom term
    (no joint friction here)."""
    from toppra.constraint.constraint import DiscretizationType
    from toppra.constraint.linear_constraint import canlinear_colloc_to_interpolate

    class _Batched(toppra.constraint.SecondOrderConstraint):
        def compute_constraint_params(self, path, gridpoints):
            if path.dof != self.dof:
                raise ValueError(f"path dof {path.dof} != constraint dof {self.dof}")
            p, ps, pss = path(gridpoints), path(gridpoints, 1), path(gridpoints, 2)
            zero = np.zeros_like(p)
            c = np.asarray(self.inv_dyn(p, zero, zero), dtype=np.float64)
            a = np.asarray(self.inv_dyn(p, zero, ps), dtype=np.float64) - c
            b = np.asarray(self.inv_dyn(p, ps, pss), dtype=np.float64) - c
            f = np.array([self.constraint_F(q) for q in p])
            g = np.array([self.constraint_g(q) for q in p])
            if self.discretization_type == DiscretizationType.Collocation:
                return a, b, c, f, g, None, None
            return canlinear_colloc_to_interpolate(a, b, c, f, g, None, None, gridpoints)

    return _Batched


def toppra_total(
    kinematics: Kinematics,
    nodes,
    intervals,
    limits: MoveLimits,
    gridpoints: int = 600,
    ee_directions: int = 96,
) -> float:
    """The time-optimal traversal (s) of the spline's geometric path by TOPP-RA (Pham and
    Pham 2018, the ``toppra`` package), from rest to rest, under the same limits: joint speed
    and acceleration boxes, the joint torque of the arm's inverse dynamics (toppra's
    second-order constraint, exact for dynamics quadratic in the speeds) and the end
    effector's acceleration |X''| <= a as |n . X''| <= a over ``ee_directions`` directions n
    and their negatives (a polytope around the ball, so a relaxation: the result is a lower
    bound, like TOPP-RA's own gridding). The path is the spline in its own time, s in [0, T]."""
    import toppra
    import toppra.algorithm
    import toppra.constraint

    spline = quintic_spline(nodes, intervals)
    t_end = float(np.sum(intervals))
    dof = int(np.asarray(nodes).shape[1])

    class _Path(toppra.interpolator.AbstractGeometricPath):
        def __call__(self, path_positions, order=0):
            return spline(np.asarray(path_positions, dtype=np.float64), nu=order)

        @property
        def dof(self) -> int:
            return dof

        @property
        def path_interval(self):
            return np.array([0.0, t_end])

    vlim = np.tile([-limits.joint_speed_rad_s, limits.joint_speed_rad_s], (dof, 1))
    alim = np.tile([-limits.joint_accel_rad_s2, limits.joint_accel_rad_s2], (dof, 1))
    constraints = [
        toppra.constraint.JointVelocityConstraint(vlim),
        toppra.constraint.JointAccelerationConstraint(alim),
    ]
    # An arm whose dynamics take arrays of points (the delta's) gets its second-order
    # constraints' coefficients in one call per term (_BatchedSecondOrder); any other arm
    # toppra's point-by-point calls, which give the same numbers.
    batched = hasattr(kinematics, "platform_motion")
    second_order = _batched_second_order(toppra) if batched else None
    if limits.joint_torque_nm is not None and hasattr(kinematics, "inverse_dynamics"):
        tlim = np.tile([-limits.joint_torque_nm, limits.joint_torque_nm], (dof, 1))
        torque = toppra.constraint.SecondOrderConstraint.joint_torque_constraint(
            kinematics.inverse_dynamics, tlim, np.zeros(dof)
        )
        if batched:
            torque = second_order(
                kinematics.inverse_dynamics, torque.constraint_F, torque.constraint_g, dof
            )
        constraints.append(torque)
    if limits.ee_accel_m_s2 is not None:
        half = _sphere_directions(ee_directions)
        f = np.vstack([half, -half])
        g = np.full(len(f), limits.ee_accel_m_s2)

        def ee(q, qd, qdd):
            if batched:
                return kinematics.platform_motion(q, qd, qdd)[2]
            return _dynamics(kinematics, q, qd, qdd)[2]

        kind = second_order or toppra.constraint.SecondOrderConstraint
        constraints.append(kind(ee, lambda _q: f, lambda _q: g, dof))
    grid = np.linspace(0.0, t_end, gridpoints + 1)
    instance = toppra.algorithm.TOPPRA(
        constraints, _Path(), gridpoints=grid, solver_wrapper="seidel"
    )
    _, sd, _ = instance.compute_parameterization(0.0, 0.0)
    if sd is None:
        raise MoveRefused("toppra", "TOPP-RA found no feasible parameterisation of the path")
    sd = np.sqrt(np.maximum(np.asarray(sd, dtype=np.float64) ** 2, 0.0))
    ds = np.diff(grid)
    return float(np.sum(2.0 * ds / (sd[1:] + sd[:-1])))
