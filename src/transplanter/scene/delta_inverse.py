"""MuJoCo's inverse dynamics (``mj_inverse``) of the delta model (models/delta/delta.xml) along
a motion of its three arms, as the torques the three actuated joints must give: the yardstick
for the lumped model of Eq. 9 (``DeltaKinematics.inverse_dynamics``, after Zhao et al. 2022,
"Research on the End Effector and Optimal Motion Control Strategy for a Plug Seedling
Transplanting Parallel Robot") that the planner holds to the torque limit.

The model is a closed chain: 21 degrees of freedom (three arm hinges, two hinges on each of
the six rods, the platform's free joint) tied by six ``connect`` equalities (18 equations),
3 left. ``mj_inverse`` needs a full state, and with the equalities on it would add their
soft-constraint force computed from how far ``qacc`` strays from the constraint's reference
acceleration, which is noise at this stiffness. So, per sample:

1. positions: the arms at q; the 18 passive coordinates by Newton's method on the
   equalities' residual (``efc_pos``, their Jacobian ``efc_J``), continued from the last
   sample;
2. velocities: qdot_p = -J_p^-1 J_a qdot (the equalities' rows J = [J_a J_p], J_p square),
   i.e. qvel = G qdot with G = [I; -J_p^-1 J_a];
3. accelerations: J qacc + Jdot qvel = 0, Jdot qvel by a central difference of J along qvel;
4. ``mj_inverse`` with the constraints disabled: qfrc_inverse = M qacc + c - passive (rigid
   bodies, gravity, the armature, the joints' damping);
5. the actuated joints' torques by virtual work: tau = G^T qfrc_inverse (the equalities'
   forces do no work along G), which is the solution of M qacc + c - passive = S^T tau +
   J^T lambda for tau (the residual is reported).

MuJoCo is imported here only (the scene side); the pure planner does not use it.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from transplanter.scene.closed_chain import chain_motion, unconstrained_inverse
from transplanter.scene.delta_scene import models_dir

__all__ = ["DeltaInverse", "load_delta_model"]

ARM_JOINTS = ("q1", "q2", "q3")


def load_delta_model() -> mujoco.MjModel:
    """The bare delta (models/delta/delta.xml: no claws, no trays)."""
    return mujoco.MjModel.from_xml_path(str(models_dir() / "delta" / "delta.xml"))


@dataclass
class InverseResult:
    """Per sample (k, 3): the actuated joints' torques (N m at the joint, positive lowering the
    arm, as Eq. 9), their gravity part (the same state at rest), the joints' damping part, and
    the largest residual of the full equations of motion after the projection (N or N m), the
    largest equality residual (m) and velocity residual (m/s)."""

    torque: np.ndarray
    gravity: np.ndarray
    damping: np.ndarray
    residual: float
    closure_m: float
    closure_speed_m_s: float


class DeltaInverse:
    """``mj_inverse`` of the delta model along arm motions (see the module's text)."""

    def __init__(self, model: mujoco.MjModel | None = None):
        self.model = model if model is not None else load_delta_model()
        self.data = mujoco.MjData(self.model)
        m = self.model
        ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name) for name in ARM_JOINTS]
        self.arm_qpos = np.array([m.jnt_qposadr[i] for i in ids])
        self.arm_dof = np.array([m.jnt_dofadr[i] for i in ids])
        self.passive_dof = np.setdiff1d(np.arange(m.nv), self.arm_dof)
        key = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "home")
        self.qpos = m.key_qpos[key].copy() if key >= 0 else m.qpos0.copy()

    # -- the closed chain's state ---------------------------------------------------------
    def _equality_rows(self, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(residual (18,), Jacobian (18, nv)) of the six connects at qpos."""
        m, d = self.model, self.data
        d.qpos[:] = qpos
        mujoco.mj_fwdPosition(m, d)
        rows = np.flatnonzero(d.efc_type[: d.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY)
        jac = np.asarray(d.efc_J[: d.nefc * m.nv]).reshape(d.nefc, m.nv)
        return d.efc_pos[rows].copy(), jac[rows].copy()

    def _close(self, q: np.ndarray, qpos: np.ndarray) -> np.ndarray:
        """qpos with the arms at q and the passive coordinates solving the equalities
        (Newton's method from the given qpos)."""
        m = self.model
        qpos = qpos.copy()
        qpos[self.arm_qpos] = q
        for _ in range(50):
            res, jac = self._equality_rows(qpos)
            if np.abs(res).max() < 1e-13:
                break
            step = np.zeros(m.nv)
            step[self.passive_dof] = -np.linalg.lstsq(jac[:, self.passive_dof], res, rcond=None)[0]
            mujoco.mj_integratePos(m, qpos, step, 1.0)
            qpos[self.arm_qpos] = q
        return qpos

    def state(self, q, qd, qdd, qpos_guess=None):
        """(qpos, qvel, qacc, G (nv, 3), closure residual (m)) of the closed chain with the
        arms at q, qdot, qddot."""
        m = self.model
        q, qd, qdd = (np.asarray(v, dtype=np.float64) for v in (q, qd, qdd))
        qpos = self._close(q, self.qpos if qpos_guess is None else qpos_guess)
        res, jac = self._equality_rows(qpos)
        qvel, qacc, g = chain_motion(
            m, qpos, jac, self._equality_rows, self.arm_dof, self.passive_dof, qd, qdd
        )
        return qpos, qvel, qacc, g, float(np.abs(res).max())

    def _inverse(self, qpos, qvel, qacc) -> np.ndarray:
        """qfrc_inverse with the constraints off: M qacc + c - passive."""
        return unconstrained_inverse(self.model, self.data, qpos, qvel, qacc)

    # -- the torques --------------------------------------------------------------------
    def torques(self, q, qd, qdd) -> InverseResult:
        """The actuated joints' torques along samples (k, 3) of the arms' motion (consecutive
        samples: each closes the chain from the last one)."""
        m = self.model
        q, qd, qdd = (np.atleast_2d(np.asarray(v, dtype=np.float64)) for v in (q, qd, qdd))
        damping = m.dof_damping.copy()
        out = np.zeros((len(q), 3))
        grav = np.zeros((len(q), 3))
        damp = np.zeros((len(q), 3))
        worst, closure, speed = 0.0, 0.0, 0.0
        qpos = None
        try:
            # walk the chain from the home pose to the first sample
            for s in np.linspace(0.0, 1.0, 11)[1:]:
                qpos = self._close(
                    (1 - s) * self.qpos[self.arm_qpos] + s * q[0],
                    self.qpos if qpos is None else qpos,
                )
            for k in range(len(q)):
                qpos, qvel, qacc, g, res = self.state(q[k], qd[k], qdd[k], qpos)
                _, jac = self._equality_rows(qpos)
                closure = max(closure, res)
                speed = max(speed, float(np.abs(jac @ qvel).max()))
                f = self._inverse(qpos, qvel, qacc)
                out[k] = g.T @ f
                # the full equations: f = S^T tau + J^T lambda, lambda from the passive rows
                lam = np.linalg.lstsq(jac[:, self.passive_dof].T, f[self.passive_dof], rcond=None)[
                    0
                ]
                worst = max(
                    worst,
                    float(np.abs(f[self.arm_dof] - out[k] - jac[:, self.arm_dof].T @ lam).max()),
                )
                zero = np.zeros(m.nv)
                grav[k] = g.T @ self._inverse(qpos, zero, zero)
                m.dof_damping[:] = 0.0
                damp[k] = out[k] - g.T @ self._inverse(qpos, qvel, qacc)
                m.dof_damping[:] = damping
        finally:
            m.dof_damping[:] = damping
        return InverseResult(out, grav, damp, worst, closure, speed)
