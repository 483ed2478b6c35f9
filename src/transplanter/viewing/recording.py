"""Record a simulated trial to a rerun .rrd file (`transplanter.viewing.playback` reads it back).

The geometry is taken from the compiled ``MjModel`` and logged once as static data; body
poses and scalar channels are buffered at a fixed frame rate in numpy arrays and written in
columns (``send_columns``), so recording costs almost nothing per physics step.

Entity layout::

    world                               view coordinates (right-handed, z up)
    world/bodies/<body>                 the body's world pose (flat: one entity per body)
    world/bodies/<body>/<geom>          the geom's shape, its pose relative to the body
    scalars/<group>/<channel>           scalar time series, e.g. ``scalars/motors/theta1``
    events                              text log of trial events (grasp, release, failure ...)

Everything temporal is on the ``sim_time`` duration timeline (seconds of simulated time).
"""

from __future__ import annotations

import dataclasses
import math
import os
import uuid
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from transplanter import fileio
from transplanter.errors import TransplanterError

TIMELINE = "sim_time"
BODIES_ROOT = "world/bodies"
SCALARS_ROOT = "scalars"
EVENTS_ENTITY = "events"

# MuJoCo's viewer shows geom groups 0, 1 and 2 by default; higher groups hold collision
# or helper geoms that a replay should not draw.
_FIRST_HIDDEN_GEOM_GROUP = 3
# A geom's rgba equal to MuJoCo's internal default means "use the material colour".
_MUJOCO_DEFAULT_RGBA = np.array([0.5, 0.5, 0.5, 1.0], dtype=np.float32)
_EVENT_LEVELS = {"failure": "WARN"}
_DEFAULT_EVENT_LEVEL = "INFO"


@dataclass(frozen=True)
class RecordingConfig:
    """Settings of a recording that a user may want to change (SI units)."""

    rate_hz: float = 60.0  # frames per second of simulated time
    flush_frames: int = 3600  # frames buffered before they are sent (bounds the memory)
    plane_half_size: float = 1.0  # m, drawn half extent of an infinite (size 0) plane
    plane_thickness: float = 0.002  # m, planes are drawn as a thin box below their surface

    def __post_init__(self) -> None:
        if not (math.isfinite(self.rate_hz) and self.rate_hz > 0.0):
            raise ValueError(f"rate_hz must be a positive finite number, got {self.rate_hz!r}")
        if self.flush_frames < 1:
            raise ValueError(f"flush_frames must be at least 1, got {self.flush_frames!r}")
        if not (self.plane_half_size > 0.0 and self.plane_thickness > 0.0):
            raise ValueError("plane_half_size and plane_thickness must be positive (metres)")


def _name(model: mujoco.MjModel, obj: mujoco.mjtObj, index: int, fallback: str) -> str:
    name = mujoco.mj_id2name(model, obj, index)
    return rr.escape_entity_path_part(name) if name else f"{fallback}_{index}"


def _xyzw(quat_wxyz: np.ndarray) -> np.ndarray:
    """MuJoCo quaternions (w, x, y, z) to rerun's order (x, y, z, w)."""
    return np.asarray(quat_wxyz)[..., [1, 2, 3, 0]]


def _rgba8(rgba: np.ndarray) -> np.ndarray:
    return np.clip(np.round(np.asarray(rgba) * 255.0), 0, 255).astype(np.uint8)


def _geom_rgba(model: mujoco.MjModel, geom_id: int) -> np.ndarray:
    """The colour MuJoCo draws: the material's unless the geom sets its own rgba."""
    rgba = model.geom_rgba[geom_id]
    mat_id = model.geom_matid[geom_id]
    if mat_id >= 0 and np.allclose(rgba, _MUJOCO_DEFAULT_RGBA):
        return model.mat_rgba[mat_id]
    return rgba


