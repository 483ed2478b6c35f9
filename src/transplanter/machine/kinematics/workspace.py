"""An arm's workspace as its own kinematics decides it, and whether a job's key points fit in it.

The workspace is sampled, not assumed: the forward kinematics over a grid of every axis's
window bounds it, and :meth:`Kinematics.check` (the arm's own IK with every joint, singularity
and travel limit it refuses moves by) decides each point of a grid of voxels in that box.
:func:`placement` then asks whether some placement of the arm (a shift, and a turn about
the vertical by a quarter turn at a time) puts every one of a job's key points (the cells it
picks from and places into, its bin, its tube) on reachable voxels: a necessary condition for
the arm to do the job, computed from its kinematics, never a list of names.

Pure numpy, like the rest of the firmware package.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from transplanter.machine.kinematics.base import Kinematics

__all__ = ["Placement", "Workspace", "placement", "workspace"]

_FK_SAMPLES = 24_000
"""Joint-space samples whose forward kinematics bound the workspace."""
_MAX_VOXELS = 250_000
"""The most voxels a workspace is checked at (the grid is coarsened to stay below)."""


@dataclass(frozen=True)
class Workspace:
    """The voxels an arm reaches: ``reach[i, j, k]`` for the voxel centred at
    ``origin + (i, j, k) * step_m``."""

    origin: np.ndarray
    step_m: float
    reach: np.ndarray

    @property
    def span_m(self) -> np.ndarray:
        """The reachable voxels' extent along x, y, z (m); zeros where none is reachable."""
        idx = np.argwhere(self.reach)
        if not len(idx):
            return np.zeros(3)
        return (idx.max(axis=0) - idx.min(axis=0) + 1) * self.step_m


@dataclass(frozen=True)
class Placement:
    """Where the key points fit (None: nowhere) and what was compared."""

    shift_m: np.ndarray | None
    """The key points' shift into the arm's frame (after the turn), or None."""
    turn_deg: int | None
    """The turn about z applied first (0, 90, 180 or 270), or None."""
    points_span_m: np.ndarray
    """The key points' extent along x, y, z (m)."""
    workspace_span_m: np.ndarray
    """The reachable voxels' extent along x, y, z (m)."""
    step_m: float

    @property
    def fits(self) -> bool:
        return self.shift_m is not None


def _joint_samples(kinematics: Kinematics) -> np.ndarray:
    windows = [axis.window for axis in kinematics.axes]
    per_axis = max(2, int(round(_FK_SAMPLES ** (1.0 / len(windows)))))
    grids = np.meshgrid(*(np.linspace(lo, hi, per_axis) for lo, hi in windows), indexing="ij")
    return np.stack([g.ravel() for g in grids], axis=-1)


def workspace(kinematics: Kinematics, step_m: float = 0.010) -> Workspace:
    """The arm's reachable voxels at `step_m` (coarser where the box would hold more than
    `_MAX_VOXELS`), each decided by ``kinematics.check`` at its centre."""
    tips = kinematics.point(_joint_samples(kinematics))
    tips = tips[np.isfinite(tips).all(axis=-1)]
    if not len(tips):
        raise ValueError(f"the {kinematics.kind} kinematics closes at no joint sample")
    lo, hi = tips.min(axis=0) - step_m, tips.max(axis=0) + step_m
    while np.prod(np.ceil((hi - lo) / step_m) + 1) > _MAX_VOXELS:
        step_m *= 1.25
    shape = tuple(int(n) for n in np.ceil((hi - lo) / step_m) + 1)
    axes = [lo[d] + np.arange(shape[d]) * step_m for d in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    ok = np.asarray(kinematics.check(grid).ok, dtype=bool).reshape(shape)
    return Workspace(origin=lo, step_m=step_m, reach=ok)


def _turned(points: np.ndarray, turn_deg: int) -> np.ndarray:
    c, s = (round(math.cos(math.radians(turn_deg))), round(math.sin(math.radians(turn_deg))))
    x, y = points[:, 0], points[:, 1]
    return np.stack([c * x - s * y, s * x + c * y, points[:, 2]], axis=-1)


def placement(space: Workspace, points) -> Placement:
    """Whether some shift of `points` ((N, 3), m, in the job's frame), turned about z by 0,
    90, 180 or 270 deg, puts every point on a reachable voxel of `space` (each point taken at
    its nearest voxel, so to within half a voxel), and the first such shift found."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    span = pts.max(axis=0) - pts.min(axis=0)
    shape = np.array(space.reach.shape)
    for turn in (0, 90, 180, 270):
        turned = _turned(pts, turn)
        base = turned.min(axis=0)
        offsets = np.unique(np.rint((turned - base) / space.step_m).astype(int), axis=0)
        room = shape - offsets.max(axis=0)
        if (room <= 0).any():
            continue
        fits = np.ones(tuple(room), dtype=bool)
        for i, j, k in offsets:
            fits &= space.reach[i : i + room[0], j : j + room[1], k : k + room[2]]
            if not fits.any():
                break
        found = np.argwhere(fits)
        if len(found):
            corner = space.origin + found[0] * space.step_m
            return Placement(corner - base, turn, span, space.span_m, space.step_m)
    return Placement(None, None, span, space.span_m, space.step_m)
