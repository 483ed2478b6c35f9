"""The kinematics seam: what the firmware, the preflight, the command line and the scene ask
of an arm, whatever its kind.

Modelled on RepRapFirmware's ``Kinematics`` class (CartesianToMotorSteps,
MotorStepsToCartesian, IsReachable, LimitPosition, homing hooks, created by type) and Klipper's
``klippy/kinematics/*.py`` (one module per arm, loaded by name). An arm drives any number of
:class:`Axis` (each a stepper drive with the joint position of its homing switch and its
window); the vertical slide is one of them, not a bypass (as RRF's ``ZLeadscrewKinematics``
base). Points are Cartesian ``(x, y, z)`` in metres in the machine frame (the G-code frame);
joints are the axes' positions (rad for a rotary joint, m for a slide), in axis order.

A kind implements :meth:`Kinematics.joints` (IK), :meth:`Kinematics.point` (FK) and
:meth:`Kinematics.check` (per-point verdicts with typed :class:`Refusal` records); the rest
(step counters, the first refused point, homing positions) is built on those here.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from transplanter.errors import Refusal, RefusalReason, TransplanterError, refusal_text
from transplanter.machine.axes import Axis
from transplanter.machine.homing import HomingConfig
from transplanter.machine.steppers import StepperDrive
from transplanter.units import M_PER_MM, show

__all__ = ["Axis", "Kinematics", "ReachReport", "UnreachableError"]


class UnreachableError(TransplanterError, ValueError):
    """A commanded point violates the workspace or a kinematic limit: ``index`` is the
    point's index in what was checked, ``refusals`` say why (typed, with their numbers)."""

    def __init__(
        self,
        index: int,
        refusals: tuple[Refusal, ...] | str,
        message: str | None = None,
    ):
        self.index = int(index)
        if isinstance(refusals, str):  # a reason with no numbers (kept for callers' text)
            refusals = (Refusal(RefusalReason.OUT_OF_WORKSPACE, refusals),)
            self._reason = refusals[0].subject
        else:
            self._reason = refusal_text(refusals)
        self.refusals = tuple(refusals)
        super().__init__(message or f"point {index} is not reachable: {self._reason}")

    @property
    def reason(self) -> str:
        """Every refusal of the point as one line."""
        return self._reason


@dataclass(frozen=True)
class ReachReport:
    """Per-point verdicts of :meth:`Kinematics.check` (points flattened)."""

    joints: np.ndarray
    """(N, n_axes) joint positions (NaN where no IK solution), in the axes' windows."""
    ok: np.ndarray
    """(N,) True where the point passes every limit."""
    refusals: tuple[tuple[Refusal, ...], ...]
    """Per point, every limit it violates (empty for good points)."""
    diagnostics: Mapping[str, np.ndarray] = field(default_factory=dict)
    """Named per-point quantities of the kind (e.g. transmission angle, condition)."""

    @property
    def reasons(self) -> tuple[str, ...]:
        """Per point, its refusals as one line ('' for good points)."""
        return tuple(refusal_text(r) for r in self.refusals)

    @property
    def failing(self) -> np.ndarray:
        """Indices of the failing points."""
        return np.flatnonzero(~self.ok)


def as_points(xyz) -> np.ndarray:
    """(N, 3) float64 points of any (..., 3) input."""
    pts = np.asarray(xyz, dtype=np.float64)
    if pts.shape[-1:] != (3,):
        raise ValueError(f"points must be (..., 3) x, y, z in m, got shape {pts.shape}")
    return pts.reshape(-1, 3)