def _mesh_archetype(model: mujoco.MjModel, mesh_id: int, rgba8: np.ndarray) -> rr.Mesh3D:
    """The compiled mesh, one vertex per face corner so each face gets its flat normal."""
    vert_start, vert_count = model.mesh_vertadr[mesh_id], model.mesh_vertnum[mesh_id]
    face_start, face_count = model.mesh_faceadr[mesh_id], model.mesh_facenum[mesh_id]
    vertices = model.mesh_vert[vert_start : vert_start + vert_count]
    faces = model.mesh_face[face_start : face_start + face_count]
    corners = vertices[faces]  # (faces, 3 corners, xyz)
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, lengths, out=np.zeros_like(normals), where=lengths > 0.0)
    return rr.Mesh3D(
        vertex_positions=corners.reshape(-1, 3),
        vertex_normals=np.repeat(normals, 3, axis=0),
        triangle_indices=np.arange(3 * face_count, dtype=np.uint32).reshape(-1, 3),
        albedo_factor=rgba8,
    )


def _geom_archetype(model: mujoco.MjModel, geom_id: int, config: RecordingConfig):
    """The rerun archetype that draws a geom in its own frame, or None if not drawable."""
    geom_type = mujoco.mjtGeom(model.geom_type[geom_id])
    size = model.geom_size[geom_id]
    rgba8 = _rgba8(_geom_rgba(model, geom_id))
    colors = [rgba8]
    if geom_type == mujoco.mjtGeom.mjGEOM_BOX:
        return rr.Boxes3D(half_sizes=[size], colors=colors, fill_mode="solid")
    if geom_type == mujoco.mjtGeom.mjGEOM_SPHERE:
        return rr.Ellipsoids3D(half_sizes=[[size[0]] * 3], colors=colors, fill_mode="solid")
    if geom_type == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        return rr.Ellipsoids3D(half_sizes=[size], colors=colors, fill_mode="solid")
    if geom_type == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return rr.Cylinders3D(
            lengths=[2.0 * size[1]], radii=[size[0]], colors=colors, fill_mode="solid"
        )
    if geom_type == mujoco.mjtGeom.mjGEOM_CAPSULE:
        # rerun's capsule runs from its origin along +z; MuJoCo's is centred.
        return rr.Capsules3D(
            lengths=[2.0 * size[1]],
            radii=[size[0]],
            translations=[[0.0, 0.0, -size[1]]],
            colors=colors,
            fill_mode="solid",
        )
    if geom_type == mujoco.mjtGeom.mjGEOM_PLANE:
        half_x = size[0] if size[0] > 0.0 else config.plane_half_size
        half_y = size[1] if size[1] > 0.0 else config.plane_half_size
        half_z = 0.5 * config.plane_thickness
        return rr.Boxes3D(
            half_sizes=[[half_x, half_y, half_z]],
            centers=[[0.0, 0.0, -half_z]],
            colors=colors,
            fill_mode="solid",
        )
    if geom_type == mujoco.mjtGeom.mjGEOM_MESH:
        return _mesh_archetype(model, model.geom_dataid[geom_id], rgba8)
    return None  # height fields and SDFs are not drawn


def _is_visible(model: mujoco.MjModel, geom_id: int) -> bool:
    return (
        model.geom_group[geom_id] < _FIRST_HIDDEN_GEOM_GROUP and _geom_rgba(model, geom_id)[3] > 0.0
    )


def _validate_scalar_names(scalar_names: Sequence[str]) -> list[str]:
    names = list(scalar_names)
    for name in names:
        if not isinstance(name, str) or not name or any(not p for p in name.split("/")):
            raise ValueError(
                f"scalar name {name!r} is not a path like 'motors/theta1': use non-empty "
                "parts separated by single '/'"
            )
    duplicates = sorted(n for n, c in Counter(names).items() if c > 1)
    if duplicates:
        raise ValueError(f"scalar names must be unique, repeated: {duplicates}")
    return names


class RecordingError(TransplanterError, RuntimeError):
    """The recording could not be written (the trial's results are not affected)."""


