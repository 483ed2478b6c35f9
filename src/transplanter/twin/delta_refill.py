"""The delta's cull-and-refill trial (seed 002: Zhao, Cheng, Dong, Ma, Xiong and Tong,
*Research on the End Effector and Optimal Motion Control Strategy for a Plug Seedling
Transplanting Parallel Robot*), headless: `transplanter trial delta_refill`.

The chain, as on the machine:

- **Host** (the paper's PC + PLC): the trays are imaged and graded (`twin.delta_grading`:
  the recognition pipeline on the imaging station's pictures, or the drawn truth with
  `delta_refill.vision = "truth"`; the PC's time is `image_delay_ms`), then for every
  inferior cell a removal to the bin and a supplementation from the supply tray, for every
  empty cell a supplementation; G-code lines one at a time over the bus (the host waits for
  each `ok`). The claws are driven through the controller's two servo outputs, as the PLC's
  valve outputs: `M280 P0 S1` extends the claws, `M280 P0 S0` retracts them (the stripper
  pushes the plug off), `M280 P1 S0|S90` sets the rotary cylinder; `G4 P<ms>` waits the
  stroke and settle times (the PLC's timers). After the tray: the claws home (`G28`) and
  the tray is changed (`tray_change_ms`).
- **Controller**: `machine.delta_drives.DeltaController`, the SGF with DeltaKinematics
  (every interpolated point through the delta's IK and joint window) and the pre-move check
  of joint speed, acceleration and torque.
- **Drives**: `machine.delta_drives.PulseServos` turn the pulse counts into joint commands
  for the model's torque-limited position servos (tau_max through the reducer); a following
  error beyond `following_error_limit_deg` raises the drive's alarm and ends the trial.
- **Physics**: the plugs are held by the claws through contact only
  (`scene.plug_physics`), the cells' adhesion and the substrate's loss per step.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Protocol

import mujoco
import numpy as np

from transplanter.machine.bus import ComBus
from transplanter.machine.delta_drives import DeltaController, PulseServos
from transplanter.machine.gcode import format_number
from transplanter.machine.host import HostProgram, Mark, Wait, WaitSince
from transplanter.machine.kinematics.delta import DeltaKinematics
from transplanter.machine.rig import SimulatedEndstops
from transplanter.scenario.assemble import delta_sgf_config, require_awake, require_kinds
from transplanter.scene.delta_scene import (
    DeltaSceneConfig,
    JobCells,
    build_delta_spec,
    compile_scene,
    plug_name,
)
from transplanter.scene.effectors import plug_claws
from transplanter.scene.effectors.plug_claws import ClawCycle
from transplanter.scene.plug_physics import LeafWatch, PlugPhysics, stripper_push
from transplanter.scene.plug_substrate import Substrate
from transplanter.scene.plug_tray import TrayDraw, draw_tray
from transplanter.scene.robots import delta as delta_robot
from transplanter.twin.delta_grading import (
    CellGrading,
    GradingMap,
    from_truth,
    grading_map,
    truth_grades,
)
from transplanter.twin.loop import StepLoop
from transplanter.twin.motors import MotorMeter
from transplanter.vision.grading import EMPTY, HEALTHY, HEALTHY_LR, HEALTHY_UD, INFERIOR

__all__ = ["DeltaRefillJudge", "DeltaRefillResult", "ProgressObserver", "run_delta_refill"]

DEFINITIONS = {
    "time_per_operation_s": "work time / operations. The work time is simulated from the "
    "claws' arrival at the first serviced cell to the end of the last operation (its stroke "
    "and settle): every removal and supplementation, the transfers between them, cylinder "
    "strokes, rotary swings and settles. An operation is one serviced cell: a removal and a "
    "supplementation for an inferior cell, a supplementation for an empty one (the paper's "
    "Table 4 counts a removal and a supplementation). The tray's own time (the image delay, "
    "the approach from the homed machine to the first cell, the last lift) is in the tray "
    "time, not here, so that the time per operation does not depend on how many cells a "
    "tray needs",
    "work_time_s": "simulated, from the claws' arrival at the first serviced cell to the end "
    "of the last operation",
    "tray_time_s": "simulated, from the image to the claws' last lift: the image delay, the "
    "approach from the homed machine, the work time and the last lift",
    "plants_per_hour": "3600 x plants handled (culled to the bin + refills seated) / "
    "(tray time + tray change); for a run that serviced only some of the cells the grading "
    "asked for (delta_refill.max_cells), the whole tray's: the serviced cells' plants and work "
    "time scaled by the plants the grading asks of the whole tray (an inferior cell's cull and "
    "refill, an empty cell's refill) over those of the serviced cells, the tray's own time "
    "(image delay, approach, last lift, tray change) counted once, so that the rate does not "
    "depend on how many cells the run serviced (rate_basis)",
    "trays_per_hour": "3600 / (tray time + tray change), the whole tray's as plants_per_hour",
    "cells_to_service": "the planting tray's cells the grading found inferior or empty: the "
    "whole tray's work",
    "rate_basis": "'tray': the rates of the tray as run; 'whole_tray_estimate': a partial run's "
    "rates scaled to the whole tray (plants_per_hour)",
    "leaf_damage_rate": "refill seedlings with at least one leaf torn by a claw or the "
    "stripper / refill seedlings picked",
    "tray_leaf_damage_rate": "seedlings of the finished planting tray (refills seated and "
    "seedlings left in place) with a torn leaf / seedlings in it (the paper's Table 5 counts "
    "damaged / 128 of a tray)",
    "substrate_retention": "mean over seated refills of plug mass after / before",
    "dropped": "plugs that came off the pins out of place: culls neither in the bin nor left "
    "in their cell, refills not seated, whose pins sheared (dropped, or jammed: wedged against "
    "the stripper and carried by the head)",
}
HEALTHY_CLASSES = (HEALTHY, HEALTHY_LR, HEALTHY_UD)
UNSTABLE = "MuJoCo: the simulation went unstable"
FAULT_KINDS = (("drive_alarm", "Err24"), ("unstable", UNSTABLE))
"""A fault's failure kind by how its text starts (else `controller_error`)."""
_BAD_VALUES = {
    mujoco.mjtWarning.mjWARN_BADQPOS: "QPOS",
    mujoco.mjtWarning.mjWARN_BADQVEL: "QVEL",
    mujoco.mjtWarning.mjWARN_BADQACC: "QACC",
}


