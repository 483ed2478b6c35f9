"""What ``mj_inverse`` needs of a closed chain's motion, shared by the delta's and the
five-bar's inverse-dynamics yardsticks (``scene.delta_inverse``, ``scene.fivebar_inverse``):
the passive joints' speeds and accelerations that keep the loop closed while the actuated
joints move at qdot, qddot, and the joint forces of that motion with the constraints off.

With the loop's rows J = [J_a J_p] (J_p square), qvel = G qdot, G = [I; -J_p^-1 J_a], and
J qacc + Jdot qvel = 0 with Jdot qvel by a central difference of J along qvel. MuJoCo is
imported here (the scene side only)."""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

__all__ = ["chain_motion", "unconstrained_inverse"]

JDOT_STEP = 1e-6
"""The central difference's step along qvel (in the time qvel moves qpos)."""


def chain_motion(
    model: mujoco.MjModel,
    qpos: np.ndarray,
    jac: np.ndarray,
    rows: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    arm_dof,
    passive_dof,
    qd: np.ndarray,
    qdd: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(qvel, qacc, G (nv, actuated)) of the chain at ``qpos`` (closed) whose loop rows there
    are ``jac``, ``rows(qpos) -> (residual, jacobian)`` giving them anywhere, with the actuated
    dofs ``arm_dof`` at speeds ``qd`` and accelerations ``qdd``; dofs in neither list hold."""
    ja, jp = jac[:, arm_dof], jac[:, passive_dof]
    g = np.zeros((model.nv, len(qd)))
    g[arm_dof] = np.eye(len(qd))
    g[passive_dof] = -np.linalg.solve(jp, ja)
    qvel = g @ qd
    jdot = []
    for sign in (1.0, -1.0):
        shifted = qpos.copy()
        mujoco.mj_integratePos(model, shifted, qvel, sign * JDOT_STEP)
        jdot.append(rows(shifted)[1])
    jdot_qvel = (jdot[0] - jdot[1]) @ qvel / (2.0 * JDOT_STEP)
    qacc = np.zeros(model.nv)
    qacc[arm_dof] = qdd
    qacc[passive_dof] = -np.linalg.solve(jp, ja @ qdd + jdot_qvel)
    return qvel, qacc, g


def unconstrained_inverse(
    model: mujoco.MjModel, data: mujoco.MjData, qpos, qvel, qacc
) -> np.ndarray:
    """qfrc_inverse with the constraints off: M qacc + c - passive (the bodies, gravity, the
    armature, the joints' damping)."""
    saved = model.opt.disableflags
    model.opt.disableflags = saved | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    try:
        data.qpos[:], data.qvel[:], data.qacc[:] = qpos, qvel, qacc
        mujoco.mj_inverse(model, data)
        return data.qfrc_inverse.copy()
    finally:
        model.opt.disableflags = saved
