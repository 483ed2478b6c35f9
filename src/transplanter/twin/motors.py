"""What the machine's drives do in a run: each actuator's peak force or torque and the
mechanical work it does, from MuJoCo's actuator forces and velocities after every physics
step. The same meter runs in every job (the five-bar's trial, the delta's tray, the serial
arm's jobs), so that machines are compared alike (`transplanter compare`).

The drives are the robot's actuators and its effector's (`ACTUATORS` of the robot and
effector kind modules, transplanter.scene.kinds); the workcell's (belts, conveyors) and the
scene's helpers are not the machine's and are left out.

Per actuator, with force f (N m for a rotary drive, N for a linear one, in the actuator's
own space: at the motor shaft through its gear) and velocity v (rad/s or m/s, the same
space) after each step of length dt:

- ``peak``: max |f| over the run after a 5 ms first-order lag (`PEAK_TIME_CONSTANT_S`);
- ``work_j``: the sum of max(f v, 0) dt, the mechanical energy the drive puts into the
  machine (a motor does not take energy back when the load drives it: braking is spent, not
  recovered). Electrical losses (winding resistance, driver, idle holding current) are not in
  it: it is the lower bound of what a supply must deliver, the same for every machine.

Cost: two row copies into a block buffer per step; the products and sums are done once a
block (`BLOCK_STEPS`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from scipy.signal import lfilter

from transplanter.scene import kinds

__all__ = ["BLOCK_STEPS", "MotorMeter", "MotorReport", "drive_actuators", "motor_columns"]

BLOCK_STEPS = 256
"""Steps buffered before the products and sums are taken."""

PEAK_TIME_CONSTANT_S = 0.005
"""The peak force or torque is taken after a first-order lag of this time constant: what a
drive must give for a few milliseconds (a motor's peak rating), not single-step spikes,
whose height depends on the timestep. The paper trial, seed 3, 10 seedlings, at 1, 0.5 and
0.25 ms: the robot's peak 0.228, 0.221, 0.220 N m (unfiltered 0.52, 0.46, 0.42, the Z screw's
spikes); the drives' work 17.92, 18.15, 18.01 J."""


def drive_actuators(robot_kind: str, effector_kind: str) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The names of the robot's and the effector's actuators (the kinds' ``ACTUATORS``)."""
    return (
        tuple(kinds.robot(robot_kind).ACTUATORS),
        tuple(kinds.effector(effector_kind).ACTUATORS),
    )


@dataclass(frozen=True)
class MotorReport:
    """A run's drives: per actuator (in the model's order) its name, whether it is the
    robot's (else the effector's), whether it is linear (force in N) or rotary (N m), its peak
    |force| and its positive mechanical work (J)."""

    names: tuple[str, ...]
    robot: tuple[bool, ...]
    linear: tuple[bool, ...]
    peak: tuple[float, ...]
    work_j: tuple[float, ...]

    @property
    def energy_j(self) -> float:
        """The work of every drive, robot and effector (J)."""
        return float(sum(self.work_j))

    @property
    def peak_robot_torque_nm(self) -> float | None:
        """The largest peak torque of the robot's rotary drives (N m at the motor shaft),
        None for a robot without one."""
        values = [
            p for p, r, lin in zip(self.peak, self.robot, self.linear, strict=True) if r and not lin
        ]
        return max(values) if values else None

    def to_dict(self) -> dict:
        return {
            "energy_j": self.energy_j,
            "peak_robot_torque_nm": self.peak_robot_torque_nm,
            "drives": [
                {
                    "name": n,
                    "part": "robot" if r else "effector",
                    "unit": "N" if lin else "N m",
                    "peak": p,
                    "work_j": w,
                }
                for n, r, lin, p, w in zip(
                    self.names, self.robot, self.linear, self.peak, self.work_j, strict=True
                )
            ],
        }


def _linear(model: mujoco.MjModel, actuator: int) -> bool:
    """Whether an actuator's force is a force (N): a tendon's, or a slide joint's through a
    unit gear; a hinge's, or a slide driven through a screw's gear (rad/m: the force is then
    the motor's torque), is a torque (N m)."""
    trn = int(model.actuator_trntype[actuator])
    if trn == int(mujoco.mjtTrn.mjTRN_TENDON):
        return True
    if trn not in (int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT)):
        return False
    joint = model.actuator_trnid[actuator, 0]
    slide = int(model.jnt_type[joint]) == int(mujoco.mjtJoint.mjJNT_SLIDE)
    return bool(slide and model.actuator_gear[actuator, 0] == 1.0)