def _instability(model, data, t: float, physics: dict) -> str:
    """The fault of a step after which MuJoCo reset the state (a NaN, Inf or huge value in
    qpos, qvel or qacc): where, and the body it was in. The trial stops there: the reset
    world is not the tray's, so its verdicts are void (`valid` False)."""
    where = ""
    for warning, field_name in _BAD_VALUES.items():
        if data.warning[warning].number:
            dof = int(data.warning[warning].lastinfo)
            if 0 <= dof < model.nv:
                body = model.body(int(model.dof_bodyid[dof])).name
                plug = physics.get(body)
                dropped = (
                    f", dropped by the claws {t - plug.dropped_at_s:.3f} s before"
                    if plug is not None and plug.dropped_at_s is not None
                    else ""
                )
                where = f" (a NaN, Inf or huge value in {field_name} at DOF {dof}: {body}{dropped})"
            break
    return (
        f"{UNSTABLE} at {t:.3f} s{where} and reset its state; the trial stops there and "
        'its verdicts are void (judge a setting over seeds: docs/delta.md, "Dropped plugs")'
    )


@dataclass
class CellRecord:
    """One serviced planting cell: its class in the host's map (`grade`, what the host acted
    on) beside the drawn `truth`, and the same for the supply seedling that refilled it."""

    index: int
    truth: str
    rotary_deg: float
    culled: str | None = None  # binned / dropped / left / jammed (inferior cells); void: unstable
    supply_index: int | None = None
    refilled: str | None = None  # seated / dropped / jammed / not_seated / ...; void (as culled)
    retention: float | None = None
    leaf_damage: list[dict] = field(default_factory=list)
    cull_dropped_at_s: float | None = None
    refill_dropped_at_s: float | None = None
    refill_peak_load_n: float | None = None
    start_s: float = math.nan
    end_s: float = math.nan
    grade: str = ""
    supply_grade: str | None = None
    supply_truth: str | None = None
    rotary_truth_deg: float | None = None
    """The setting the supply seedling's truth would have given."""
    misgrades: list[str] = field(default_factory=list)
    """What misgrading cost this cell (MISGRADES' kinds)."""

    def as_dict(self) -> dict:
        return {
            "index": self.index,
            "grade": self.grade,
            "truth": self.truth,
            "supply_grade": self.supply_grade,
            "supply_truth": self.supply_truth,
            "rotary_deg": self.rotary_deg,
            "rotary_truth_deg": self.rotary_truth_deg,
            "misgrades": self.misgrades,
            "culled": self.culled,
            "supply_index": self.supply_index,
            "refilled": self.refilled,
            "retention": self.retention,
            "leaf_damage": self.leaf_damage,
            "cull_dropped_at_s": self.cull_dropped_at_s,
            "refill_dropped_at_s": self.refill_dropped_at_s,
            "refill_peak_load_n": self.refill_peak_load_n,
            "start_s": round(self.start_s, 6),
            "end_s": round(self.end_s, 6),
        }


