"""Whether a scenario's robot can reach its job at all, computed from the kinds: the job's key
points (its ``KEY_POINTS``: the cells it picks from and places into, its bin, its tube, in
its workcell's frame) against the robot's workspace as its own kinematics decides it
(:mod:`transplanter.machine.kinematics.workspace`: ``Kinematics.check`` on a voxel grid).

A robot reaches a job when some placement of it (a shift, a quarter turn about the vertical)
puts every key point on a voxel it reaches: a necessary condition, so a robot refused here
cannot do the job wherever it stands; one that passes may still be refused by the job (no
host program drives it, the effector does not fit) or by the preflight of its taught points.
"""

from __future__ import annotations

import importlib

import numpy as np

from transplanter import kinds
from transplanter.machine.kinematics.workspace import Placement, Workspace, placement, workspace

__all__ = ["key_points", "reach", "reach_refusal"]

_SPACES: dict[str, Workspace] = {}
"""Workspaces by their kinematics' repr (a robot's is computed once a process)."""


def key_points(scenario) -> dict[str, np.ndarray]:
    """{what: (3,) point, m} the scenario's job needs the tool at ({} for a job without
    ``KEY_POINTS``: a bench that moves no robot)."""
    target = getattr(kinds.job(scenario.workcell.kind), "KEY_POINTS", "")
    if not target:
        return {}
    module, _, name = target.partition(":")
    return getattr(importlib.import_module(module), name)(scenario)


def _space(scenario) -> Workspace:
    from transplanter.scenario.assemble import robot_kinematics

    kin = robot_kinematics(scenario)
    key = repr(kin)
    if key not in _SPACES:
        _SPACES[key] = workspace(kin)
    return _SPACES[key]


def reach(scenario) -> Placement | None:
    """Where the job's key points fit in the robot's workspace (None: the job has none)."""
    points = key_points(scenario)
    if not points:
        return None
    return placement(_space(scenario), np.stack(list(points.values())))


def _mm(span) -> str:
    return " x ".join(f"{v * 1e3:,.0f}" for v in span)


def reach_refusal(scenario) -> str | None:
    """Why the scenario's robot reaches its job's key points from no placement, in one line
    (None: some placement does, or the job has no key points)."""
    fit = reach(scenario)
    if fit is None or fit.fits:
        return None
    robot, job = scenario.robot.kind, scenario.workcell.kind
    return (
        f"no placement of the {robot} robot reaches the {job} job's key points: they span "
        f"{_mm(fit.points_span_m)} mm (x, y, z), its workspace {_mm(fit.workspace_span_m)} mm "
        f"(its kinematics' check on a {fit.step_m * 1e3:.0f} mm grid, turned by 0, 90, 180 "
        "or 270 deg)"
    )