class TrialRecorder:
    """Buffers a trial's body poses, scalar channels and events and writes them to an .rrd.

    Call ``frame(t, data, scalars)`` at every physics step: it records only on the
    ``1/rate_hz`` grid (``rate_hz`` None takes ``config.rate_hz``, 60 Hz by default).
    Call ``event(...)`` when something happens and ``close()`` at the end (or use it as a
    context manager). The file appears at ``path`` only once it is complete; one that cannot
    even be started (a full disk, a directory it may not write) raises RecordingError and
    leaves no temporary file.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        path: str | os.PathLike,
        rate_hz: float | None = None,
        scalar_names: Sequence[str] = (),
        application_id: str = "transplanter",
        blueprint: bool = True,
        config: RecordingConfig | None = None,
    ) -> None:
        config = config if config is not None else RecordingConfig()
        if rate_hz is not None:
            config = dataclasses.replace(config, rate_hz=rate_hz)
        self.config = config
        self.path = Path(path)
        if self.path.suffix != ".rrd":
            raise ValueError(f"recording path {str(self.path)!r} must end in .rrd")
        if not self.path.parent.is_dir():
            raise FileNotFoundError(
                f"directory {str(self.path.parent)!r} for the recording does not exist: create it"
            )
        self.scalar_names = _validate_scalar_names(scalar_names)
        self._blueprint = blueprint
        # The recording grows in an exclusively created temporary file beside its target (a
        # symlink's target) and replaces it only once complete.
        self._target = Path(os.path.realpath(self.path)) if self.path.is_symlink() else self.path
        try:
            self._tmp_path = fileio.temp_beside(self._target)
        except OSError as exc:  # a full disk (no room for the name), a read-only directory
            raise RecordingError(self._cannot_write(exc)) from exc

        body_names = [_name(model, mujoco.mjtObj.mjOBJ_BODY, b, "body") for b in range(model.nbody)]
        self.body_entities = [f"{BODIES_ROOT}/{name}" for name in body_names]
        # A body welded to the world (no joint on its path to the world, not mocap) never moves.
        self.moving_body_ids = np.flatnonzero(model.body_weldid != 0)
        self.static_body_ids = np.flatnonzero(model.body_weldid == 0)

        self._rate_hz = self.config.rate_hz
        self._grid_tolerance_s = 1e-9
        self._next_frame_t = -math.inf
        self._last_frame_t = -math.inf
        capacity = self.config.flush_frames
        n_moving = len(self.moving_body_ids)
        # float32: rerun stores translations and quaternions as float32 anyway.
        self._times = np.empty(capacity, dtype=np.float64)
        self._positions = np.empty((capacity, n_moving, 3), dtype=np.float32)
        self._quats_wxyz = np.empty((capacity, n_moving, 4), dtype=np.float32)
        self._scalars = np.empty((capacity, len(self.scalar_names)), dtype=np.float64)
        self._n_buffered = 0
        self.n_frames = 0
        self._events: list[tuple[float, str, str, int | None]] = []
        self.event_counts: Counter[str] = Counter()
        self.skipped_geoms: list[str] = []
        self.closed = False

        self._stream = rr.RecordingStream(application_id, recording_id=uuid.uuid4())
        if not self._stream.is_enabled():
            fileio.discard(self._tmp_path)
            raise RuntimeError(
                "rerun logging is disabled (environment variable RERUN="
                f"{os.environ.get('RERUN')!r}): unset RERUN to record {str(self.path)!r}"
            )
        try:
            self._stream.save(self._tmp_path)  # writes the file's header: a full disk fails here
        except Exception as exc:
            self._stream.disconnect()
            fileio.discard(self._tmp_path)
            raise RecordingError(self._cannot_write(exc)) from exc
        try:
            self._log_static_scene(model)
        except BaseException:
            self._stream.disconnect()
            fileio.discard(self._tmp_path)
            raise

    # -- static scene -------------------------------------------------------------------

    def _log_static_scene(self, model: mujoco.MjModel) -> None:
        log = self._stream.log
        log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        # Bodies welded to the world have the same pose for any qpos: take it from a fresh
        # forward kinematics pass so it does not depend on the caller's data.
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        for body_id in self.static_body_ids:
            log(
                self.body_entities[body_id],
                rr.Transform3D(
                    translation=data.xpos[body_id], quaternion=_xyzw(data.xquat[body_id])
                ),
                static=True,
            )
        for geom_id in range(model.ngeom):
            if not _is_visible(model, geom_id):
                continue
            body_entity = self.body_entities[model.geom_bodyid[geom_id]]
            entity = f"{body_entity}/{_name(model, mujoco.mjtObj.mjOBJ_GEOM, geom_id, 'geom')}"
            archetype = _geom_archetype(model, geom_id, self.config)
            if archetype is None:
                self.skipped_geoms.append(entity)
                continue
            log(
                entity,
                rr.Transform3D(
                    translation=model.geom_pos[geom_id],
                    quaternion=_xyzw(model.geom_quat[geom_id]),
                ),
                archetype,
                static=True,
            )

    # -- per step -----------------------------------------------------------------------

    def due(self, t: float) -> bool:
        """Whether ``frame(t, ...)`` would record (compute costly scalars only then)."""
        return t >= self._next_frame_t

    def frame(
        self, t: float, data: mujoco.MjData, scalars: np.ndarray | None = None, force: bool = False
    ) -> None:
        """Record the moving bodies' poses and the scalars if ``t`` reached the next frame
        (or, with ``force``, now: the last state of a trial, off the frame grid)."""
        if t < self._next_frame_t and not (force and t > self._last_frame_t):
            if t < self._last_frame_t:
                raise ValueError(
                    f"frame time {t} s is before the last recorded frame at "
                    f"{self._last_frame_t} s: use a new TrialRecorder for a new trial"
                )
            return
        self._record(t, data, scalars)

    def _record(self, t: float, data: mujoco.MjData, scalars: np.ndarray | None) -> None:
        if self.closed:
            raise RuntimeError(f"recorder for {str(self.path)!r} is closed")
        if not math.isfinite(t):
            raise ValueError(f"frame time must be finite, got {t!r}")
        n_channels = len(self.scalar_names)
        if n_channels:
            if scalars is None:
                raise ValueError(
                    f"frame() needs scalars with {n_channels} values ({self.scalar_names})"
                )
            values = np.asarray(scalars, dtype=np.float64).reshape(-1)
            if values.shape != (n_channels,):
                raise ValueError(
                    f"scalars has {values.size} values, expected {n_channels} "
                    f"in the order {self.scalar_names}"
                )
        elif scalars is not None and np.size(scalars):
            raise ValueError("scalars given but the recorder was created without scalar_names")

        row = self._n_buffered
        self._times[row] = t
        self._positions[row] = data.xpos[self.moving_body_ids]
        self._quats_wxyz[row] = data.xquat[self.moving_body_ids]
        if n_channels:
            self._scalars[row] = values
        self._n_buffered += 1
        self.n_frames += 1
        self._last_frame_t = t
        next_index = math.floor(t * self._rate_hz + 1e-6) + 1
        self._next_frame_t = next_index / self._rate_hz - self._grid_tolerance_s
        if self._n_buffered == len(self._times):
            self._send_buffered_frames()

    def event(self, t: float, kind: str, text: str, seedling: int | None = None) -> None:
        """Buffer a trial event; ``kind`` 'failure' is logged as a warning."""
        if self.closed:
            raise RuntimeError(f"recorder for {str(self.path)!r} is closed")
        if not isinstance(kind, str) or not kind:
            raise ValueError(f"event kind must be a non-empty string, got {kind!r}")
        if not math.isfinite(t):
            raise ValueError(f"event time must be finite, got {t!r}")
        self._events.append(
            (float(t), kind, str(text), None if seedling is None else int(seedling))
        )
        self.event_counts[kind] += 1

    def log_at(self, t: float, entity: str, *archetypes) -> None:
        """Log rerun archetypes on an entity at simulated time `t` now (for what changes
        seldom, such as the delta's tray state; the poses and scalars go by `frame`)."""
        if self.closed:
            raise RuntimeError(f"recorder for {str(self.path)!r} is closed")
        if not math.isfinite(t):
            raise ValueError(f"log time must be finite, got {t!r}")
        self._stream.set_time(TIMELINE, duration=float(t))
        self._stream.log(entity, *archetypes)

    # -- writing ------------------------------------------------------------------------

    def _send_buffered_frames(self) -> None:
        n = self._n_buffered
        if n == 0:
            return
        send = self._stream.send_columns
        times = [rr.TimeColumn(TIMELINE, duration=self._times[:n])]
        quats_xyzw = _xyzw(self._quats_wxyz[:n])
        for column, body_id in enumerate(self.moving_body_ids):
            send(
                self.body_entities[body_id],
                indexes=times,
                columns=rr.Transform3D.columns(
                    translation=self._positions[:n, column],
                    quaternion=quats_xyzw[:, column],
                ),
            )
        for column, name in enumerate(self.scalar_names):
            send(
                f"{SCALARS_ROOT}/{name}",
                indexes=times,
                columns=rr.Scalars.columns(scalars=self._scalars[:n, column]),
            )
        self._n_buffered = 0

    def _send_events(self) -> None:
        if not self._events:
            return
        events = sorted(self._events, key=lambda e: e[0])
        texts = [
            f"{kind}: {text}" + ("" if seedling is None else f" (seedling {seedling})")
            for _, kind, text, seedling in events
        ]
        self._stream.send_columns(
            EVENTS_ENTITY,
            indexes=[rr.TimeColumn(TIMELINE, duration=[e[0] for e in events])],
            columns=[
                *rr.TextLog.columns(
                    text=texts,
                    level=[_EVENT_LEVELS.get(e[1], _DEFAULT_EVENT_LEVEL) for e in events],
                ),
                *rr.AnyValues.columns(
                    kind=[e[1] for e in events],
                    seedling=[-1 if e[3] is None else e[3] for e in events],
                ),
            ],
        )
        self._events.clear()

    def _default_blueprint(self) -> rrb.Blueprint:
        groups = list(dict.fromkeys(name.split("/")[0] for name in self.scalar_names))
        side = [rrb.TimeSeriesView(origin=f"{SCALARS_ROOT}/{g}", name=g) for g in groups]
        side.append(rrb.TextLogView(origin=EVENTS_ENTITY, name="events"))
        return rrb.Blueprint(
            rrb.Horizontal(
                rrb.Spatial3DView(origin="world", name="scene"),
                rrb.Vertical(*side),
                column_shares=[3, 2],
            ),
            collapse_panels=True,
        )

    def close(self, path: str | os.PathLike | None = None, follow: bool = True) -> None:
        """Write everything buffered, finish the file and move it to ``path`` (by default the
        path given at creation). Idempotent. On failure (disk full, say) the temporary file
        is removed, an older file at the path is left as it was, and RecordingError says why.
        A symlink at ``path`` is written through (the user's name) or, with ``follow`` False
        (a name the program derived), replaced by the recording itself.
        """
        if self.closed:
            return
        self.closed = True
        try:
            try:
                self._send_buffered_frames()
                self._send_events()
                if self._blueprint:
                    self._stream.send_blueprint(self._default_blueprint())
                self._stream.flush()
            finally:
                self._stream.disconnect()
            target = self._target if path is None else Path(path)
            fileio.commit(self._tmp_path, target, follow=follow)
        except BaseException as exc:
            fileio.discard(self._tmp_path)
            if isinstance(exc, Exception):
                raise RecordingError(self._cannot_write(exc)) from exc
            raise

    def _cannot_write(self, exc: BaseException) -> str:
        return f"the recording {str(self.path)!r} could not be written: {exc}"

    def abort(self) -> None:
        """Stop recording and remove the unfinished file; an older file at the path stays."""
        if self.closed:
            return
        self.closed = True
        try:
            self._stream.disconnect()
        finally:
            fileio.discard(self._tmp_path)

    def __enter__(self) -> TrialRecorder:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()