@dataclass
class DeltaRefillResult:
    seed: int
    pose_judgement: bool
    operations: int
    tray_time_s: float
    time_per_operation_s: float
    work_time_s: float
    plants_per_hour: float
    trays_per_hour: float
    leaf_damage_rate: float
    tray_leaf_damage_rate: float
    dropped: int
    substrate_retention: float | None
    failures: dict[str, int]
    cells: list[CellRecord]
    neighbour_leaf_damage: list[dict]
    fault: str | None
    refused: list[str]
    peak_following_error_deg: list[float]
    wall_time_s: float
    sim_time_s: float
    valid: bool = True
    """False when MuJoCo warned (an unstable step) or the job ran out of simulated time."""
    recording_error: str | None = None
    planner: str = "lines"
    """The controller's ``motion.planner``."""
    peak_joint_speed_deg_s: list[float] = field(default_factory=list)
    """The arms' largest measured speed in the physics (per arm)."""
    peak_joint_torque_nm: list[float] = field(default_factory=list)
    """The arms' largest torque at the joint from the servos in the physics (per arm)."""
    vision: str = "truth"
    """Where the host's grading map came from (`delta_refill.vision`)."""
    grading: dict = field(default_factory=dict)
    """The map against the truth per tray (GradingMap.summary): confusion, wall times."""
    misgraded: list[dict] = field(default_factory=list)
    """Every misgraded cell the job acted on or passed over, with what it cost."""
    motors: dict | None = None
    """The drives' peak torque and mechanical work (transplanter.twin.motors)."""
    cells_to_service: int = 0
    """The planting tray's cells the grading found inferior or empty (the whole tray's work;
    a run of delta_refill.max_cells services the first of them)."""
    rate_basis: str = "tray"
    """'tray', or 'whole_tray_estimate' for a partial run's rates (DEFINITIONS)."""

    @property
    def successes(self) -> int:
        return sum(1 for c in self.cells if _cell_ok(c))

    @property
    def seedlings(self) -> int:
        return len(self.cells)

    def to_dict(self) -> dict[str, Any]:
        return {
            "trial": "delta_refill",
            "seed": self.seed,
            "pose_judgement": self.pose_judgement,
            "operations": self.operations,
            "tray_time_s": self.tray_time_s,
            "work_time_s": self.work_time_s,
            "time_per_operation_s": self.time_per_operation_s,
            "plants_per_hour": self.plants_per_hour,
            "trays_per_hour": self.trays_per_hour,
            "cells_to_service": self.cells_to_service,
            "rate_basis": self.rate_basis,
            "leaf_damage_rate": self.leaf_damage_rate,
            "tray_leaf_damage_rate": self.tray_leaf_damage_rate,
            "dropped": self.dropped,
            "substrate_retention": self.substrate_retention,
            "failures": dict(sorted(self.failures.items())),
            "cells": [c.as_dict() for c in self.cells],
            "neighbour_leaf_damage": self.neighbour_leaf_damage,
            "fault": self.fault,
            "refused": self.refused,
            "peak_following_error_deg": self.peak_following_error_deg,
            "planner": self.planner,
            "peak_joint_speed_deg_s": self.peak_joint_speed_deg_s,
            "peak_joint_torque_nm": self.peak_joint_torque_nm,
            "vision": self.vision,
            "grading": self.grading,
            "misgraded": self.misgraded,
            "motors": self.motors,
            "sim_time_s": self.sim_time_s,
            "valid": self.valid,
            "wall_time_s": self.wall_time_s,
            "definitions": DEFINITIONS,
        }


def _cell_ok(c: CellRecord) -> bool:
    return (
        c.culled in (None, "binned")
        and c.refilled == "seated"
        and not c.leaf_damage
        and not c.misgrades
    )


class DeltaRefillJudge:
    """Judges the plugs at the end of a trial: where each culled plug ended (the bin, dropped
    on the way, left in its cell, jammed in the head) and whether each refill stands in its
    target cell (or was dropped, or jammed in the head: off the pins but wedged against the
    stripper, carried wherever the head went)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        cfg: DeltaSceneConfig,
        bin_xy: tuple[float, float],
        tol_m: float,
    ) -> None:
        self.model, self.cfg, self.bin_xy, self.tol_m = model, cfg, bin_xy, tol_m

    def _jammed(self, data: mujoco.MjData, physics: PlugPhysics) -> bool:
        return (
            physics.dropped_at_s is not None and stripper_push(self.model, data, physics.name) > 0.0
        )

    def culled(self, data: mujoco.MjData, physics: PlugPhysics, cell_xy) -> str:
        x, y, z = (float(v) for v in data.xpos[physics.body])
        half = self.cfg.bin_size_m / 2
        in_bin = abs(x - self.bin_xy[0]) < half and abs(y - self.bin_xy[1]) < half
        if in_bin and z < self.cfg.tray_top_m:
            return "binned"
        if physics.seated_in(data, cell_xy, self.tol_m):
            return "left"
        return "jammed" if self._jammed(data, physics) else "dropped"

    def refilled(self, data: mujoco.MjData, physics: PlugPhysics, cell_xy) -> str:
        if physics.seated_in(data, cell_xy, self.tol_m):
            return "seated"
        if physics.dropped_at_s is None:
            return "not_seated"
        return "jammed" if self._jammed(data, physics) else "dropped"


@dataclass(frozen=True)
class _Op:
    cell: int
    truth: str  # the cell's class in the host's map: what the host acts on
    supply: int | None
    rotary_deg: float


MISGRADES = {
    "healthy_culled": "a healthy planting seedling graded inferior: pulled out to the bin",
    "empty_culled": "an empty planting cell graded inferior: the claws pulled at a hole",
    "refill_on_plug": "a planting seedling graded empty: a refill let go on top of its plug",
    "inferior_left": "an inferior planting seedling graded healthy: left in the tray",
    "empty_missed": "an empty planting cell graded healthy: not refilled",
    "inferior_planted": "an inferior supply seedling graded healthy: planted as a refill",
    "empty_picked": "an empty supply cell graded healthy: the claws came up without a plug",
    "orientation_damage": "a refill's leaf torn at the setting its grade gave where its truth "
    "gave the other",
}
"""The kinds of misgrading cost the trial counts (failures `misgrade_<kind>`)."""


def rotary_for(cell: CellGrading | None, judge: bool, fixed: float) -> float:
    """The claws' setting for a seedling, from its class and leaf reach in the host's map: the
    stripper's blocks come down beside the claws' entry points (along x at 0 deg), so the claws
    go in across the seedling's narrower side: left-right crossers 90 deg, up-down crossers
    0 deg (docs/plug_claws.md), a seedling inside its cell by the reach of its leaves (90 deg
    when they reach farther left-right). Without pose judgement: `fixed`."""
    if not judge or cell is None:
        return fixed
    if cell.grade == HEALTHY_LR:
        return 90.0
    if cell.grade == HEALTHY_UD:
        return 0.0
    return 90.0 if cell.reach_lr_mm > cell.reach_ud_mm else 0.0


def _plants_of(grade: str) -> int:
    """The plants a cell's service handles: an inferior cell's cull and refill, an empty
    cell's refill."""
    return 2 if grade == INFERIOR else 1 if grade == EMPTY else 0


