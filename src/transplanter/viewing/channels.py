"""The scalar channels a trial recording carries: one list of (name, getter).

Each channel's name is its entity path under `scalars/` with the unit in the name; its getter
reads the value from the twin (and the step rates measured since the last frame), so names
and values cannot drift apart.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from transplanter.twin.sim import Twin

__all__ = ["Channel", "CHANNELS", "channel_names", "sample"]


@dataclass(frozen=True)
class Channel:
    name: str
    value: Callable[[Twin, np.ndarray], float]  # (twin, step rates Hz per motor) -> value


def _cmd(i: int) -> Callable[[Twin, np.ndarray], float]:
    return lambda twin, rates: float(twin.commanded_joints()[i])


def _act(i: int) -> Callable[[Twin, np.ndarray], float]:
    return lambda twin, rates: float(twin.scene.joint_positions(twin.data)[i])


def _deg(getter: Callable[[Twin, np.ndarray], float]) -> Callable[[Twin, np.ndarray], float]:
    return lambda twin, rates: math.degrees(getter(twin, rates))


def _mm(getter: Callable[[Twin, np.ndarray], float]) -> Callable[[Twin, np.ndarray], float]:
    return lambda twin, rates: getter(twin, rates) * 1e3


CHANNELS: tuple[Channel, ...] = (
    Channel("motors/theta1_cmd_deg", _deg(_cmd(0))),
    Channel("motors/theta1_deg", _deg(_act(0))),
    Channel("motors/theta2_cmd_deg", _deg(_cmd(1))),
    Channel("motors/theta2_deg", _deg(_act(1))),
    Channel("motors/z_cmd_mm", _mm(_cmd(2))),
    Channel("motors/z_mm", _mm(_act(2))),
    Channel("step_rate/arm1_hz", lambda twin, rates: float(rates[0])),
    Channel("step_rate/arm2_hz", lambda twin, rates: float(rates[1])),
    Channel("step_rate/z_hz", lambda twin, rates: float(rates[2])),
    Channel(
        "gripper/opening_cmd_mm",
        lambda twin, rates: float(twin.gripper_opening_cmd(np.array([twin.time]))[0]) * 1e3,
    ),
    Channel("gripper/opening_mm", lambda twin, rates: twin.scene.gripper_opening(twin.data) * 1e3),
    # each jaw's share of the total normal force on the pots
    Channel("gripper/force_n", lambda twin, rates: 0.5 * twin.scene.grip_force(twin.data)),
    Channel(
        "gripper/wrist_deg",
        lambda twin, rates: math.degrees(twin.data.qpos[twin.scene.wrist_qpos_adr]),
    ),
    Channel(
        "conveyor/position_mm", lambda twin, rates: twin.scene.conveyor_position(twin.data) * 1e3
    ),
    # the largest bend of the seedling shoots the judge follows now (transplanter.twin.shoot)
    Channel("seedling/stem_bend_deg", lambda twin, rates: twin.stem_bend_deg),
)


def channel_names() -> tuple[str, ...]:
    return tuple(c.name for c in CHANNELS)


def sample(twin: Twin, step_rates_hz: np.ndarray) -> np.ndarray:
    """Every channel's value now, in CHANNELS order."""
    return np.array([c.value(twin, step_rates_hz) for c in CHANNELS], dtype=np.float64)
