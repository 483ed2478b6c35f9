"""The serial arm on the seedling job (`transplanter trial serial_arm_pots`): the arm of seed
004 (Dewi, Nurmaini, Risma, Oktarina and Roriz, *Inverse kinematic analysis of 4 DOF pick and
place arm robot manipulator using fuzzy logic controller*) with its fuzzy gripper on the
five-bar's pot line (the `conveyor_tube` workcell of seed 000: paper pots in rows on a
feeding conveyor, a drop tube), so that its cycle and success stand beside the five-bar's.

The chain is the serial arm's (`twin.serial_arm`): host over the bus, the SGF with the arm's
IK per point, the 50 Hz PWM frames, the hobby servos, MuJoCo. The arm stands on a pedestal
in front of the line, turned to face it (`[serial_pots]`). Sensor 1 of the paper is one
HC-SR04 per cell of the pickup row, in front of it, looking across the belt: it reads the pot
in its cell (Near) or the next row behind (Medium: no pot). Sensor 2 is on the gripper. For
every pot of the pickup row the host reads the cell's sensor, comes down over the pot, reads
both sensors again, sends the fuzzy controller's angle and lifts; if the cell's sensor still
hears the pot, the grasp missed and the host opens and tries again (`[serial_pots]
attempts`); else it carries the pot over the drop tube and opens to standby. After the row,
`M710` indexes the conveyor (the five-bar's M-code: the SGF acknowledges it after
`conveyor.index_time_ms`, the scene's conveyor drive moves the carriage); a pot left on the
belt goes over its front edge with the row.

Judged from the physics at the end: a pot inside the tube below the funnel's throat is a
success; one still on the belt was missed; anywhere else it was dropped.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from types import SimpleNamespace
from typing import Any

import mujoco
import numpy as np

from transplanter.machine.fuzzy_gripper import NO_ECHO
from transplanter.machine.host import Call, Wait
from transplanter.scenario.assemble import require_awake
from transplanter.twin.serial_arm import (
    SENSE_CYCLE_S,
    GripRecord,
    _compile,
    _g1,
    _ms,
    _park_point,
    _Ranger,
    _Rig,
    _Squeeze,
    grasp_items,
    release_items,
    require_own_motion,
    world_to_paper,
)

__all__ = [
    "PotRecord",
    "finish_observers",
    "SerialPotsResult",
    "line_config",
    "pitch_release",
    "PotBook",
    "run_serial_pots",
]

DETECTED_CM = 5.0
"""Sensor 1 reads a pot in its cell when nearer than this (the controller's Near core)."""
PEDESTAL_HALF_M = 0.045
"""The pedestal under the arm's base plate: 90 mm square (estimate)."""

DEFINITIONS = {
    "success": "the pot fell into the drop tube below the funnel's throat (then planted)",
    "missed": "the pot still on the belt (not lifted, or slipped back)",
    "dropped": "the pot neither in the tube nor on the belt",
    "no pot": "sensor 1 of the cell read no pot: the host skipped it",
    "cycle_time_s": "mean time from one pot's pick to the next's (indexes included)",
    "seedlings_per_hour": "3600 / cycle_time_s",
}


def line_config(sc):
    """The pot line of the scenario (its `[conveyor]`, `[pots]`, `[drop_tube]` and physics
    sections) as the five-bar's scene config, which the conveyor_tube workcell reads; the
    five-bar's own numbers in it are not used (no five-bar in this scene)."""
    from transplanter.scenario.assemble import machine_config, scene_config

    five = replace(
        sc,
        robot=replace(sc.robot, kind="fivebar"),
        effector=replace(sc.effector, kind="parallel_jaw"),
    )
    line = scene_config(five, machine_config(five))
    return replace(line, live_rows=line.rows)  # every row's pots are bodies: no window


def finish_observers(observers, records, t: float) -> str | None:
    """Each pot's verdict as an event at the end of its pick, the observers closed; the first
    one's error (None: written)."""
    for observer in observers:
        for rec in records:
            if rec.start_s is not None:
                kind = "seedling" if rec.outcome == "success" else "failure"
                at = rec.end_s if rec.end_s is not None else t
                observer.event(at, kind, f"pot {rec.index} ({rec.pot}): {rec.outcome}", rec.index)
        observer.finish(t)
    return next((o.error for o in observers if getattr(o, "error", None)), None)


def _reporter(progress, records, dt: float):
    """A per-step hook calling `progress(done, sim_t)` once a simulated second: the records
    whose pick has ended (or that the host skipped)."""
    every = max(1, round(1.0 / dt))
    k = [0]

    def fn(t: float) -> None:
        k[0] += 1
        if k[0] % every == 0:
            done = sum(r.end_s is not None or r.outcome == "no pot" for r in records)
            progress(done, t)

    return fn


class PotBook:
    """The pots a pot job on the five-bar's line (`line`: its scene config) picks: a record
    and a body id for each of the first `n` cells, the one in the gripper (`holding`), the
    planting unit and the host's marks."""

    def __init__(self, line, model: mujoco.MjModel, data: mujoco.MjData, n: int):
        self.records = [
            PotRecord(i, f"pot_{i // line.cols}_{i % line.cols}", *divmod(i, line.cols))
            for i in range(n)
        ]
        self.body_ids = {r.pot: model.body(r.pot).id for r in self.records}
        self.holding: list[int] = []
        self.model, self.data = model, data
        self._throat_r = line.funnel_throat_diameter_m / 2
        self._throat_z = line.funnel_top_z_m - line.funnel_height_m
        self._tube_xy = line.drop_tube_xy_m
        self._planted: list[int] = []

    def _in_tube(self, rec) -> bool:
        x, y, z = (float(v) for v in self.data.xpos[self.body_ids[rec.pot]])
        tx, ty = self._tube_xy
        return math.hypot(x - tx, y - ty) < self._throat_r and z < self._throat_z

    def plant(self) -> None:
        """The planting unit takes every picked pot below the funnel's throat away, marking
        its record a success, and rests it far from the machine (as the five-bar's judge
        parks them)."""
        model, data = self.model, self.data
        for rec in self.records:
            if rec.start_s is None or rec.outcome == "success" or not self._in_tube(rec):
                continue
            rec.outcome = "success"
            adr = model.jnt_qposadr[model.body_jntadr[self.body_ids[rec.pot]]]
            dof = model.jnt_dofadr[model.body_jntadr[self.body_ids[rec.pot]]]
            k = len(self._planted)
            data.qpos[adr : adr + 3] = (1.0 + 0.1 * (k % 10), -1.0 - 0.1 * (k // 10), -0.13)
            data.qpos[adr + 3 : adr + 7] = (1.0, 0.0, 0.0, 0.0)
            data.qvel[dof : dof + 6] = 0.0
            self._planted.append(rec.index)

    def mark(self, i: int, key: str):
        """The host's mark of pot i's `key` ("start_s", "end_s"): its time in the record,
        the pot in the gripper from its start, the planting unit at its end."""

        def fn(t: float) -> None:
            setattr(self.records[i], key, t)
            self.holding[:] = [i] if key == "start_s" else []
            if key == "end_s":
                self.plant()

        return fn


def pitch_release(kin, grasp, over, lowest_y: float, max_tilt_rad: float) -> np.ndarray:
    """The release point over ``over`` (paper frame x, z; its y unused): the arm has no
    wrist, so the gripper, and the pot it holds, tilt with the forearm (theta2 + theta3); a
    pot released at the grasp's pitch hangs as it stood on the belt, but over the tube, nearer
    the base than the cells, that pitch lies high (a long fall). The lowest point at or above
    ``lowest_y`` whose pitch differs from the grasp's by at most ``max_tilt_rad``; ValueError
    where no point over ``over`` has the grasp's pitch within reach."""
    l1, l2 = kin.geometry.l1_m, kin.geometry.l2_m
    q = kin.joints(np.asarray(grasp, dtype=np.float64))
    pitch = float(q[1] + q[2])
    r = math.hypot(float(over[0]), float(over[2]))
    c2 = (r - l2 * math.cos(pitch)) / l1
    if not -1.0 <= c2 <= 1.0:
        raise ValueError(f"no point {r * 1e3:.1f} mm from the base axis has the grasp's pitch")
    theta2 = math.acos(c2)  # the upper arm above the horizontal (the elbow-up branch)
    level = l1 * math.sin(theta2) + l2 * math.sin(pitch)  # the grasp's pitch exactly

    def tilt(y: float) -> float:
        j = kin.joints(np.array([float(over[0]), y, float(over[2])]))
        return abs(float(j[1] + j[2]) - pitch)

    lo, hi = float(lowest_y), max(float(lowest_y), level)
    if tilt(lo) <= max_tilt_rad:
        return np.array([float(over[0]), lo, float(over[2])])
    for _ in range(40):  # the tilt falls as the point rises towards the grasp's pitch
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if tilt(mid) <= max_tilt_rad else (mid, hi)
    return np.array([float(over[0]), hi, float(over[2])])


PLACEMENT_KEYS = "serial_pots.base_x_mm, base_y_mm, base_z_mm, base_yaw_deg"


def check_placement(sc) -> None:
    """ScenarioError naming the placement keys when the arm on its pedestal cannot reach a
    pickup cell, the hover point above it, or a release over the drop tube at the grasp's
    pitch (the arm's reach, base-axis radius and joint windows: `Serial4Kinematics.check`);
    nothing is built or run."""
    from transplanter.machine.kinematics.serial4 import Serial4Kinematics
    from transplanter.scenario.schema import ScenarioError
    from transplanter.scene.geometry import cell_columns_x

    job = sc.serial_pots
    line = line_config(sc)
    kin = Serial4Kinematics.from_scenario(sc)
    base, yaw = (job.base_x_m, job.base_y_m, job.base_z_m), job.base_yaw_rad
    where = f"the arm's base at ({', '.join(f'{1e3 * v:g}' for v in base)}) mm, yaw " \
        f"{math.degrees(yaw):g} deg"  # fmt: skip
    up = np.array([0.0, sc.serial_arm.hover_m, 0.0])
    for col, x in enumerate(cell_columns_x(line)):
        grasp = world_to_paper(np.array([x, line.pickup_row_y_m, job.grasp_z_m]), base, yaw)
        report = kin.check(np.stack([grasp, grasp + up]))
        for point, ok, why in zip(("the grasp", "the hover point above it"), report.ok,
                                  report.reasons, strict=True):  # fmt: skip
            if not ok:
                raise ScenarioError(
                    f"{where} cannot reach {point} of pickup column {col + 1} "
                    f"(x {1e3 * x:.1f} mm on the belt): {why}; move it ({PLACEMENT_KEYS}) "
                    "or change [serial4] l1_mm, l2_mm"
                )
        top = line.funnel_top_z_m
        over = world_to_paper(np.array([*line.drop_tube_xy_m, top]), base, yaw)
        lowest = float(world_to_paper(np.array([0.0, 0.0, top + job.release_gap_m
                                                + job.grasp_z_m]), base, yaw)[1])  # fmt: skip
        try:
            release = pitch_release(kin, grasp, over, lowest, job.release_tilt_rad)
        except ValueError as exc:
            raise ScenarioError(
                f"{where} cannot release column {col + 1}'s pot over the drop tube: {exc}; "
                f"move it ({PLACEMENT_KEYS})"
            ) from None
        report = kin.check(np.stack([release, release + up]))
        if not report.ok.all():
            why = next(r for r in report.reasons if r)
            raise ScenarioError(
                f"{where} cannot reach the release over the drop tube for column {col + 1}: "
                f"{why}; move it ({PLACEMENT_KEYS})"
            )


def _scene(sc, seed: int):
    from transplanter.scene import serial_scene
    from transplanter.scene.geometry import cell_columns_x

    job = sc.serial_pots
    line = line_config(sc)
    cfg = serial_scene.serial_scene_config(sc, workcell_kind="conveyor_tube", workcell=line)
    cfg = replace(
        cfg,
        base_pos_m=(job.base_x_m, job.base_y_m, job.base_z_m),
        base_yaw_rad=job.base_yaw_rad,
        decor=False,
    )
    spec = serial_scene.build_serial_spec(cfg, seed)
    ground = min(
        (float(g.pos[2]) for g in spec.worldbody.geoms if g.type == mujoco.mjtGeom.mjGEOM_PLANE),
        default=0.0,
    )
    half_h = 0.5 * (job.base_z_m - ground)
    if half_h > 0:
        spec.worldbody.add_geom(
            name="pedestal",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[PEDESTAL_HALF_M, PEDESTAL_HALF_M, half_h],
            pos=[job.base_x_m, job.base_y_m, ground + half_h],
            contype=1,
            conaffinity=6,
            rgba=[0.45, 0.45, 0.5, 1],
        )
    # sensor 1 of each pickup cell: in front of the row, looking across the belt (+y)
    y = line.pickup_row_y_m - line.pot_diameter_m / 2 - job.sensor_gap_m
    for c, x in enumerate(cell_columns_x(line)):
        body = spec.worldbody.add_body(name=f"station_sensor_c{c}", pos=[x, y, job.sensor_z_m])
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[0.0225, 0.001, 0.01],
            contype=0,
            conaffinity=0,
            group=2,
            rgba=[0.1, 0.45, 0.2, 1],
        )
        body.add_site(name=f"station_sensor_c{c}", zaxis=[0, 1, 0], size=[0.002, 0, 0])
    return spec, cfg, line


@dataclass
class PotRecord(GripRecord):
    index: int
    pot: str
    row: int
    col: int
    attempts: int = 0
    """Grasps tried (another while sensor 1 still heard the pot in its cell after the lift)."""

    def as_dict(self) -> dict:
        return {
            "index": self.index,
            "pot": self.pot,
            "row": self.row,
            "col": self.col,
            **self.grip_dict(),
            "attempts": self.attempts,
        }


@dataclass
class SerialPotsResult:
    scenario: str
    seed: int
    records: list[PotRecord] = field(default_factory=list)
    sim_time_s: float = 0.0
    wall_s: float = 0.0
    fault: str | None = None
    valid: bool = True
    recording_error: str | None = None
    motors: dict | None = None
    """The drives' peak torque and mechanical work (transplanter.twin.motors)."""

    @property
    def picked(self) -> list[PotRecord]:
        return [r for r in self.records if r.start_s is not None]

    @property
    def successes(self) -> int:
        return sum(r.outcome == "success" for r in self.records)

    @property
    def seedlings(self) -> int:
        return len(self.records)

    @property
    def outcomes(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for r in self.records:
            out[r.outcome] = out.get(r.outcome, 0) + 1
        return dict(sorted(out.items()))

    @property
    def cycle_time_s(self) -> float:
        starts = [r.start_s for r in self.picked]
        return float(np.diff(starts).mean()) if len(starts) > 1 else math.nan

    def to_dict(self) -> dict[str, Any]:
        cycle = self.cycle_time_s
        rate = self.successes / self.seedlings if self.seedlings else math.nan
        return {
            "scenario": self.scenario,
            "seed": self.seed,
            "seedlings": self.seedlings,
            "successes": self.successes,
            "success_rate": rate,
            "outcomes": self.outcomes,
            "cycle_time_s": round(cycle, 4),
            "seedlings_per_hour": round(3600.0 / cycle, 1) if math.isfinite(cycle) else None,
            "peak_squeeze_n": round(max((r.peak_squeeze_n for r in self.records), default=0), 4),
            "pots": [r.as_dict() for r in self.records],
            "sim_time_s": round(self.sim_time_s, 4),
            "motors": self.motors,
            "fault": self.fault,
            "valid": self.valid,
            "definitions": DEFINITIONS,
            "wall_time_s": round(self.wall_s, 3),
        }


def run_serial_pots(sc, seed: int | None = None, progress=None, observers=()) -> SerialPotsResult:
    """`scenario.seedlings` pots of the scenario's pot line (seed `seed`, default the
    scenario's), picked row by row into the drop tube (module docstring). `progress(done,
    sim_t)`: called once a simulated second with the pots whose pick has ended; `observers`
    (`viewing.loop_recording.LoopRecording`) watch the loop without changing it."""
    require_awake(sc, "the serial arm's pot job")
    require_own_motion(sc, "the serial arm's pot job")
    from transplanter.scene.conveyor import ConveyorDrive
    from transplanter.scene.geometry import cell_columns_x

    check_placement(sc)
    wall0 = time.perf_counter()
    seed = sc.seed if seed is None else seed
    job, arm = sc.serial_pots, sc.serial_arm
    spec, cfg, line = _scene(sc, seed)
    model, data = _compile(spec, cfg)
    rig = _Rig(sc, model, data, seed, cfg=cfg)
    streams = np.random.default_rng([seed, 4005]).spawn(line.cols)
    sensor = rig.rangers["gripper"].sensor
    for c in range(line.cols):
        rig.rangers[f"station_c{c}"] = _Ranger(model, f"station_sensor_c{c}", sensor, streams[c])
    conveyor_qpos = model.jnt_qposadr[model.joint("conveyor").id]
    conveyor_dof = model.jnt_dofadr[model.joint("conveyor").id]
    drive = ConveyorDrive(
        SimpleNamespace(
            model=model, config=line, conveyor_qpos_adr=conveyor_qpos, conveyor_dof_adr=conveyor_dof
        )
    )

    def on_event(t_event: float, name: str) -> None:
        if name == "conveyor_index":
            drive.start(data, t_event, rig.sgf_cfg.conveyor_index_s)

    def before(t: float) -> None:
        if drive.armed(data):
            drive.apply(data, t)

    rig.on_machine_event.append(on_event)
    rig.before_step.append(before)
    n = min(sc.meta.seedlings, line.rows * line.cols)
    book = PotBook(line, model, data, n)
    records, body_ids, holding, plant, mark = (
        book.records, book.body_ids, book.holding, book.plant, book.mark
    )  # fmt: skip
    squeeze = _Squeeze(model, body_ids)
    rig.on_step.append(lambda _t: squeeze.after_step(data) if holding else None)
    if progress is not None:
        rig.on_step.append(_reporter(progress, records, rig.dt))
    xs = cell_columns_x(line)
    base, yaw = cfg.base_pos_m, cfg.base_yaw_rad
    z_top = line.funnel_top_z_m

    def paper(x: float, y: float, z: float) -> np.ndarray:
        return world_to_paper(np.array([x, y, z]), base, yaw)

    over_tube = paper(*line.drop_tube_xy_m, z_top)
    lowest = z_top + job.release_gap_m + job.grasp_z_m  # the pot's bottom release_gap up
    park = _park_point(rig.kin)

    def sense(col: int):
        def fn(_t: float) -> dict:
            out = rig.readings()
            out["station"] = rig.rangers[f"station_c{col}"].last_cm
            return out

        return fn

    def program():
        yield "G28"
        yield "G90"
        yield rig.standby_line
        for row in range(line.rows):
            for col in range(line.cols):
                i = row * line.cols + col
                if i >= n:
                    break
                yield "M400"
                yield Wait(2 * SENSE_CYCLE_S)
                readings = yield Call(sense(col))
                if readings["station"] == NO_ECHO or readings["station"] > DETECTED_CM:
                    records[i].outcome = "no pot"
                    continue
                grasp = paper(xs[col], line.pickup_row_y_m, job.grasp_z_m)
                low = float(paper(0.0, 0.0, lowest)[1])
                tube = pitch_release(rig.kin, grasp, over_tube, low, job.release_tilt_rad)
                yield Call(mark(i, "start_s"))
                for attempt in range(1, job.attempts + 1):
                    records[i].attempts = attempt
                    yield from grasp_items(rig, records[i], grasp, Call(sense(col)))
                    yield "M400"
                    yield Wait(2 * SENSE_CYCLE_S)
                    readings = yield Call(sense(col))
                    if readings["station"] > DETECTED_CM:  # the cell is empty: the pot is up
                        break
                    yield rig.standby_line  # sensor 1 still hears the pot in its cell: missed
                    yield f"G4 P{_ms(arm.release_settle_s)}"
                else:
                    yield Call(mark(i, "end_s"))
                    continue
                yield from release_items(rig, tube)
                yield "M400"
                yield Call(mark(i, "end_s"))
            if (row + 1) * line.cols >= n:
                break
            yield _g1(park, arm.travel_speed_m_s)
            yield "M710"
            yield "M400"
        yield _g1(park, arm.travel_speed_m_s)
        yield "M400"

    rig.start(program())
    for observer in observers:
        observer.attach(rig.loop)
    try:
        fault = rig.run(limit_s=60.0 + 20.0 * n, settle_s=1.0)
    except BaseException:
        for observer in observers:
            observer.abort()
        raise
    plant()
    half_w = line.cols * line.cell_pitch_m / 2 + line.table_side_margin_m
    for rec in records:
        rec.peak_squeeze_n = squeeze.peak[rec.pot]
        if rec.start_s is None or rec.outcome == "success":
            continue
        x, y, z = (float(v) for v in data.xpos[body_ids[rec.pot]])
        if abs(x) <= half_w and y >= line.pickup_row_y_m - line.row_pitch_m and 0 <= z < 0.1:
            rec.outcome = "missed"
        else:
            rec.outcome = "dropped"
    result = SerialPotsResult(sc.meta.name, seed, records)
    result.recording_error = finish_observers(observers, records, rig.t)
    result.sim_time_s = rig.t
    result.fault = fault
    result.valid = rig.valid
    result.motors = rig.motors.report().to_dict()
    result.wall_s = time.perf_counter() - wall0
    return result
