"""The index pushes a row skipped outside the physics, run in a model of that row alone.

A windowed scene (scene.live_rows) lets a row of a long belt into the physics a few indexes
before its pickup; on a belt with a body per pot the same row has been pushed by every index
since the trial began. Each push moves a pot in its cell (a random walk across the belt and a
small drift towards +x, docs/performance.md "The window of live rows"), so an entering row
placed at its drawn offsets would arrive with fewer pushes behind it than a row of the full
belt. `RowPushes` runs the skipped pushes: a small model of one row of the belt (the belt
table, the conveyor carriage with that row's ribs, the row's pots as `add_pots` builds them
for the full scene, the full scene's solver options and contact parameters) indexed by the
same `ConveyorDrive` profile, with a rest after each index until the pots lie still (they
rest between indexes on the machine too).

The carriage's drive is a PD controller (SceneConfig.conveyor_kp_n_m): how far it lags its
profile, and so where the ribs leave the pots, depends on how many pots it drags. On the
full belt index i drags the pots of rows i.. (the rows before have left at the pickup), so
the side model carries a ballast: one pot-shaped body in a cell of its own beside the row
(its own ribs, its own collision bit: it never meets the row's pots) with, at each push, the
mass of the other pots the full belt's carriage drags at that index and their mass-weighted
friction on the belt. Without it a carriage dragging five pots leaves them 0.2 mm behind
their cell centres where the 16-row belt's leaves them 0.9 mm, and they drift further across
(mean 1.5 mm after 4 pushes against 0.9). The ballast slides along the belt only, on a joint
whose dry friction is the pots' friction on the belt (a body of that mass standing on the
belt rocks on the low ribs).

`push` returns the pots' in-cell poses after each push: their offsets from the cell centre
as the carriage has carried it, height and orientation, which the window gives the entering
pots.

The side model holds no state between calls: the same row, pushes and index time give the
same poses, bit for bit.
"""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace
from typing import Any

import mujoco
import numpy as np

from transplanter.scene import kinds as scene_kinds
from transplanter.scene.config import ROLLING_FRICTION, TORSIONAL_FRICTION, row_bit
from transplanter.scene.conveyor import USERDATA_CONVEYOR, ConveyorDrive
from transplanter.scene.geometry import belt_table, cell_columns_x, pot_inertia, rib_boxes, row_y

__all__ = ["PUSH_CAP", "RowPushes", "REST_MAX_S", "modelled_indexes"]

PUSH_CAP = 17
"""The most index pushes a row is given before its pickup (the window's own and the side
model's together): past it the offsets' distribution no longer changes (measured with
benchmarks/push_cap.py, docs/performance.md "The window of live rows"), and it keeps a
row's cost bounded on a belt of any length."""

REST_MAX_S = 1.0
"""The longest rest after an index (s): the pots lie still (asleep, or slower than
REST_SPEED) well before it, and the machine's pick cycle between two indexes is longer."""
REST_SPEED = 1e-3
"""A pot slower than this (m/s and rad/s, every component) lies at rest (as scene.live_rows)."""
_OPTION_FIELDS = (
    "timestep", "impratio", "tolerance", "ls_tolerance", "noslip_tolerance", "ccd_tolerance",
    "sleep_tolerance", "gravity", "wind", "magnetic", "density", "viscosity", "o_margin",
    "o_solref", "o_solimp", "o_friction", "integrator", "cone", "jacobian", "solver",
    "iterations", "ls_iterations", "noslip_iterations", "ccd_iterations", "disableflags",
    "enableflags", "disableactuator", "sdf_initpoints", "sdf_iterations",
)  # fmt: skip
# contact parameters of the table and the ribs, as the full scene compiled them
_CONTACT_FIELDS = ("friction", "solref", "solimp", "solmix", "margin", "gap", "priority", "condim")


def modelled_indexes(row: int, done: int, cap: int = PUSH_CAP) -> range:
    """The full belt's indexes (1 the first) the side model runs for row `row` entering the
    physics after `done` indexes: those it skipped, of the last `cap` before its pickup
    (row `row` reaches the pickup after index `row`)."""
    return range(max(0, row - cap) + 1, done + 1)