def tray_work(grades: GradingMap) -> tuple[int, int]:
    """The whole tray's work as the grading map asks it (whatever delta_refill.max_cells
    lets a run do): the planting cells to service (inferior or empty) and their plants."""
    plants = [_plants_of(c.grade) for c in grades.planting.cells]
    return sum(1 for n in plants if n), sum(plants)


def plan_job(
    sc, planting: TrayDraw, supply: TrayDraw, grades: GradingMap | None = None
) -> list[_Op]:
    """The host's work list from the grading map (default: the drawn truth): inferior cells
    culled and refilled, empty cells refilled, in index order, each refill from the next
    supply cell graded healthy."""
    job = sc.delta_refill
    fixed = math.degrees(job.fixed_rotary_rad)
    grades = grades or from_truth(planting, supply)
    supply_cells = grades.supply.cells
    healthy = [i for i, c in enumerate(supply_cells) if c.grade in HEALTHY_CLASSES]
    ops: list[_Op] = []
    todo = [i for i, c in enumerate(grades.planting.cells) if c.grade in (INFERIOR, EMPTY)]
    if job.max_cells:
        todo = todo[: job.max_cells]
    for k, cell in enumerate(todo):
        src = healthy[k] if k < len(healthy) else None
        # the setting is the refill seedling's; the culled plug is lifted at the same setting
        graded = supply_cells[src] if src is not None else None
        rotary = rotary_for(graded, job.pose_judgement, fixed)
        ops.append(_Op(cell, grades.planting.cells[cell].grade, src, rotary))
    return ops


def _scene_config(sc, kin: DeltaKinematics) -> DeltaSceneConfig:
    from transplanter.scenario.assemble import claws_config, plugs_config

    d, job = sc.delta, sc.delta_refill
    work_z = -0.8
    q0 = tuple(float(v) for v in kin.joints(np.array([0.0, 0.0, work_z])))
    return DeltaSceneConfig(
        gear_ratio=d.gear_ratio,
        joint_torque_limit_nm=d.joint_torque_limit_nm,
        platform_mass_kg=d.platform_mass_kg,
        home_q_rad=q0,
        work_z_m=work_z,
        bin_xy_m=(job.bin_x_m, job.bin_y_m),
        claws=claws_config(sc),
        plugs=plugs_config(sc),
        timestep_s=sc.physics.timestep_s,
    )


def _program(sc, cfg: DeltaSceneConfig, ops: list[_Op]) -> tuple[list, list[str]]:
    """The host's items and, in order, the plug each claws extension grips.

    ``motion.planner = "lines"``: every pick and place is straight lines (travel at the lift
    height, approach down, claws, back up). ``"bspline5"``: after the first approach, one
    ``G0`` per transfer from where the claws worked to where they work next (the controller
    runs it as the paper's lift-arc-top-arc-descent spline), and the rotary cylinder swings
    during the transfer that takes the claws to the cell it is set for (the claws extend once
    its swing and settle are over, the PLC's timer from the swing's command)."""
    job, claws = sc.delta_refill, cfg.claws
    spline = sc.motion.planner == "bspline5"
    stroke_ms = claws.cylinder_stroke_ms + 2 * claws.settle_ms
    work = cfg.work_z_m
    up = work + job.lift_m
    v_travel, v_app = job.travel_speed_m_s * 1e3, job.approach_speed_m_s * 1e3
    items: list = [Mark("image"), Wait(job.image_delay_s), Mark("start")]
    grips: list[str] = []
    rotary = 0.0
    culls = 0
    first = [True]

    def mm(v: float) -> str:
        return f"{v * 1e3:.3f}"

    num = format_number  # a word's value as set, never rounded to another number

    def go(x: float, y: float, z: float) -> None:
        if spline and not first[0]:
            items.append(f"G0 X{mm(x)} Y{mm(y)} Z{mm(z)}")
        else:
            items.extend([f"G1 X{mm(x)} Y{mm(y)} Z{mm(up)} S{num(v_travel)}",
                          f"G1 Z{mm(z)} S{num(v_app)}"])  # fmt: skip
        if first[0]:
            items.append(Mark("work_start"))  # the reply to the approach's last line
        first[0] = False

    def leave() -> None:
        if not spline:
            items.append(f"G1 Z{mm(up)} S{num(v_travel)}")

    swing_wait: list[float] = []

    def pick(x: float, y: float, plug: str) -> None:
        go(x, y, work)
        if swing_wait:
            items.append(WaitSince("rotary", swing_wait.pop()))
        items.extend(["M280 P0 S1", f"G4 P{num(stroke_ms)}"])
        leave()
        grips.append(plug)

    def place(x: float, y: float, above: float) -> None:
        go(x, y, work + above)
        items.extend(["M280 P0 S0", f"G4 P{num(stroke_ms)}"])
        leave()

    for op in ops:
        items.append(Mark(f"cell{op.cell}_start"))
        x, y = cfg.cell_xy("planting", op.cell)
        if op.rotary_deg != rotary:
            swing = abs(op.rotary_deg - rotary) / 90.0 * claws.rotary_stroke_ms
            items.append(f"M280 P1 S{num(op.rotary_deg)}")
            if not spline or first[0]:
                items.append(f"G4 P{num(swing + claws.settle_ms)}")
            else:
                items.append(Mark("rotary"))
                swing_wait[:] = [(swing + claws.settle_ms) * 1e-3]
            rotary = op.rotary_deg
        if op.truth == INFERIOR:
            pick(x, y, plug_name("planting", op.cell))
            place(*cfg.bin_spot(culls), job.bin_release_above_m)
            culls += 1
        if op.supply is not None:
            sx, sy = cfg.cell_xy("supply", op.supply)
            pick(sx, sy, plug_name("supply", op.supply))
            place(x, y, job.release_above_m)
        items.append(Mark(f"cell{op.cell}_end"))
    items.append(Mark("work_end"))
    if spline and not first[0]:
        items.append(f"G1 Z{mm(up)} S{num(v_travel)}")
    items += [Mark("end"), "G28"]
    return items, grips