class Kinematics(ABC):
    """An arm: its axes, IK, FK, reach check and what homing and the scene need of it.

    Subclasses set :attr:`kind` (the scenario's ``[robot] kind``) and implement
    :meth:`joints`, :meth:`point` and :meth:`check`. Instances are immutable values.
    """

    kind: str = ""
    """The registry name of this kind of arm."""
    coordinates: tuple[str, ...] = ("X", "Y", "Z")
    """The G-code axis letters of a point's coordinates."""

    @property
    @abstractmethod
    def axes(self) -> tuple[Axis, ...]:
        """The driven joints, in motor order."""

    # -- the kind's own maths --------------------------------------------------------
    @abstractmethod
    def joints(self, xyz) -> np.ndarray:
        """(..., n_axes) joint positions of (..., 3) points (IK); NaN where unreachable."""

    @abstractmethod
    def point(self, joints) -> np.ndarray:
        """(..., 3) point of (..., n_axes) joint positions (FK); NaN where the chain cannot
        close. ``point(joints(p)) == p`` for a reachable ``p``."""

    @abstractmethod
    def check(self, xyz) -> ReachReport:
        """Per-point verdicts, with typed refusals, against the workspace and every limit."""

    def limit_target(self, xyz) -> Refusal | None:
        """A move's target outside the machine's Cartesian range (RRF's LimitPosition), or
        None. Checked before the move is interpolated. Default: no range."""
        return None

    @property
    def lower_hard_limits(self) -> tuple[tuple[int, int], ...]:
        """(coordinate index, switch index) of switches that stop a coordinate going down
        while they read closed (a hard limit). Default: none."""
        return ()

    @classmethod
    def from_scenario(cls, scenario) -> Kinematics:
        """The arm a validated scenario describes (its robot's sections, in SI). A kind that
        does not override this is refused by name when a scenario asks for it (ValueError,
        which the scenario's assembly reports as a refusal)."""
        raise ValueError(
            f"robot kind {cls.kind!r} ({cls.__name__}) cannot be made from a scenario: its "
            "kinematics defines no from_scenario"
        )

    @classmethod
    def homing_from_scenario(cls, scenario) -> HomingConfig:
        """How the scenario's machine homes this arm's axes (default: HomingConfig())."""
        return HomingConfig()

    def describe(self) -> dict[str, float | str]:
        """The arm's parameters for results and the scene (kind and lengths in m)."""
        return {"kind": self.kind}

    def point_lines(self, report: ReachReport, i: int) -> list[str]:
        """What `transplanter ik` prints of a reachable point of a report: each axis's joint
        position (deg for a rotary joint, mm for a slide)."""
        lines = []
        for axis, value in zip(self.axes, report.joints[i], strict=True):
            if axis.linear:
                lines.append(f"{axis.name} = {value / M_PER_MM:.4f} mm")
            else:
                lines.append(f"{axis.name} = {math.degrees(value):.4f} deg")
        return lines

    # -- built on the above ----------------------------------------------------------
    @property
    def drives(self) -> tuple[StepperDrive, ...]:
        """The axes' stepper drives, in motor order."""
        return tuple(axis.drive for axis in self.axes)

    @property
    def n_axes(self) -> int:
        return len(self.axes)

    @property
    def home_joints(self) -> np.ndarray:
        """(n_axes,) joint positions at which the homing switches trip."""
        return np.array([axis.home_position for axis in self.axes], dtype=np.float64)

    @property
    def home_steps(self) -> np.ndarray:
        """(n_axes,) step counters homing sets when each switch trips (nearest step)."""
        return np.array([int(a.drive.to_steps(a.home_position)) for a in self.axes], dtype=np.int64)

    def require(self, xyz) -> np.ndarray:
        """(N, n_axes) joints if every point passes, else UnreachableError for the first
        failing point (its index, refusals and coordinates in mm)."""
        pts = as_points(xyz)
        report = self.check(pts)
        if not report.ok.all():
            i = int(report.failing[0])
            reason = report.reasons[i]
            shown = ", ".join(show(v / M_PER_MM) for v in pts[i, : self._shown_coordinates])
            names = ", ".join(c.lower() for c in self.coordinates[: self._shown_coordinates])
            raise UnreachableError(
                i,
                report.refusals[i],
                f"target position not reachable: point {i} at ({names}) = ({shown}) mm: {reason}",
            )
        return report.joints

    _shown_coordinates: int = 3
    """How many coordinates a refusal shows (a planar arm on a slide shows x and y)."""

    def steps_of_point(self, xyz) -> np.ndarray:
        """(..., n_axes) int64 step counters at (..., 3) points (IK; ValueError where a point
        is unreachable)."""
        xyz = np.asarray(xyz, dtype=np.float64)
        joints = self.joints(xyz)
        return np.stack(
            [axis.drive.to_steps(joints[..., m]) for m, axis in enumerate(self.axes)], axis=-1
        )

    def point_of_steps(self, steps) -> np.ndarray:
        """(..., 3) point in m of (..., n_axes) step counters (FK)."""
        steps = np.asarray(steps)
        joints = np.stack(
            [axis.drive.to_position(steps[..., m]) for m, axis in enumerate(self.axes)],
            axis=-1,
        )
        return np.asarray(self.point(joints), dtype=np.float64)
