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
from dataclasses import dataclass, replace
from typing import Any

import mujoco
import numpy as np

from transplanter.machine.fuzzy_gripper import NO_ECHO
from transplanter.machine.host import Call, Wait
from transplanter.machine.pgf import LinePhase
from transplanter.scenario.assemble import judge_config
from transplanter.scene.effectors import fuzzy_gripper
from transplanter.twin.pot_job import (
    DEFINITIONS,
    INVALID,
    PotJob,
    PotJobResult,
    close_observers,
    event_sink,
    pot_line,
    reporter,
)
from transplanter.twin.serial_arm import (
    SENSE_CYCLE_S,
    GripRecord,
    _compile,
    _g1,
    _ms,
    _park_point,
    _Ranger,
    _Rig,
    grasp_items,
    release_items,
    require_own_motion,
    world_to_paper,
)

__all__ = [
    "DEFINITIONS",
    "PotRecord",
    "check",
    "line_config",
    "pitch_release",
    "run_serial_pots",
]

DETECTED_CM = 5.0
"""Sensor 1 reads a pot in its cell when nearer than this (the controller's Near core)."""
PEDESTAL_HALF_M = 0.045
"""The pedestal under the arm's base plate: 90 mm square (estimate)."""


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
    return scene_config(five, machine_config(five))


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


def scene_spec(sc, seed: int, decor: bool = False):
    """The trial's scene for seed `seed` (spec, scene config, line config); `decor`: with
    the pots' decor drawn, as `transplanter export` writes it (the trial leaves it out)."""
    return _scene(sc, seed, decor)