def run_delta_refill(
    sc, seed: int | None = None, observers=(), grades: GradingMap | None = None
) -> DeltaRefillResult:
    """One tray of the scenario `sc` (its [delta], [delta_refill], [vision] and [bus]), seed
    `seed` (default the scenario's). Deterministic: the same inputs give the same result, with
    or without `observers` (DeltaObserver: they only read the state, at their frame times).
    `grades`: the host's grading map instead of the one `delta_refill.vision` gives
    (GradingUnavailable without a GL context for the pipeline's pictures, GradingFailed for a
    picture it cannot grade)."""
    require_awake(sc, "the delta's tray job")
    require_delta(sc)
    wall0 = time.perf_counter()
    seed = sc.seed if seed is None else seed
    job = sc.delta_refill
    kin = DeltaKinematics.from_scenario(sc)
    cfg = _scene_config(sc, kin)
    planting, supply = _trays(sc, seed)
    grades = grades or grading_map(sc, seed, planting, supply)
    ops = plan_job(sc, planting, supply, grades)
    cells = _job_cells(ops, planting)
    spec = build_delta_spec(cfg, planting, supply, cells)
    model = compile_scene(spec)
    data = mujoco.MjData(model)
    data.qpos[:] = delta_robot.home_qpos(model, cfg, (0.0, 0.0, cfg.work_z_m))
    data.ctrl[:3] = delta_robot.home_ctrl(cfg)
    data.ctrl[3:6] = plug_claws.home_ctrl(cfg.claws)
    mujoco.mj_forward(model, data)
    meter = MotorMeter(model, delta_robot.ACTUATORS, plug_claws.ACTUATORS)
    sub = Substrate(cfg.plugs)
    names = [plug_name("planting", i) for i in cells.culled if planting.cells[i].seedling] + [
        plug_name("supply", i) for i in cells.supply if supply.cells[i].seedling
    ]  # a misgraded empty cell has no plug to free
    physics = {n: PlugPhysics(model, data, n, sub) for n in names}
    watched = tuple(
        plug_name(t, c.index)
        for t, draw in (("planting", planting), ("supply", supply))
        for c in draw.cells
        if c.seedling is not None
    )
    leaves = LeafWatch(model, watched, cfg.claws.leaf_damage_force_n)

    sgf_cfg = delta_sgf_config(sc, job, kin)
    controller = DeltaController(sgf_cfg)
    q0 = np.array(cfg.home_q_rad)
    endstops = SimulatedEndstops(sgf_cfg, q0)
    drives = PulseServos(kin, q0, job.following_error_limit_rad)
    bus = ComBus(baud_bps=sc.bus.baud_bps)
    items, grips = _program(sc, cfg, ops)
    host = HostProgram(["G28", "G90", *items], bus)
    loop = StepLoop(model, data, host, bus, controller, endstops)
    cycle = ClawCycle(cfg.claws)
    arms = [model.jnt_qposadr[model.joint(n).id] for n in delta_robot.ARMS]
    arm_dofs = [model.jnt_dofadr[model.joint(n).id] for n in delta_robot.ARMS]
    peaks = np.zeros((2, 3))  # the arms' measured |speed| (rad/s) and |torque| (N m)
    eff = [model.actuator(n).id for n in plug_claws.ACTUATORS]
    gear = cfg.gear_ratio
    stroke = cfg.claws.cylinder_stroke_ms * 1e-3
    carried: dict[str, list[float]] = {}  # plug -> [from, until]
    dt = model.opt.timestep
    limit_s = 120.0 + 30.0 * max(len(ops), 1)
    # valid: False at once when a step went unstable; command: the drives' last joint command
    state: dict[str, Any] = {"fault": None, "valid": None, "holding": None,
                             "command": q0}  # fmt: skip
    view = DeltaView(model, data, cfg, ops, host, cycle, physics, leaves, q0) if observers else None
    look = [view.attach(observers) if view is not None else math.inf]  # the next look's time

    def claws(_t: float, commands: list) -> None:
        for t_cmd, index, value in commands:
            holding = state["holding"]
            if index == 0 and value > 0:
                cycle.extend(t_cmd)
                holding = grips.pop(0) if grips else None
                if holding in physics:
                    carried[holding] = [t_cmd + stroke, math.inf]
            elif index == 0:
                cycle.retract(t_cmd)
                if holding in carried:
                    carried[holding][1] = t_cmd
                holding = None
            else:
                cycle.rotate(t_cmd, float(value))
            state["holding"] = holding

    def commands(t: float) -> None:
        command = state["command"] = drives.command(loop.raw)
        measured = data.qpos[arms]
        if drives.watch(t, command, measured) is not None and state["fault"] is None:
            state["fault"] = drives.alarm.text()
            loop.settle_until(t + job.settle_after_s)
        data.ctrl[:3] = gear * (measured if state["fault"] else command)
        data.ctrl[eff] = cycle.ctrl(t)
        for p in physics.values():
            p.before_step(data)

    def stable(t: float) -> str | None:
        if data.time + dt < t:  # MuJoCo found a bad value and reset the state to the model's
            state["valid"] = False
            return _instability(model, data, t, physics)
        return None

    def watch(t: float) -> None:
        meter.record(data)
        np.maximum(peaks[0], np.abs(data.qvel[arm_dofs]), out=peaks[0])
        np.maximum(peaks[1], np.abs(data.qfrc_actuator[arm_dofs]), out=peaks[1])
        for name, p in physics.items():
            span = carried.get(name)
            p.after_step(data, t, carried=span is not None and span[0] <= t < span[1])
        leaves.after_step(data, t)
        if loop.time >= look[0]:  # observers only at their frame times (math.inf without)
            look[0] = view.look(loop.time, state["command"])

    loop.on_servo.append(claws)
    loop.before_step.append(commands)
    loop.guard = stable
    loop.after_step.append(watch)
    timed_out = loop.run_program(limit_s, job.settle_after_s, what="the job")
    fault, valid, t, k = state["fault"] or timed_out, state["valid"], loop.last_t, loop.k
    if loop.stopped is not None:
        fault = loop.stopped
    if valid is None:
        valid = t <= limit_s and not any(int(w.number) for w in data.warning)
    if fault is None and host.error is not None:
        fault = host.error
    result = _judge(sc, seed, cfg, ops, planting, data, physics, leaves, host, controller,
                    drives, fault, k * dt, time.perf_counter() - wall0, valid,
                    tray_work(grades))  # fmt: skip
    _grading_costs(sc, result, planting, supply, grades)
    result.peak_joint_speed_deg_s = [round(math.degrees(v), 4) for v in peaks[0]]
    result.peak_joint_torque_nm = [round(float(v), 4) for v in peaks[1]]
    result.motors = meter.report().to_dict()
    return result