class MotorMeter:
    """Records the drives' forces and velocities after each `mj_step` (`record(data)`) and
    gives the run's `MotorReport` (`report()`)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        robot_actuators: Sequence[str],
        effector_actuators: Sequence[str] = (),
    ) -> None:
        names = [*robot_actuators, *effector_actuators]
        ids = []
        for name in names:
            try:
                ids.append(model.actuator(name).id)
            except KeyError:
                raise ValueError(
                    f"the model has no actuator {name!r} (a kind's ACTUATORS names one it "
                    "does not add)"
                ) from None
        order = np.argsort(ids, kind="stable")
        self.ids = np.asarray(ids, dtype=np.intp)[order]
        self.names = tuple(names[i] for i in order)
        n_robot = len(robot_actuators)
        self.robot = tuple(bool(i < n_robot) for i in order)
        self.linear = tuple(_linear(model, int(a)) for a in self.ids)
        lo, hi = int(self.ids.min()), int(self.ids.max()) + 1
        # a contiguous run of actuators (the kinds put theirs first, robot then effector):
        # one slice view per step; otherwise the span that holds them all
        self._span = slice(lo, hi)
        self._pick = self.ids - lo
        self.dt = float(model.opt.timestep)
        width = hi - lo
        self._f = np.zeros((BLOCK_STEPS, width))
        self._v = np.zeros((BLOCK_STEPS, width))
        self._i = 0
        self._peak = np.zeros(len(self.ids))
        self._work = np.zeros(len(self.ids))
        # the peak is that of the force through a first-order lag of PEAK_TIME_CONSTANT_S:
        # a continuous filter sampled at the step, so it converges as the step shrinks
        self._alpha = -math.expm1(-self.dt / PEAK_TIME_CONSTANT_S)
        self._lag = np.zeros((1, len(self.ids)))

    def record(self, data: mujoco.MjData) -> None:
        """After a physics step: the drives' forces and velocities now."""
        i = self._i
        self._f[i] = data.actuator_force[self._span]
        self._v[i] = data.actuator_velocity[self._span]
        self._i = i + 1
        if self._i == BLOCK_STEPS:
            self._flush()

    def _flush(self) -> None:
        n = self._i
        if not n:
            return
        f = self._f[:n, self._pick]
        v = self._v[:n, self._pick]
        lagged, self._lag = lfilter(
            [self._alpha], [1.0, self._alpha - 1.0], f, axis=0, zi=self._lag
        )
        np.maximum(self._peak, np.abs(lagged).max(axis=0), out=self._peak)
        self._work += np.maximum(f * v, 0.0).sum(axis=0) * self.dt
        self._i = 0

    def report(self) -> MotorReport:
        """The run so far."""
        self._flush()
        return MotorReport(
            names=self.names,
            robot=self.robot,
            linear=self.linear,
            peak=tuple(float(p) for p in self._peak),
            work_j=tuple(float(w) for w in self._work),
        )


def motor_columns(motors: Mapping[str, Any] | None) -> dict[str, Any]:
    """A row's drive columns from a result's `motors` (transplanter.twin.motors): the drives'
    mechanical work (J) and the robot's peak motor torque (N m at the shaft)."""
    if not motors:
        return {"motor_energy_j": None, "peak_motor_torque_nm": None}
    return {
        "motor_energy_j": motors["energy_j"],
        "peak_motor_torque_nm": motors["peak_robot_torque_nm"],
    }