def _scene(sc, seed: int, decor: bool = False):
    from transplanter.scene import serial_scene
    from transplanter.scene.geometry import cell_columns_x

    job = sc.serial_pots
    line = line_config(sc)
    cfg = serial_scene.serial_scene_config(sc, workcell_kind="conveyor_tube", workcell=line)
    cfg = replace(
        cfg,
        base_pos_m=(job.base_x_m, job.base_y_m, job.base_z_m),
        base_yaw_rad=job.base_yaw_rad,
        decor=decor,
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


def check(sc) -> None:
    """ScenarioError (or ValueError: a timestep the servos' PWM frame cannot divide) for what
    the serial arm's pot job cannot run: its robot, gripper and motion, its placement."""
    from transplanter.machine.servo_drives import frame_steps

    frame_steps(sc.physics.timestep_s)
    require_own_motion(sc, "the serial arm's pot job")
    check_placement(sc)


def run_serial_pots(sc, seed: int | None = None, progress=None, observers=()) -> PotJobResult:
    """`scenario.seedlings` pots of the scenario's pot line (seed `seed`, default the
    scenario's), picked row by row into the drop tube and judged by the pot line's judge
    (module docstring). `progress(done, sim_t)`: called once a simulated second with the pots
    whose pick has ended; `observers` (`viewing.loop_recording.LoopRecording`) watch the loop
    without changing it."""
    require_own_motion(sc, "the serial arm's pot job")
    from transplanter.scene.geometry import cell_columns_x
    from transplanter.scene.pots import PotBatch

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
    n = min(sc.meta.seedlings, line.rows * line.cols)
    grips = [PotRecord(i, f"pot_{i // line.cols}_{i % line.cols}", *divmod(i, line.cols))
             for i in range(n)]  # fmt: skip
    xs = cell_columns_x(line)
    base, yaw = cfg.base_pos_m, cfg.base_yaw_rad
    z_top = line.funnel_top_z_m

    def paper(x: float, y: float, z: float) -> np.ndarray:
        return world_to_paper(np.array([x, y, z]), base, yaw)

    over_tube = paper(*line.drop_tube_xy_m, z_top)
    lowest = z_top + job.release_gap_m + job.grasp_z_m  # the pot's bottom release_gap up
    park = _park_point(rig.kin)
    box: dict[str, Any] = {}  # the pot job, once the loop exists (rig.start)

    def sense(col: int):
        def fn(_t: float) -> dict:
            out = rig.readings()
            out["station"] = rig.rangers[f"station_c{col}"].last_cm
            return out

        return fn

    def mark(i: int, key: str):
        return Call(lambda t: setattr(grips[i], key, t))

    def program():
        pj = box["job"]
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
                    grips[i].outcome = "no pot"
                    yield pj.skipped(i)
                    continue
                grasp = paper(xs[col], line.pickup_row_y_m, job.grasp_z_m)
                low = float(paper(0.0, 0.0, lowest)[1])
                tube = pitch_release(rig.kin, grasp, over_tube, low, job.release_tilt_rad)
                yield mark(i, "start_s")
                yield pj.sent(LinePhase.APPROACH, i)
                for attempt in range(1, job.attempts + 1):
                    grips[i].attempts = attempt
                    yield from grasp_items(rig, grips[i], grasp, Call(sense(col)),
                                           phase=lambda p, i=i: pj.done(p, i))  # fmt: skip
                    yield "M400"
                    yield pj.done(LinePhase.LIFT, i)
                    yield Wait(2 * SENSE_CYCLE_S)
                    readings = yield Call(sense(col))
                    if readings["station"] > DETECTED_CM:  # the cell is empty: the pot is up
                        break
                    yield rig.standby_line  # sensor 1 still hears the pot in its cell: missed
                    yield f"G4 P{_ms(arm.release_settle_s)}"
                else:
                    yield mark(i, "end_s")
                    yield pj.give_up(i, f"sensor 1 still heard it after {job.attempts} grasps")
                    continue
                yield from release_items(rig, tube, phase=lambda p, i=i: pj.done(p, i))
                yield "M400"
                yield mark(i, "end_s")
                yield pj.done(LinePhase.RELEASE_WAIT, i)
            if (row + 1) * line.cols >= n:
                break
            yield _g1(park, arm.travel_speed_m_s)
            yield "M710"
            yield "M400"
            yield pj.done(LinePhase.INDEX, min(n, (row + 1) * line.cols) - 1)
        yield _g1(park, arm.travel_speed_m_s)
        yield "M400"

    rig.start(program())
    pots = PotBatch.draw(line, seed)  # the pots the workcell's populate drew for this seed
    scene = pot_line(model, line, pots, fuzzy_gripper.PARTS)
    pickups = [(x, line.pickup_row_y_m) for x in xs]
    pot_job = box["job"] = PotJob(rig.loop, scene, judge_config(sc), pickups, arm.hover_m, n,
                                  event_sink(observers), seed)  # fmt: skip
    drive = pot_job.conveyor

    def on_event(t_event: float, name: str) -> None:
        if name == "conveyor_index":
            pot_job.index(t_event, rig.sgf_cfg.conveyor_index_s)

    def before(t: float) -> None:
        if drive.armed(data):
            drive.apply(data, t)

    rig.on_machine_event.append(on_event)
    rig.before_step.append(before)
    if progress is not None:
        rig.on_step.append(reporter(progress, pot_job, rig.dt))
    for observer in observers:
        observer.attach(rig.loop)
    try:
        fault = rig.run(limit_s=60.0 + 20.0 * n, settle_s=1.0)
    except BaseException:
        for observer in observers:
            observer.abort()
        raise
    pot_job.finish(rig.t, rig.valid)
    for grip_rec, rec in zip(grips, pot_job.records, strict=True):
        grip_rec.outcome = str(rec.outcome)
    result = PotJobResult(
        scenario=sc.meta.name,
        seed=seed,
        per_seedling=pot_job.records,
        sim_time_s=rig.t,
        wall_time_s=0.0,
        valid=rig.valid,
        invalid_reason=None if rig.valid else INVALID,
        fault=fault,
        overrides=dict(sc.overrides),
        motors=rig.motors.report().to_dict(),
        trial="serial_arm_pots",
        pots=grips,
        definitions=DEFINITIONS,
    )
    result.recording_error = close_observers(observers, rig.t)
    result.wall_time_s = time.perf_counter() - wall0
    return result