class DeltaObserver(Protocol):
    """Watches a delta trial without changing it (`transplanter.viewing.delta`): `attach`
    once the scene and the host exist (the power-on state), `look` at the first step whose
    end reaches `next_t` (simulated s; it sets the next), `finish` after the result."""

    next_t: float

    def attach(self, view: DeltaView) -> None: ...

    def look(self, view: DeltaView) -> None: ...

    def finish(self, view: DeltaView, result: DeltaRefillResult) -> None: ...

    def abort(self) -> None: ...


@dataclass
class DeltaView:
    """What an observer may read of a running delta trial (never write): the model and its
    data, the scene's config, the job, the host (its marks), the claws' valve schedule, the
    free plugs' physics and the leaf watch; `t` and `command` (the drives' joint command,
    rad) are those of the latest look."""

    model: mujoco.MjModel
    data: mujoco.MjData
    cfg: DeltaSceneConfig
    ops: list
    host: HostProgram
    cycle: ClawCycle
    physics: dict[str, PlugPhysics]
    leaves: LeafWatch
    command: np.ndarray
    t: float = 0.0
    observers: tuple = ()

    def attach(self, observers) -> float:
        """Attach every observer (power-on state at t = 0); the first look's time."""
        self.observers = tuple(observers)
        for o in self.observers:
            o.attach(self)
        return min(o.next_t for o in self.observers)

    def look(self, t: float, command: np.ndarray) -> float:
        """The observers due at `t` look; the next look's time."""
        self.t, self.command = t, command
        for o in self.observers:
            if t >= o.next_t:
                o.look(self)
        return min(o.next_t for o in self.observers)


class ProgressObserver:
    """A DeltaObserver that reports the tray's progress once a simulated second,
    `progress(done, sim_t, total)`: the cells serviced so far of the cells the host planned.
    It only reads the host's marks, so the trial is the same with it."""

    def __init__(self, progress, period_s: float = 1.0) -> None:
        self.progress, self.period_s = progress, period_s
        self.next_t = period_s
        self.total = 0

    def attach(self, view: DeltaView) -> None:
        self.total = len(view.ops)
        self.progress(0, 0.0, self.total)

    def look(self, view: DeltaView) -> None:
        marks = view.host.marks
        done = sum(f"cell{op.cell}_end" in marks for op in view.ops)
        self.progress(done, view.t, self.total)
        self.next_t = view.t + self.period_s

    def finish(self, view: DeltaView, result: DeltaRefillResult) -> None:
        self.progress(result.operations, result.sim_time_s, self.total)

    def abort(self) -> None:
        pass


