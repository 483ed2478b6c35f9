"""The rotary delta's part of the scene (models/delta/): its three servos' torque limit
(tau_max at the joint through the reducer), the platform's mass less the end effector that
hangs under it, the effector attached under the platform by MjSpec attach (no weld: the
claws' mount becomes a child body of the platform) and the power-on pose.

The six site-to-site `connect` equalities that close the parallelograms are the model's own
and the only equalities in the scene (docs/delta.md).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import mujoco
import numpy as np

MODEL = "delta"
"""The robot's folder: models/delta/delta.xml."""

INERTIAL_BODIES = ("platform",)
ARMS = ("q1", "q2", "q3")
ACTUATORS = ARMS
"""The robot's drives, one servo per arm (named as its joint)."""
EFFECTOR_MODEL = "effectors/plug_claws/plug_claws.xml"


@contextmanager
def quiet_prefix_note() -> Iterator[None]:
    """Silence MuJoCo's note that a spec was attached without a name prefix (printed and
    logged to MUJOCO_LOG.TXT, and a Python warning at compile): the claws keep their names,
    which the claws' module looks up. Any other MuJoCo warning is passed on."""
    notes: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(notes.append)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*empty prefix.*", category=UserWarning)
            yield
    finally:
        mujoco.set_mju_user_warning(previous)
    for note in notes:
        if "empty prefix" not in note:
            warnings.warn(note, stacklevel=3)


def attach_effector(spec: mujoco.MjSpec, models: Path) -> None:
    """Merge the plug-in claws under the platform: a frame on the platform's underside, the
    claws' mount attached to it (its bodies, joints, actuators and assets come along)."""
    claws = mujoco.MjSpec.from_file(str(models / EFFECTOR_MODEL))
    for spec_ in (spec, claws):  # the scene writes its own power-on keyframe
        for key in list(spec_.keys):
            spec_.delete(key)
    spec.option.impratio = claws.option.impratio  # the claws' friction-cone setting
    platform = spec.body("platform")
    half = float(spec.geom("platform").size[1])
    frame = platform.add_frame(pos=[0.0, 0.0, -half])
    with quiet_prefix_note():
        frame.attach_body(claws.body("claws_mount"), "", "")


def apply(spec: mujoco.MjSpec, cfg) -> None:
    """The servos' torque limit at the motor: tau_max / gear (forcerange), and the power-on
    keyframe is the scene's (`home_qpos`)."""
    gear = float(cfg.gear_ratio)
    limit = float(cfg.joint_torque_limit_nm) / gear
    for name in ARMS:
        act = spec.actuator(name)
        act.gear = [gear, 0, 0, 0, 0, 0]
        act.forcerange = [-limit, limit]


def _subtree_mass(body) -> float:
    total = float(body.mass)
    for child in body.bodies:
        total += _subtree_mass(child)
    return total


def apply_inertials(spec: mujoco.MjSpec, cfg) -> None:
    """The platform's disc carries m_move less the effector under it (the delta's
    `platform_mass_kg` counts platform, effector and a seedling)."""
    effector = _subtree_mass(spec.body("claws_mount"))
    spec.geom("platform").mass = max(float(cfg.platform_mass_kg) - effector, 0.05)


def home_joints(cfg) -> dict[str, float]:
    """Arm angles at power-on (rad)."""
    return dict(zip(ARMS, (float(q) for q in cfg.home_q_rad), strict=True))


def home_ctrl(cfg) -> list[float]:
    """The servos' commands at power-on: motor angles gear * q."""
    return [float(cfg.gear_ratio) * float(q) for q in cfg.home_q_rad]


def home_qpos(model: mujoco.MjModel, cfg, platform_xyz) -> np.ndarray:
    """The scene's qpos at power-on: the arms at `home_q_rad`, the rods' universal joints
    from the closed chain (solved by the model's own constraints from the drawn pose), the
    platform at `platform_xyz`, everything else at its body's drawn position."""
    qpos = model.qpos0.copy()
    for name, q in home_joints(cfg).items():
        qpos[model.jnt_qposadr[model.joint(name).id]] = q
    adr = model.jnt_qposadr[model.joint("platform").id]
    qpos[adr : adr + 3] = platform_xyz
    qpos[adr + 3 : adr + 7] = [1, 0, 0, 0]
    return qpos
