"""The window of live rows: a long conveyor's pots as a few rows of reused bodies.

Every pot on the belt as a body of its own makes a step's cost grow with the belt's length
(MuJoCo's broadphase walks every collidable body at every step, asleep or not, and each
index pushes every pot). With `SceneConfig.live_rows` below `rows`, the model holds the
bodies of the first live_rows rows only (`pot_{r}_{c}`, the slots) and rows of ribs that
move to the rows they serve (`ConveyorDrive`). A pot of a later row rides the belt outside
the physics, in its cell at its drawn offset, until its row enters: the slots of `cols`
pots that have left the physics take its pots' masses, inertias, sizes, frictions, wall
softness, row bits and feet (compiled from the same `add_pots` as a body per pot, so the fields
are the compiler's own) and their poses in the cells the carriage has carried them to.

A pot leaves the physics when the judge parks it (`release`), or, once its row is two
indexes past the pickup, when it lies at rest (a failed pot on the floor or the belt's
edge: it is frozen where it lies); a pot of a row three indexes past it that still moves is
frozen too when its slot is needed (`frozen_moving` counts those). A row enters as soon as
a row's worth of slots is free, checked at every index start and after every release:
normally after the first pickup of the row before it (when the last pot of the row picked
before that has been parked), so it gets live_rows - 1 index pushes before its own pickup
(live_rows - 2 when a failed pot of that row was still moving), enough for the pots'
offsets across the belt to settle (config.settle_pushes). This is bookkeeping at index and
release events, never per step.

Which pot a slot holds lives here and in the model, not in the MjData (like the ribs of
`ConveyorDrive`): one simulation at a time per scene.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from transplanter.scene import kinds as scene_kinds

__all__ = ["LiveRows"]

# Model fields of a pot body, its six dofs and its geom that its draws decide: copied from
# the compiler's output for the pot onto the slot that takes it.
_BODY_FIELDS = (
    "body_mass", "body_subtreemass", "body_inertia", "body_ipos", "body_iquat",
    "body_invweight0", "body_contype", "body_conaffinity", "body_margin",
)  # fmt: skip
_DOF_FIELDS = ("dof_invweight0", "dof_M0")
_GEOM_FIELDS = (
    "geom_size", "geom_rbound", "geom_aabb", "geom_friction", "geom_solimp", "geom_solref",
    "geom_contype", "geom_conaffinity",
)  # fmt: skip
# A pot's feet (SceneConfig.pot_feet) sit on a ring by its radius, at its base by its height.
_FOOT_FIELDS = ("geom_pos", *_GEOM_FIELDS)
REST_SPEED = 1e-3
"""A pot slower than this (m/s and rad/s, every component) lies at rest."""
WAITING, LIVE, GONE = 0, 1, 2
"""A pot's place: on the belt outside the physics, a body, out of the physics for good."""