def _judge(sc, seed, cfg, ops, planting, data, physics, leaves, host, controller, drives, fault,
           sim_t, wall, valid, whole) -> DeltaRefillResult:  # fmt: skip
    job = sc.delta_refill
    judge = DeltaRefillJudge(leaves.model, cfg, (job.bin_x_m, job.bin_y_m), 0.006)
    records: list[CellRecord] = []
    damage_by_plug: dict[str, list[dict]] = {}
    for d in leaves.damage:
        plug = d.leaf.split("_", 1)[0]
        damage_by_plug.setdefault(plug, []).append(
            {"leaf": d.leaf, "by": d.by, "force_n": round(d.force_n, 4), "time_s": d.time_s}
        )
    own: set[str] = set()
    void = fault is not None and fault.startswith(UNSTABLE)  # the state is MuJoCo's reset one
    for op in ops:
        truth = planting.cells[op.cell].truth
        rec = CellRecord(op.cell, truth, op.rotary_deg, supply_index=op.supply, grade=op.truth)
        rec.start_s = host.marks.get(f"cell{op.cell}_start", math.nan)
        rec.end_s = host.marks.get(f"cell{op.cell}_end", math.nan)
        xy = cfg.cell_xy("planting", op.cell)
        if op.truth == INFERIOR and plug_name("planting", op.cell) not in physics:
            rec.culled = "nothing"  # no plug: the cell was empty
        elif op.truth == INFERIOR:
            name = plug_name("planting", op.cell)
            rec.culled = "void" if void else judge.culled(data, physics[name], xy)
            rec.cull_dropped_at_s = physics[name].dropped_at_s
            own.add(name)
        if op.supply is not None and plug_name("supply", op.supply) not in physics:
            rec.refilled = "nothing_picked"  # no plug: the supply cell was empty
        elif op.supply is not None:
            name = plug_name("supply", op.supply)
            own.add(name)
            p = physics[name]
            rec.refilled = "void" if void else judge.refilled(data, p, xy)
            rec.refill_dropped_at_s = p.dropped_at_s
            rec.refill_peak_load_n = round(p.peak_load_n, 6)
            if rec.refilled == "seated":
                rec.retention = p.mass_kg / p.mass0
            rec.leaf_damage = damage_by_plug.get(name, [])
        else:
            rec.refilled = "no_supply"
        records.append(rec)
    neighbours = [d for plug, ds in sorted(damage_by_plug.items()) if plug not in own for d in ds]
    failures: dict[str, int] = {}

    def fail(kind: str) -> None:
        failures[kind] = failures.get(kind, 0) + 1

    for r in records:
        if r.culled in ("dropped", "left", "jammed"):
            fail(f"cull_{r.culled}")
        if r.refilled not in ("seated", "void"):
            fail(f"refill_{r.refilled}")
        if r.leaf_damage:
            fail("leaf_damage")
    if neighbours:
        failures["neighbour_leaf_damage"] = len(neighbours)
    if fault is not None:
        fail(
            next((kind for kind, head in FAULT_KINDS if fault.startswith(head)), "controller_error")
        )
    end = host.marks.get("end")
    image = host.marks.get("image", 0.0)
    tray_time = (end - image) if (end is not None) else math.nan
    w0, w1 = host.marks.get("work_start"), host.marks.get("work_end")
    work_time = (w1 - w0) if (end is not None and w0 is not None) else math.nan
    ops_done = sum(1 for r in records if not math.isnan(r.end_s))
    per_op = work_time / ops_done if ops_done else math.nan
    cycle = tray_time + job.tray_change_s
    handled = sum(1 for r in records if r.culled == "binned") + sum(
        1 for r in records if r.refilled == "seated"
    )
    basis, (needed, plants) = "tray", whole
    if end is not None and fault is None and 0 < ops_done == len(ops) < needed:
        # a partial run (max_cells): the whole tray's rates, its own time counted once, the
        # serviced cells' work and plants scaled by the plants the grading asks of the tray
        # against those of these cells (an inferior cell's two, an empty one's one)
        scale = plants / sum(_plants_of(op.truth) for op in ops)
        cycle = (tray_time - work_time) + job.tray_change_s + work_time * scale
        handled = handled * scale
        basis = "whole_tray_estimate"
    picked = [r for r in records if r.supply_index is not None and r.refilled != "nothing_picked"]
    damaged = sum(1 for r in picked if r.leaf_damage)
    kept = [r.retention for r in records if r.retention is not None]
    culled = {plug_name("planting", r.index) for r in records if r.culled == "binned"}
    seated = [r for r in records if r.refilled == "seated"]
    in_tray = sum(1 for c in planting.cells if c.seedling is not None) - len(culled) + len(seated)
    torn_here = {p for p in damage_by_plug if p.startswith("p") and p not in culled}
    torn_here |= {plug_name("supply", r.supply_index) for r in seated if r.leaf_damage}
    off = ("dropped", "jammed")  # off the pins, out of place
    dropped = sum(1 for r in records if r.culled in off or r.refilled in off)
    return DeltaRefillResult(
        seed=seed,
        pose_judgement=job.pose_judgement,
        operations=ops_done,
        tray_time_s=tray_time,
        time_per_operation_s=per_op,
        work_time_s=work_time,
        plants_per_hour=3600.0 * handled / cycle if cycle > 0 else math.nan,
        trays_per_hour=3600.0 / cycle if cycle > 0 else math.nan,
        cells_to_service=whole[0],
        rate_basis=basis,
        leaf_damage_rate=damaged / len(picked) if picked else 0.0,
        tray_leaf_damage_rate=len(torn_here) / in_tray if in_tray else 0.0,
        dropped=dropped,
        substrate_retention=float(np.mean(kept)) if kept else None,
        failures=failures,
        cells=records,
        neighbour_leaf_damage=neighbours,
        fault=fault,
        refused=list(controller.refused),
        peak_following_error_deg=[round(math.degrees(v), 6) for v in drives.peak_error_rad],
        planner=sc.motion.planner,
        wall_time_s=wall,
        sim_time_s=sim_t,
        valid=valid,
    )


def require_delta(sc) -> None:
    """ScenarioError unless the scenario runs the delta with the plug claws: the tray job's
    scene hangs the delta over the two 566 x 286 mm trays and the bin, and its host plans the
    delta's transfers; for a robot whose workspace misses the trays' key points the reason
    says so, with the spans compared (`scenario.reach`)."""
    from transplanter.scenario.reach import reach_refusal

    far = reach_refusal(sc) if sc.robot.kind != "delta" else None
    require_kinds(
        sc,
        "the plug-tray job",
        "delta",
        "plug_claws",
        "its scene hangs the delta and its claws over two 566 x 286 mm trays and a bin"
        + (f"; {far}" if far else ", and its host drives the delta's own controller"),
    )


