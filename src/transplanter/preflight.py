"""Checks a machine's taught points before any simulation starts.

Every taught point must be reachable (kinematics limits, Z range), and every straight line
the PGF will ask for must be reachable at every interpolated point, so a trial never starts
on a program the SGF would reject halfway through. Errors name the scenario key.
"""

from __future__ import annotations

import numpy as np

from transplanter import kinematics
from transplanter.machine import Machine
from transplanter.motion import plan_line
from transplanter.scenario import ScenarioError
from transplanter.units import M_PER_MM

__all__ = ["check_machine"]


def check_machine(machine: Machine) -> None:
    """Raise ScenarioError naming the scenario key of the first taught point (as stored in
    the EEPROM image) or move that fails."""
    taught = machine.eeprom
    points: list[tuple[str, tuple[float, float]]] = [("taught.drop_mm", taught.drop_xy_m)]
    for i, p in enumerate(taught.pickups):
        points.append((f"taught.pickup[{i}].approach_mm", p.approach_xy_m))
        points.append((f"taught.pickup[{i}].grip_mm", p.grip_xy_m))
    xy = np.array([p for _, p in points])
    report = kinematics.check_points(
        machine.geometry, machine.limits, xy[:, 0], xy[:, 1], mode=machine.mode
    )
    for (key, p), ok, reason in zip(points, report.ok, report.reasons, strict=True):
        if not ok:
            raise ScenarioError(
                f"{key} = [{p[0] / M_PER_MM:g}, {p[1] / M_PER_MM:g}] mm cannot be reached: "
                f"{reason}. "
                "Teach a point inside the workspace."
            )
    z_low, z_up = taught.z_low_m, taught.z_up_m
    drop = (*taught.drop_xy_m, z_up)
    homed = _homed_xyz(machine)
    _require_line(
        machine,
        homed,
        drop,
        "taught.drop_mm: the first move, from the homed position",
        "Move the drop point or the limit switches (drives.home_*).",
    )
    for i, p in enumerate(taught.pickups):
        approach_low, grip_low = (*p.approach_xy_m, z_low), (*p.grip_xy_m, z_low)
        grip_up, approach_up = (*p.grip_xy_m, z_up), (*p.approach_xy_m, z_up)
        path = [drop, approach_low, grip_low, grip_up, approach_up, drop]
        for a, b in zip(path[:-1], path[1:], strict=True):
            _require_line(
                machine,
                a,
                b,
                f"taught.pickup[{i}]: the move from",
                "Move the approach or grip point.",
            )


def _require_line(machine, a, b, what: str, hint: str) -> None:
    """ScenarioError '<what> a to b mm leaves the workspace: <reason>. <hint>' if the SGF
    would refuse the straight line from a to b."""
    try:
        _check_line(machine, a, b)
    except kinematics.UnreachableError as exc:
        raise ScenarioError(
            f"{what} {_mm(a)} to {_mm(b)} mm leaves the workspace: {exc.reason}. {hint}"
        ) from None


def _homed_xyz(machine) -> tuple[float, float, float]:
    """Where G28 leaves the machine: the SGF's homed step counters, through its kinematics."""
    sgf = machine.sgf
    x, y, z = sgf.kinematics.point_of_steps(sgf.homed_steps, sgf.drives)
    return (float(x), float(y), float(z))


def _check_line(machine, a, b) -> None:
    start = np.asarray(a, dtype=float)
    steps = machine.sgf.kinematics.steps_of_point(start, machine.drives)
    speed = machine.eeprom.s_high_m_s
    plan_line(
        steps,
        start,
        np.asarray(b, dtype=float),
        speed,
        machine.geometry,
        machine.limits,
        machine.drives,
        machine.motion,
        mode=machine.mode,
    )


def _mm(p) -> str:
    return "(" + ", ".join(f"{v / M_PER_MM:g}" for v in p) + ")"
