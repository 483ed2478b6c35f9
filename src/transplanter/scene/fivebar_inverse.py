"""MuJoCo's inverse dynamics (``mj_inverse``) of the five-bar's own model (models/fivebar/
fivebar.xml with the scenario's config, ``build.robot_spec``) along a motion of its two arms,
as the torques its arm motors must give: the yardstick for the lumped model
(``FiveBarKinematics.inverse_dynamics``) that the ``bspline5`` planner holds to
``drives.arm_torque_limit_nm`` (docs/planner.md, "The five-bar").

The model carries a pot in its jaws for this (a cylinder of the load's mass welded to the
gripper at the grip centre: the pot the lumped model puts at C). Its closed chain: the arm
hinges theta1, theta2, the passive hinges phi1, phi2, the Z slide, the wrist and the two
jaws, tied by the ``five_bar_loop`` connect at C (its two horizontal rows: the passive links
lie in one plane, so the vertical row is identically zero) and the jaws' coupling. Per
sample, as ``scene.delta_inverse`` does for the delta:

1. positions: the arms at q; phi1, phi2 from the five-bar's closed form, polished by Newton's
   method on the connect's residual; Z, the wrist and the jaws held where they are (the
   transfer holds Z; the wrist's and the jaws' servos hold the gripper and the pot);
2. velocities: qvel = G qdot, G = [I; -J_p^-1 J_a] on the arm and passive columns of the
   connect's horizontal rows (zero on the held joints);
3. accelerations: J qacc + Jdot qvel = 0, Jdot qvel by a central difference of J;
4. ``mj_inverse`` with the constraints disabled: qfrc_inverse = M qacc + c - passive (the
   bodies, gravity, the rotors' armature, the passive hinges' damping);
5. the arm joints' torques by virtual work, tau = G^T qfrc_inverse, and at the motors
   tau / gear (the actuators' gear: the belt ratio).

MuJoCo is imported here only (the scene side); the planner does not use it.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from transplanter.scene.build import robot_spec
from transplanter.scene.closed_chain import chain_motion, unconstrained_inverse
from transplanter.scene.config import SceneConfig

__all__ = ["FiveBarInverse", "InverseResult", "load_fivebar_model"]

ARM_JOINTS = ("theta1", "theta2")
PASSIVE_JOINTS = ("phi1", "phi2")


def load_fivebar_model(cfg: SceneConfig, carried_kg: float) -> mujoco.MjModel:
    """The five-bar of ``cfg`` alone with a pot of ``carried_kg`` (a cylinder of the config's
    pot size, no contacts) welded to the gripper at its grip centre."""
    spec = robot_spec(cfg)
    site = spec.site("grip_center")
    pot = spec.body("gripper").add_body(name="carried_pot", pos=list(site.pos))
    pot.add_geom(
        name="carried_pot",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[0.5 * cfg.pot_diameter_m, 0.5 * cfg.pot_height_m, 0],
        mass=float(carried_kg),
        contype=0,
        conaffinity=0,
    )
    return spec.compile()


@dataclass
class InverseResult:
    """Per sample (k, 2): the arm motors' torques (N m at the motor shaft, as the lumped
    model and the actuators' forces), their gravity part (the same pose at rest), the
    passive hinges' damping part; the largest horizontal residual of the loop at C (m) and
    of its speed (m/s)."""

    torque: np.ndarray
    gravity: np.ndarray
    damping: np.ndarray
    closure_m: float
    closure_speed_m_s: float


class FiveBarInverse:
    """``mj_inverse`` of the five-bar model along arm motions (see the module's text)."""

    def __init__(self, cfg: SceneConfig, carried_kg: float, z_m: float | None = None):
        self.cfg = cfg
        self.model = load_fivebar_model(cfg, carried_kg)
        self.data = mujoco.MjData(self.model)
        self.kinematics = cfg.kinematics()
        m = self.model

        def dofs(names):
            return np.array([m.jnt_dofadr[m.joint(n).id] for n in names])

        def qadr(names):
            return np.array([m.jnt_qposadr[m.joint(n).id] for n in names])

        self.arm_dof, self.passive_dof = dofs(ARM_JOINTS), dofs(PASSIVE_JOINTS)
        self.arm_qpos, self.passive_qpos = qadr(ARM_JOINTS), qadr(PASSIVE_JOINTS)
        self.gear = np.array([m.actuator(n).gear[0] for n in ARM_JOINTS])
        self.sites = (m.site("c1").id, m.site("c2").id)
        self.qpos = m.qpos0.copy()
        if z_m is not None:
            self.qpos[m.joint("z").qposadr[0]] = z_m

    def _loop_rows(self, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(residual (2,), Jacobian (2, nv)) of the loop at C: c1 - c2 in the plane."""
        m, d = self.model, self.data
        d.qpos[:] = qpos
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        jacs = []
        for site in self.sites:
            jac = np.zeros((3, m.nv))
            mujoco.mj_jacSite(m, d, jac, None, site)
            jacs.append(jac)
        res = d.site_xpos[self.sites[0]] - d.site_xpos[self.sites[1]]
        return res[:2].copy(), (jacs[0] - jacs[1])[:2]

    def _close(self, q: np.ndarray) -> np.ndarray:
        """qpos with the arms at q and phi1, phi2 closing the loop (the closed form, then
        Newton on the model's own residual)."""
        qpos = self.qpos.copy()
        qpos[self.arm_qpos] = q
        qpos[self.passive_qpos] = np.asarray(self.kinematics.passive_angles(q[0], q[1]))
        for _ in range(20):
            res, jac = self._loop_rows(qpos)
            if np.abs(res).max() < 1e-14:
                break
            qpos[self.passive_qpos] -= np.linalg.solve(jac[:, self.passive_dof], res)
        return qpos

    def state(self, q, qd, qdd):
        """(qpos, qvel, qacc, G (nv, 2), closure residual (m), speed residual (m/s))."""
        m = self.model
        q, qd, qdd = (np.asarray(v, dtype=np.float64) for v in (q, qd, qdd))
        qpos = self._close(q)
        res, jac = self._loop_rows(qpos)
        qvel, qacc, g = chain_motion(
            m, qpos, jac, self._loop_rows, self.arm_dof, self.passive_dof, qd, qdd
        )
        return qpos, qvel, qacc, g, float(np.abs(res).max()), float(np.abs(jac @ qvel).max())

    def _inverse(self, qpos, qvel, qacc) -> np.ndarray:
        """qfrc_inverse with the constraints off: M qacc + c - passive."""
        return unconstrained_inverse(self.model, self.data, qpos, qvel, qacc)

    def torques(self, q, qd, qdd) -> InverseResult:
        """The arm motors' torques along samples (k, 2) of the arms' motion."""
        m = self.model
        q, qd, qdd = (np.atleast_2d(np.asarray(v, dtype=np.float64)) for v in (q, qd, qdd))
        damping = m.dof_damping.copy()
        out, grav, damp = (np.zeros((len(q), 2)) for _ in range(3))
        closure = speed = 0.0
        zero = np.zeros(m.nv)
        try:
            for k in range(len(q)):
                qpos, qvel, qacc, g, res, res_v = self.state(q[k], qd[k], qdd[k])
                closure, speed = max(closure, res), max(speed, res_v)
                out[k] = g.T @ self._inverse(qpos, qvel, qacc)
                grav[k] = g.T @ self._inverse(qpos, zero, zero)
                m.dof_damping[:] = 0.0
                damp[k] = out[k] - g.T @ self._inverse(qpos, qvel, qacc)
                m.dof_damping[:] = damping
        finally:
            m.dof_damping[:] = damping
        return InverseResult(out / self.gear, grav / self.gear, damp / self.gear, closure, speed)