class LiveRows:
    """Which pot each slot body holds, and the pots' places outside the physics."""

    def __init__(self, scene: Any):  # the Scene (scene.handles) that owns the window
        cfg = scene.config
        self.scene, self.config = scene, cfg
        self.cols = cfg.cols
        n_slots = cfg.body_rows * cfg.cols
        n_pots = cfg.rows * cfg.cols
        self.slot_body = scene.pot_bodies.ravel()[:n_slots].copy()
        self.slot_geom = scene.pot_geoms[:n_slots].copy()
        self.slot_qadr = scene.pot_qpos_adr[:n_slots].copy()
        self.slot_dadr = scene.pot_dof_adr[:n_slots].copy()
        self.slot_pot = np.arange(n_slots)  # -1: free
        self.state = np.full(n_pots, WAITING, dtype=np.int8)
        self.state[:n_slots] = LIVE
        # the index count when each pot entered the physics (-1: not yet)
        self.entered_at = np.full(n_pots, -1, dtype=int)
        self.entered_at[:n_slots] = 0
        self.gone_pose = np.zeros((n_pots, 7))  # xyz, quat (w first) of the pots gone
        self.next_row = cfg.body_rows
        self.indexes = 0  # indexes started so far
        self.frozen_moving = 0  # pots taken out of the physics while still moving
        pots = scene.pots
        self._rest_z = pots.height / 2
        self._tree = scene.model.body_treeid[self.slot_body]
        m = scene.model
        # the machine's and the carriage's joints come before the pots' free joints
        self.machine_nq = m.nq - 7 * n_slots
        self.machine_nv = m.nv - 6 * n_slots
        self.slot_feet = _feet(m, n_slots, cfg.cols, cfg.pot_feet)
        self._slot_bvh = m.body_bvhadr[self.slot_body].copy()
        self._slot_nbvh = m.body_bvhnum[self.slot_body].copy()

    # ----- where the pots are -----
    def live(self) -> np.ndarray:
        """Flat indices of the pots that are bodies now (sorted)."""
        return np.flatnonzero(self.state == LIVE)

    def waiting_positions(self, data: mujoco.MjData, pots: np.ndarray) -> np.ndarray:
        """(n, 3) centres of waiting pots: their cells, carried with the carriage."""
        xy = self.scene.pots.cell_xy[pots] + self.scene.pots.offset[pots]
        out = np.empty((len(pots), 3))
        out[:, 0] = xy[:, 0]
        out[:, 1] = xy[:, 1] + data.qpos[self.scene.conveyor_qpos_adr]
        out[:, 2] = self._rest_z[pots]
        return out

    def positions(self, data: mujoco.MjData) -> np.ndarray:
        """(rows*cols, 3) every pot's centre: a body's, a waiting pot's carried cell, or where
        a pot that left the physics lies."""
        out = self.gone_pose[:, :3].copy()
        live = self.live()
        out[live] = data.xpos[self.scene.pot_bodies.ravel()[live]]
        waiting = np.flatnonzero(self.state == WAITING)
        out[waiting] = self.waiting_positions(data, waiting)
        return out

    def poses(self, data: mujoco.MjData) -> np.ndarray:
        """(rows*cols, 7) every pot's free-joint pose (xyz, quat w first): a body's, a
        waiting pot's upright in its carried cell, or where a pot that left lies."""
        out = self.gone_pose.copy()
        for slot, pot in enumerate(self.slot_pot.tolist()):
            if pot >= 0:
                adr = self.slot_qadr[slot]
                out[pot] = data.qpos[adr : adr + 7]
        waiting = np.flatnonzero(self.state == WAITING)
        out[waiting, :3] = self.waiting_positions(data, waiting)
        out[waiting, 3:] = (1.0, 0.0, 0.0, 0.0)
        return out

    # ----- events -----
    def on_index(self, data: mujoco.MjData) -> None:
        """An index starts (before the drive moves the carriage): rows enter if they fit."""
        self.indexes += 1
        self.fill(data)

    def release(self, data: mujoco.MjData, pot: int) -> None:
        """The pot leaves the physics where its body lies now (the judge parked it); its
        slot is free, and rows enter if they now fit."""
        self._free(data, pot)
        self.fill(data)

    def fill(self, data: mujoco.MjData) -> None:
        """Rows enter while a row's worth of slots is free (pots of rows two indexes past
        the pickup that lie at rest leave first)."""
        cols = self.cols
        while self.next_row < self.config.rows:
            free = np.flatnonzero(self.slot_pot < 0)
            if free.size < cols:
                self._free_resting(data)
                free = np.flatnonzero(self.slot_pot < 0)
                if free.size < cols:
                    return
            self._enter(data, self.next_row, free[:cols])
            self.next_row += 1

    def _free_resting(self, data: mujoco.MjData) -> None:
        """Pots of rows that left the pickup an index ago or more and lie at rest (asleep,
        or slower than REST_SPEED with sleep off) leave the physics where they lie; when
        that frees too few slots, so do the pots of rows two indexes past it, moving or
        not (counted in `frozen_moving`)."""
        for slack in (2, 3):
            done_rows = self.indexes - slack
            for slot in np.flatnonzero(self.slot_pot >= 0).tolist():
                pot = int(self.slot_pot[slot])
                if pot // self.cols > done_rows:
                    continue
                dadr = self.slot_dadr[slot]
                resting = data.tree_asleep[self._tree[slot]] >= 0 or (
                    np.abs(data.qvel[dadr : dadr + 6]).max() < REST_SPEED
                )
                if resting or slack == 3:
                    self.frozen_moving += not resting
                    self._free(data, pot)
            if np.count_nonzero(self.slot_pot < 0) >= self.cols:
                return

    def _free(self, data: mujoco.MjData, pot: int) -> None:
        if self.state[pot] != LIVE:
            return
        sc = self.scene
        slot = int(np.flatnonzero(self.slot_pot == pot)[0])
        qadr = self.slot_qadr[slot]  # a free body's pose (the judge may just have moved it)
        self.gone_pose[pot] = data.qpos[qadr : qadr + 7]
        self.state[pot] = GONE
        self.slot_pot[slot] = -1
        sc.set_pot_body(pot, -1, -1, -1, -1)

    def _enter(self, data: mujoco.MjData, row: int, slots: np.ndarray) -> None:
        """Row `row`'s pots take these slots, at rest in their cells as carried now."""
        sc, m = self.scene, self.scene.model
        pots = row * self.cols + np.arange(self.cols)
        lib = self._row_library(row)
        lib_feet = _feet(lib, self.cols, self.cols, self.config.pot_feet, first_row=row)
        where = self.waiting_positions(data, pots)
        for k, (slot, pot) in enumerate(zip(slots.tolist(), pots.tolist(), strict=True)):
            body, geom = int(self.slot_body[slot]), int(self.slot_geom[slot])
            qadr, dadr = int(self.slot_qadr[slot]), int(self.slot_dadr[slot])
            lib_body = lib.body(f"pot_{row}_{k}").id
            lib_geom = lib.geom(f"pot_{row}_{k}").id
            lib_dof = lib.jnt_dofadr[lib.body_jntadr[lib_body]]
            for name in _BODY_FIELDS:
                getattr(m, name)[body] = getattr(lib, name)[lib_body]
            for name in _DOF_FIELDS:
                getattr(m, name)[dadr : dadr + 6] = getattr(lib, name)[lib_dof : lib_dof + 6]
            for name in _GEOM_FIELDS:
                getattr(m, name)[geom] = getattr(lib, name)[lib_geom]
            for name in _FOOT_FIELDS:
                getattr(m, name)[self.slot_feet[slot]] = getattr(lib, name)[lib_feet[k]]
            adr, n = self._slot_bvh[slot], self._slot_nbvh[slot]
            lib_adr = lib.body_bvhadr[lib_body]
            m.bvh_aabb[adr : adr + n] = lib.bvh_aabb[lib_adr : lib_adr + n]
            data.qpos[qadr : qadr + 3] = where[k]
            data.qpos[qadr + 3 : qadr + 7] = (1.0, 0.0, 0.0, 0.0)
            data.qvel[dadr : dadr + 6] = 0.0
            data.qacc_warmstart[dadr : dadr + 6] = 0.0
            self.slot_pot[slot] = pot
            self.state[pot] = LIVE
            self.entered_at[pot] = self.indexes
            sc.set_pot_body(pot, body, geom, qadr, dadr)

    def _row_library(self, row: int) -> mujoco.MjModel:
        """Row `row`'s pots compiled on their own, as `add_pots` builds a body per pot."""
        add_pots = scene_kinds.workcell(self.config.workcell_kind).add_pots
        spec = mujoco.MjSpec()
        add_pots(spec, self.config, self.scene.pots, decor=False, count=self.cols,
                 first=row * self.cols)  # fmt: skip
        return spec.compile()


def _feet(m: mujoco.MjModel, n_pots: int, cols: int, feet: int, first_row: int = 0) -> np.ndarray:
    """(n_pots, feet) geom ids of the feet of pots first_row*cols .. + n_pots - 1 of `m`."""
    out = np.zeros((n_pots, feet), dtype=int)
    for i in range(n_pots):
        r, c = divmod(first_row * cols + i, cols)
        out[i] = [m.geom(f"foot_{r}_{c}_{k}").id for k in range(feet)]
    return out
