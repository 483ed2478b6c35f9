"""The conveyor's index drive: a controller of the scene's unactuated conveyor carriage.

The belt table is static (it ends at the front edge of the pickup row); the pots stand on it
and are pushed by the 5 mm ribs of the `conveyor` carriage, an UNACTUATED slide (so it
sleeps with its resting pots). Between indexes its drive holds it: the joint's stiffness and
damping (a stepper's detent stiffness through its pulley,
SceneConfig.conveyor_hold_stiffness_n_m) pull it back to ``qpos_spring``, the position the last
index ended at; a passive force lets the tree sleep at rest, an actuator would not.
`ConveyorDrive.start(data, now, total_s)` arms a smooth profile followed by a short hold,
all within total_s (the carriage is at rest and released by now + total_s, when the firmware
acknowledges M710); `apply(data, now)`, called before every physics step while
`armed(data)`, drives the carriage along it (SceneConfig.conveyor_index_drive): "pd" writes a
PD force following it into `qfrc_applied` of the conveyor dof (the hold off meanwhile);
"stepper" moves the hold's set point (`qpos_spring`) along it, so the stepper's own stiffness
pulls the carriage, and writes the damping times the profile's speed into `qfrc_applied`
(the joint's damping then acts on the carriage's speed relative to the profile's). A
non-zero applied force is MuJoCo's documented way to wake a sleeping tree, and writing back
an exact 0.0 at the end lets it fall asleep again. The profile overshoots by the cell
clearance and comes back, so the ribs push every pot to its new cell centre and then leave
it free (no rib contact at rest, so the pots and the carriage do not form one island).

Where the state lives: the index state (active flag, start time, profile duration, end time,
start position) is in data.userdata[0:USERDATA_CONVEYOR], nowhere else, so it is part of
the MjData and copies with it (mujoco.mj_copyData, copy.copy). The drive object itself holds
only constants of the model (addresses, gains), so one drive serves any MjData of its scene.
The hold is in the model (jnt_stiffness and dof_damping of the slide, off during a "pd"
index; qpos_spring, the held position, moved along a "stepper" index and set as each index
ends), edited like the ribs below.

Rows past the edge: each row's ribs collide only with that row's pots (collision bits
8..31). When an index carries a row's cells off the belt's top run, its ribs go round the
front drum: `start` turns their collisions off and hides them, which edits the MODEL (a
Scene's model is shared by its MjData: one simulation at a time). Which rows are off is a
function of the carriage position alone, and `start` sets every row (off or back on) from it,
so a copied or rewound MjData gets the right ribs at its next index.

A windowed scene (scene.live_rows) carries only a few rows of ribs, each row a massless body
on the carriage: `start` moves each to the row it serves next, again a function of the
carriage position alone (the first rows not past the edge after this index, in turn).
"""

from __future__ import annotations

import math
from typing import Protocol

import mujoco
import numpy as np

from transplanter.scene.config import RIB_RGBA, SceneConfig, row_bit


class ConveyorHandles(Protocol):
    """What the drive reads of a scene (``handles.Scene`` has it): the compiled model, the
    scene's config and the conveyor slide's addresses."""

    model: mujoco.MjModel
    config: SceneConfig
    conveyor_qpos_adr: int
    conveyor_dof_adr: int


USERDATA_CONVEYOR = 6
INDEX_ERROR_STREAM = 0x1DE7
"""The random stream of the index's drawn error (`conveyor.index_error_sd_mm`), with the
trial's seed: the same errors whatever robot works the line."""
_U_ACTIVE, _U_T0, _U_PROFILE, _U_END, _U_Q0, _U_ERR = range(USERDATA_CONVEYOR)


def conveyor_armed(data: mujoco.MjData) -> bool:
    """True from an index's start until the drive has released it (see ConveyorDrive)."""
    return data.userdata[_U_ACTIVE] != 0.0