class RowPushes:
    """Index pushes of one row of the belt, in a model of that row alone (module docstring).

    `scene` is the full scene (its config, pots and compiled model: the solver options and
    the contact parameters of its belt table and ribs are copied from it)."""

    def __init__(self, scene: Any):
        self.scene = scene
        # the drive of the side model: a belt of the full length, its ribs as built
        self.config = replace(scene.config, live_rows=scene.config.rows)
        main = scene.model
        table = main.geom("belt_table")
        self._table = {f: np.copy(getattr(table, f)) for f in _CONTACT_FIELDS}
        self._table_size = np.copy(table.size)
        rib = main.geom("rib_0_0")  # every rib has the same contact parameters
        self._rib = {f: np.copy(getattr(rib, f)) for f in _CONTACT_FIELDS}
        carriage = main.body("conveyor")
        self._carriage = (float(carriage.mass[0]), np.copy(carriage.inertia),
                          np.copy(carriage.ipos), np.copy(carriage.iquat))  # fmt: skip

    def model(self, row: int) -> mujoco.MjModel:
        """The side model of row `row`: table, carriage with the row's ribs, its pots."""
        cfg, pots = self.config, self.scene.pots
        spec = mujoco.MjSpec()
        spec.nuserdata = USERDATA_CONVEYOR
        size, pos = belt_table(cfg, float(self._table_size[2]))
        table = spec.worldbody.add_geom()
        table.name, table.type = "belt_table", mujoco.mjtGeom.mjGEOM_BOX
        table.size, table.pos = size, pos
        _set_contact(table, self._table)
        table.contype, table.conaffinity = 1, 6  # the workcell's "static" class
        # the ballast's cell beside the row stands on a table of its own: the row's pots stand
        # on a box of the full scene's size and place. A pot's flat bottom on the box is one
        # convex contact whose point depends on the box's extent: on a box widened for the
        # ballast the pots drifted 0.3 mm less across the belt per push series than on the
        # full scene's (docs/performance.md)
        aside = spec.worldbody.add_geom()
        aside.name, aside.type = "ballast_table", mujoco.mjtGeom.mjGEOM_BOX
        aside.size = [cfg.cell_pitch_m, size[1], size[2]]
        aside.pos = [size[0] + cfg.cell_pitch_m, pos[1], pos[2]]
        _set_contact(aside, self._table)
        aside.contype, aside.conaffinity = 1, 6
        body = spec.worldbody.add_body()
        body.name = "conveyor"
        joint = body.add_joint()
        joint.name, joint.type, joint.axis = "conveyor", mujoco.mjtJoint.mjJNT_SLIDE, [0, 1, 0]
        joint.frictionloss = cfg.conveyor_frictionloss_n
        joint.stiffness = [cfg.conveyor_hold_stiffness_n_m, 0.0, 0.0]
        joint.damping = [cfg.conveyor_hold_damping_n_s_m, 0.0, 0.0]
        mass, inertia, ipos, iquat = self._carriage
        body.mass, body.inertia, body.ipos, body.iquat = mass, inertia, ipos, iquat
        body.explicitinertial = True
        for k, (half, at) in enumerate(rib_boxes(cfg, row)):
            g = body.add_geom()
            g.name, g.type, g.size, g.pos = f"rib_{row}_{k}", mujoco.mjtGeom.mjGEOM_BOX, half, at
            _set_contact(g, self._rib)
            g.friction = [cfg.rib_friction, TORSIONAL_FRICTION, ROLLING_FRICTION]
            g.contype, g.conaffinity, g.mass = 0, row_bit(row), 0
        # the ballast's cell beside the row (+x), its ribs and the ballast: another row's bit
        ballast_bit = row_bit(row + 1)
        x = cell_columns_x(cfg)[-1] + cfg.cell_pitch_m
        y = row_y(cfg)[row]
        half_rib = cfg.rib_thickness_m / 2, cfg.rib_height_m / 2
        cross = [cfg.cell_pitch_m / 2, half_rib[0], half_rib[1]]  # before and behind it
        along = [half_rib[0], cfg.row_pitch_m / 2, half_rib[1]]  # on either side
        ribs = [(cross, [x, y + side * cfg.row_pitch_m / 2, half_rib[1]]) for side in (-1, 1)]
        ribs += [(along, [x + side * cfg.cell_pitch_m / 2, y, half_rib[1]]) for side in (-1, 1)]
        for k, (half, at) in enumerate(ribs):
            g = body.add_geom()
            g.name, g.type, g.size, g.pos = f"ballast_rib_{k}", mujoco.mjtGeom.mjGEOM_BOX, half, at
            _set_contact(g, self._rib)
            g.friction = [cfg.rib_friction, TORSIONAL_FRICTION, ROLLING_FRICTION]
            g.contype, g.conaffinity, g.mass = 0, ballast_bit, 0
        radius, height = float(pots.diameter.mean() / 2), float(pots.height.mean())
        ballast = spec.worldbody.add_body()
        ballast.name, ballast.pos = "ballast", [x, y, height / 2]
        slide = ballast.add_joint()  # along the belt only: it slides on the belt's friction
        slide.name, slide.type, slide.axis = "ballast", mujoco.mjtJoint.mjJNT_SLIDE, [0, 1, 0]
        ballast.mass, ballast.inertia = 1.0, pot_inertia(1.0, radius, height)
        ballast.explicitinertial = True
        g = ballast.add_geom()  # a pot's footprint as a box: it meets the ribs face on
        g.name, g.type, g.size = "ballast", mujoco.mjtGeom.mjGEOM_BOX, [radius, radius, height / 2]
        g.contype, g.conaffinity = ballast_bit, 0
        g.condim, g.priority = 4, 1  # as a pot's
        g.solref, g.solimp = list(cfg.contact_solref), list(cfg.contact_solimp)
        add_pots = scene_kinds.workcell(cfg.workcell_kind).add_pots
        add_pots(spec, cfg, pots, decor=False, count=cfg.cols, first=row * cfg.cols)
        model = spec.compile()
        for name in _OPTION_FIELDS:  # the full scene's solver options, as they are now
            setattr(model.opt, name, np.copy(getattr(self.scene.model.opt, name)))
        return model

    def load(self, row: int, index: int) -> tuple[float, float]:
        """(kg, friction) of the ballast at the full belt's index `index` (1 the first): the
        pots of rows index.. but `row`, their total mass and mass-weighted friction."""
        cfg, pots = self.config, self.scene.pots
        on = np.arange(index * cfg.cols, cfg.rows * cfg.cols)
        on = on[on // cfg.cols != row]
        mass = pots.mass[on] + cfg.shoot_mass_kg
        return float(mass.sum()), float((mass * pots.friction[on]).sum() / mass.sum())

    def push(
        self, row: int, indexes: list[int] | np.ndarray, index_s: float,
        errors_m: np.ndarray | None = None,
    ) -> np.ndarray:  # fmt: skip
        """(len(indexes) + 1, cols, 7): row `row`'s pots in their cells at rest as built (0)
        and after each push, the full belt's indexes `indexes` (1 the first: they set the
        ballast) of `index_s` (each leaving the row errors_m[i] off, as the twin's indexes
        do; default none): x and y from the cell centre as the carriage carries it, z, and
        the orientation (quaternion, w first)."""
        cfg = self.config
        cols = cfg.cols
        indexes = [int(i) for i in indexes]
        pushes = len(indexes)
        if not pushes <= row or not all(1 <= i < cfg.rows - 1 for i in indexes):
            raise ValueError(f"row {row} can be pushed by at most {row} indexes of 1 to "
                             f"{cfg.rows - 2}, not {indexes}")  # fmt: skip
        errors = np.zeros(pushes) if errors_m is None else np.asarray(errors_m, dtype=float)
        model = self.model(row)
        data = mujoco.MjData(model)
        scratch = mujoco.MjData(model)  # mj_setConst's workspace
        ballast = model.body("ballast").id
        ballast_dof = int(model.jnt_dofadr[model.joint("ballast").id])
        inertia = model.body_inertia[ballast].copy()  # of 1 kg
        mujoco.mj_forward(model, data)
        handles = SimpleNamespace(
            model=model, config=cfg, conveyor_qpos_adr=int(model.jnt_qposadr[0]),
            conveyor_dof_adr=int(model.jnt_dofadr[0]),
        )  # fmt: skip
        drive = ConveyorDrive(handles)
        q_adr = handles.conveyor_qpos_adr
        pot_q = np.array([model.jnt_qposadr[model.body(f"pot_{row}_{c}").jntadr[0]]
                          for c in range(cols)])  # fmt: skip
        pot_v = np.array([model.jnt_dofadr[model.body(f"pot_{row}_{c}").jntadr[0]]
                          for c in range(cols)])  # fmt: skip
        trees = model.body_treeid[[model.body(f"pot_{row}_{c}").id for c in range(cols)]]
        cells = np.column_stack([self.scene.pots.cell_xy[row * cols : (row + 1) * cols, 0],
                                 np.full(cols, row_y(cfg)[row])])  # fmt: skip
        out = np.empty((pushes + 1, cols, 7))

        def rest() -> None:
            end = data.time + REST_MAX_S
            while data.time < end:
                for _ in range(10):
                    mujoco.mj_step(model, data)
                asleep = data.tree_asleep[trees] >= 0
                speed = np.abs(np.stack([data.qvel[v : v + 6] for v in pot_v])).max(axis=1)
                if (asleep | (speed < REST_SPEED)).all():
                    return

        def record(i: int) -> None:
            for c, adr in enumerate(pot_q):
                out[i, c] = data.qpos[adr : adr + 7]
            out[i, :, 0] -= cells[:, 0]
            out[i, :, 1] -= cells[:, 1] + data.qpos[q_adr]

        rest()
        record(0)
        for i in range(pushes):
            mass, friction = self.load(row, indexes[i])
            model.body_mass[ballast], model.body_inertia[ballast] = mass, mass * inertia
            # the pots' friction on the belt, as the slide's dry friction
            model.dof_frictionloss[ballast_dof] = friction * mass * -model.opt.gravity[2]
            mujoco.mj_setConst(model, scratch)  # the weights the solver derives from masses
            drive.start(data, data.time, index_s, error_m=float(errors[i]))
            while drive.armed(data):
                drive.apply(data, data.time)
                mujoco.mj_step(model, data)
            rest()
            record(i + 1)
        return out


def _set_contact(geom: Any, fields: dict) -> None:
    for name, value in fields.items():
        setattr(geom, name, value.item() if value.size == 1 else value)