def job_spec(sc, seed: int | None = None) -> mujoco.MjSpec:
    """The scene `run_delta_refill(sc, seed)` builds, as an MjSpec (`transplanter export`):
    the same scene config, trays and job cells, with the `home` keyframe set to its power-on
    state (arms, platform and claws)."""
    require_delta(sc)
    seed = sc.seed if seed is None else seed
    kin = DeltaKinematics.from_scenario(sc)
    cfg = _scene_config(sc, kin)
    planting, supply = _trays(sc, seed)
    ops = plan_job(sc, planting, supply, grading_map(sc, seed, planting, supply))
    cells = _job_cells(ops, planting)
    spec = build_delta_spec(cfg, planting, supply, cells)
    model = compile_scene(spec)
    key = spec.add_key(name="home")
    key.qpos = delta_robot.home_qpos(model, cfg, (0.0, 0.0, cfg.work_z_m)).tolist()
    ctrl = np.zeros(model.nu)
    ctrl[:3] = delta_robot.home_ctrl(cfg)
    ctrl[3:6] = plug_claws.home_ctrl(cfg.claws)
    key.ctrl = ctrl.tolist()
    return spec


def _trays(sc, seed: int) -> tuple[TrayDraw, TrayDraw]:
    """The planting tray of `seed` and the supply tray of seed + supply_seed_offset, drawn
    with [vision]'s seedling draw."""
    from transplanter.scenario.assemble import vision_config

    draw = vision_config(sc).seedlings
    return draw_tray(seed, draw), draw_tray(seed + sc.delta_refill.supply_seed_offset, draw)


def _job_cells(ops: list[_Op], planting: TrayDraw) -> JobCells:
    """The cells the job touches. A cell graded empty that holds a plug (a misgrade) has its
    plug built free in its walls, as a culled one's: the refill let go over it meets it."""
    on_plug = [o.cell for o in ops if o.truth == EMPTY and planting.cells[o.cell].seedling]
    return JobCells(
        culled=tuple(o.cell for o in ops if o.truth == INFERIOR) + tuple(on_plug),
        filled=tuple(o.cell for o in ops if o.truth == EMPTY),
        supply=tuple(o.supply for o in ops if o.supply is not None),
    )


def _grading_costs(
    sc, result: DeltaRefillResult, planting: TrayDraw, supply: TrayDraw, grades: GradingMap
) -> None:
    """Each serviced cell's grade beside its truth and what a misgrade cost it (MISGRADES),
    the misgraded cells the job passed over (up to its last cell in index order: the whole
    tray when it serviced every cell it found), and the map's confusion and wall times."""
    job = sc.delta_refill
    fixed = math.degrees(job.fixed_rotary_rad)
    truth_supply = truth_grades(supply)
    misgraded: list[dict] = []

    def cost(kind: str, tray: str, index: int, grade: str, truth: str) -> None:
        misgraded.append({"kind": kind, "tray": tray, "index": index, "grade": grade,
                          "truth": truth})  # fmt: skip
        result.failures[f"misgrade_{kind}"] = result.failures.get(f"misgrade_{kind}", 0) + 1

    for rec in result.cells:
        kinds = []
        if rec.grade == INFERIOR and rec.truth in HEALTHY_CLASSES:
            kinds.append("healthy_culled")
        if rec.grade == INFERIOR and rec.truth == EMPTY:
            kinds.append("empty_culled")
        if rec.grade == EMPTY and rec.truth != EMPTY:
            kinds.append("refill_on_plug")
        for kind in kinds:
            cost(kind, "planting", rec.index, rec.grade, rec.truth)
        if rec.supply_index is not None:
            i = rec.supply_index
            rec.supply_grade, rec.supply_truth = grades.supply.cells[i].grade, supply.cells[i].truth
            rec.rotary_truth_deg = rotary_for(truth_supply.cells[i], job.pose_judgement, fixed)
            extra = []
            if rec.supply_truth == INFERIOR:
                extra.append("inferior_planted")
            elif rec.supply_truth == EMPTY:
                extra.append("empty_picked")
            if rec.leaf_damage and rec.rotary_deg != rec.rotary_truth_deg:
                extra.append("orientation_damage")
            for kind in extra:
                cost(kind, "supply", i, rec.supply_grade, rec.supply_truth)
            kinds += extra
        rec.misgrades = kinds
    serviced = {r.index for r in result.cells}
    todo = [i for i, c in enumerate(grades.planting.cells) if c.grade in (INFERIOR, EMPTY)]
    covered = len(planting.cells)
    if job.max_cells and len(todo) > job.max_cells:
        covered = max(serviced) + 1 if serviced else 0
    for cell, graded in zip(planting.cells[:covered], grades.planting.cells, strict=False):
        if cell.index in serviced or graded.grade in (INFERIOR, EMPTY):
            continue
        if cell.truth == INFERIOR:
            cost("inferior_left", "planting", cell.index, graded.grade, cell.truth)
        elif cell.truth == EMPTY:
            cost("empty_missed", "planting", cell.index, graded.grade, cell.truth)
    result.failures = dict(sorted(result.failures.items()))
    result.vision = grades.source
    result.grading = grades.summary(planting, supply)
    result.misgraded = misgraded