class ConveyorDrive:
    """Indexes the conveyor carriage of a Scene one row at a time (see the module docstring)."""

    def __init__(self, scene: ConveyorHandles):
        self.model = scene.model
        self.config = scene.config
        self.qpos_adr = scene.conveyor_qpos_adr
        self.dof_adr = scene.conveyor_dof_adr
        if self.model.nuserdata < USERDATA_CONVEYOR:
            raise ValueError(
                f"the model has nuserdata={self.model.nuserdata}; the conveyor needs "
                f"{USERDATA_CONVEYOR} (<size nuserdata=...> of the workcell's XML)"
            )
        m, rows = self.model, self.config.rows
        self._rib_bodies = np.zeros(0, dtype=int)
        if self.config.windowed:  # rows of ribs that move to the rows they serve
            rows = self.config.rib_slot_rows
            self._rib_bodies = np.array([m.body(f"ribs_{k}").id for k in range(rows)])
        # The drive's hold (joint stiffness about qpos_spring, and damping) as built; off
        # while a "pd" index drives the carriage, back at the new position after it.
        self._joint = int(m.dof_jntid[self.dof_adr])
        self._hold = (float(m.jnt_stiffness[self._joint]), float(m.dof_damping[self.dof_adr]))
        self._by_pd = self.config.conveyor_index_drive == "pd"
        self._rib_geoms_by_row = [
            np.array([g for g in range(m.ngeom) if (m.geom(g).name or "").startswith(f"rib_{r}_")])
            for r in range(rows)
        ]
        # as built: each row's own collision bit, opaque
        self._rib_conaffinity = [row_bit(r) for r in range(rows)]
        self._rib_alpha = [RIB_RGBA[3]] * rows
        self._row_y = self.config.pickup_row_y_m + np.arange(rows) * self.config.row_pitch_m
        # the row each row of ribs serves (as built: its own)
        self.rib_rows = np.arange(rows)

    def index_phases(self, total_s: float) -> tuple[float, float]:
        """Split an index's total time (s) into (profile, settle) durations (s).

        settle = min(conveyor_settle_s, 0.25 * total_s): the PD hold at the end of the profile
        that lets the carriage and the pots come to rest before the force is released.
        """
        settle = min(self.config.conveyor_settle_s, 0.25 * total_s)
        return total_s - settle, settle

    def start(self, data: mujoco.MjData, now: float, total_s: float, error_m: float = 0.0) -> None:
        """Index the conveyor by one row (towards -y), done by `now + total_s`; the index
        leaves the row `error_m` beyond its nominal place (belt stretch, rib play), where
        the drive then holds it until the next index takes the error back.

        total_s is the whole index time (the scenario's index time, after which the SGF
        acknowledges M710): the carriage follows the push-and-return profile, is held while
        it settles (index_phases), and by now + total_s it is at rest, the drive force is
        released and a new index may start.
        """
        if not (math.isfinite(total_s) and total_s > 0):
            raise ValueError(f"conveyor index time must be > 0 s, got {total_s}")
        u = data.userdata
        if u[_U_ACTIVE] != 0.0:
            if not self._done(data, now):
                raise RuntimeError(
                    f"conveyor is already indexing until t = {u[_U_END]:.4f} s (now {now:.4f} "
                    "s); wait until ConveyorDrive.indexing() is False"
                )
            self._release(data)
        profile_s, _ = self.index_phases(total_s)
        pitch = self.config.row_pitch_m
        q0 = round(data.qpos[self.qpos_adr] / pitch) * pitch
        if self._by_pd:  # the PD force alone drives it; the stepper's hold leads it otherwise
            self.model.jnt_stiffness[self._joint] = 0.0
            self.model.dof_damping[self.dof_adr] = 0.0
        self._set_rows_past_the_edge(q0 - pitch)
        u[_U_ACTIVE], u[_U_T0], u[_U_PROFILE], u[_U_END], u[_U_Q0], u[_U_ERR] = (
            1.0,
            now,
            profile_s,
            now + total_s,
            q0,
            error_m,
        )

    def armed(self, data: mujoco.MjData) -> bool:
        """True from start until apply has released the drive: as long as this holds,
        apply must be called before every physics step."""
        return conveyor_armed(data)

    def indexing(self, data: mujoco.MjData, now: float) -> bool:
        """True while an index (profile and settle) is under way, until start + total_s.

        It ends half a timestep early, so that rounding in data.time cannot add a step.
        """
        return conveyor_armed(data) and not self._done(data, now)

    def reference(self, data: mujoco.MjData, now: float) -> tuple[float, float]:
        """Reference position (m) and velocity (m/s) of the carriage at `now`.

        Min-jerk push by row_pitch_m + overshoot over conveyor_push_share of the profile, then
        min-jerk return by the overshoot; after the profile it holds the end position.
        """
        u = data.userdata
        t0, duration, q0 = u[_U_T0], u[_U_PROFILE], u[_U_Q0]
        cfg = self.config
        push_share = cfg.conveyor_push_share
        t = min(max(now - t0, 0.0), duration)
        overshoot = cfg.index_overshoot_m
        travel = cfg.row_pitch_m + u[_U_ERR] + overshoot
        if t < push_share * duration:
            T = push_share * duration
            s, ds = _min_jerk(t / T)
            return q0 - travel * s, -travel * ds / T
        T = (1 - push_share) * duration
        s, ds = _min_jerk((t - push_share * duration) / T)
        return q0 - travel + overshoot * s, overshoot * ds / T

    def apply(self, data: mujoco.MjData, now: float) -> None:
        """Call before every physics step: drive the carriage along the index profile
        (SceneConfig.conveyor_index_drive), else nothing."""
        if data.userdata[_U_ACTIVE] == 0.0:
            return
        if self._done(data, now):
            self._release(data)
            return
        cfg = self.config
        q_ref, v_ref = self.reference(data, now)
        if self._by_pd:
            q = data.qpos[self.qpos_adr]
            v = data.qvel[self.dof_adr]
            force = cfg.conveyor_kp_n_m * (q_ref - q) + cfg.conveyor_kd_n_s_m * (v_ref - v)
        else:  # the hold's spring pulls towards q_ref; its damper acts on v - v_ref
            self.model.qpos_spring[self.qpos_adr] = q_ref
            force = self._hold[1] * v_ref
        # -0.0 would also wake the tree; an exact zero would let it sleep mid-index.
        data.qfrc_applied[self.dof_adr] = force if force != 0.0 else 1e-12

    def position(self, data: mujoco.MjData) -> float:
        """Carriage position (m; 0 at build, -row_pitch_m after one index)."""
        return float(data.qpos[self.qpos_adr])

    def _done(self, data: mujoco.MjData, now: float) -> bool:
        # Half a timestep of slack: data.time, a sum of timesteps, drifts by rounding.
        return now >= data.userdata[_U_END] - 0.5 * self.model.opt.timestep

    def _release(self, data: mujoco.MjData) -> None:
        # An exact 0.0 lets the carriage's tree fall asleep again.
        data.qfrc_applied[self.dof_adr] = 0.0
        data.userdata[_U_ACTIVE] = 0.0
        u = data.userdata
        self.model.qpos_spring[self.qpos_adr] = u[_U_Q0] - self.config.row_pitch_m - u[_U_ERR]
        self.model.jnt_stiffness[self._joint], self.model.dof_damping[self.dof_adr] = self._hold

    def hold_position(self) -> float:
        """Where the drive holds the carriage between indexes (m)."""
        return float(self.model.qpos_spring[self.qpos_adr])

    def displacement(self, data: mujoco.MjData) -> float:
        """How far (m) the carriage is off the position its drive holds; 0 while indexing."""
        if conveyor_armed(data):
            return 0.0
        return float(data.qpos[self.qpos_adr] - self.model.qpos_spring[self.qpos_adr])

    def grid_offset(self, data: mujoco.MjData) -> float:
        """How far (m) the carriage is off its nominal row grid (whole row pitches): what
        the next index takes back (the hold's own error and any index error)."""
        pitch = self.config.row_pitch_m
        q = float(data.qpos[self.qpos_adr])
        return q - round(q / pitch) * pitch

    def _set_rows_past_the_edge(self, q_after: float) -> None:
        """Rows whose cells leave the belt's top run at this index go round the front drum:
        their ribs stop touching anything and are no longer drawn; the other rows' ribs are
        as built. Without this the ribs of emptied rows would sweep on through the drop tube
        and jam on the pot dropped last."""
        edge = self.config.pickup_row_y_m - self.config.row_pitch_m / 2
        if self._rib_bodies.size:
            self._move_rib_rows(edge, q_after)
            return
        rows = zip(
            self._row_y, self._rib_geoms_by_row, self._rib_conaffinity, self._rib_alpha,
            strict=True,
        )  # fmt: skip
        for y, geoms, conaffinity, alpha in rows:
            past = y + q_after < edge - 1e-9
            self.model.geom_conaffinity[geoms] = 0 if past else conaffinity
            self.model.geom_rgba[geoms, 3] = 0.0 if past else alpha

    def _move_rib_rows(self, edge: float, q_after: float) -> None:
        """A windowed scene's ribs: the rows of ribs serve, in turn, the first rows whose cells
        are still on the belt's top run after this index (row r by ribs r mod their count)."""
        cfg, m = self.config, self.model
        pitch, y0 = cfg.row_pitch_m, cfg.pickup_row_y_m
        first = max(0, math.ceil((edge - 1e-9 - q_after - y0) / pitch - 1e-9))
        n = self._rib_bodies.size
        for k, (body, geoms) in enumerate(
            zip(self._rib_bodies, self._rib_geoms_by_row, strict=True)
        ):
            row = first + (k - first) % n
            self.rib_rows[k] = row
            on = row < cfg.rows
            m.body_pos[body, 1] = y0 + row * pitch
            # the body's own filter too: the broadphase pairs bodies by it first
            m.body_conaffinity[body] = m.geom_conaffinity[geoms] = row_bit(row) if on else 0
            m.geom_rgba[geoms, 3] = RIB_RGBA[3] if on else 0.0


def _min_jerk(tau: float) -> tuple[float, float]:
    tau = min(max(tau, 0.0), 1.0)
    s = tau**3 * (10 - 15 * tau + 6 * tau**2)
    ds = 30 * tau**2 * (1 - tau) ** 2
    return s, ds
