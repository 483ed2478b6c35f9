"""A standalone bench for the plug-in claws: tray cells with physical plugs, the claw unit on
a three-axis carrier that stands in for the robot, and one pick run through its cycle.

The scene (built by `build_bench`): the claws' model (models/effectors/plug_claws/) with slide
joints x, y, z added to its mount (the carrier: position servos with velocity feed-forward,
following cycloidal moves), a floor, a 2 x 2 block of source cells holding the plug (and a
neighbour) and a 2 x 2 block of empty target cells, made by `transplanter.scene.plug_physics`
(tapered collision walls; free plugs with an outer frustum and an inner pin socket, the only
geom the claws meet; leaves from a drawn seedling of `transplanter.scene.plug_tray`).

`run_pick` runs one pick and applies the substrate's laws each step (`PlugPhysics`: the cell's
adhesion, the pins' load, the substrate lost, the shear that drops the plug; `LeafWatch`: leaf
strikes). `measure_hold` pulls a lifted plug off the claws to measure what the contact carries.
There is no weld or equality anywhere in the model (docs/plug_claws.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import mujoco
import numpy as np

from transplanter.scene.effectors import plug_claws
from transplanter.scene.effectors.plug_claws import ClawCycle, PlugClawsConfig
from transplanter.scene.plug_physics import (
    BIT_TRAY,
    LeafDamage,
    LeafWatch,
    PlugPhysics,
    add_cell,
    add_plug,
    stripper_push,
)
from transplanter.scene.plug_substrate import PlugsConfig, Substrate
from transplanter.scene.plug_tray import CellTruth, Seedling, TrayGeometry
from transplanter.twin.loop import StepLoop

__all__ = [
    "BenchConfig",
    "BenchResult",
    "LeafDamage",
    "build_bench",
    "centred_seedling",
    "measure_hold",
    "model_xml",
    "run_pick",
]

TRAY_TOP_M = 0.05  # the bench's tray top above its floor


def model_xml(models: str | Path | None = None) -> Path:
    """models/effectors/plug_claws/plug_claws.xml."""
    if models is None:
        from transplanter.scene.build import models_dir

        models = models_dir()
    return Path(models) / "effectors" / "plug_claws" / "plug_claws.xml"


@dataclass(frozen=True)
class BenchConfig:
    """One pick on the bench (file units in the names): the rotary setting, the lift (the
    paper's extraction acceleration), the lateral move to the target cell, the release."""

    rotary_deg: float = 0.0
    """The rotary cylinder's setting for this pick (0: claws enter along x, 90: along y)."""
    extraction_accel_m_s2: float = 10.0
    """Peak acceleration of the vertical lift out of the cell (cycloidal profile)."""
    lift_mm: float = 100.0
    """Height of the lift (the paper's Q0Q1)."""
    move_mm: float = 150.0
    """Lateral move from the source to the target cell."""
    move_accel_m_s2: float = 10.0
    """Peak acceleration of the lateral move and of the descent to the target."""
    approach_mm: float = 40.0
    """The claws come down onto the cell from this far above the working height."""
    approach_speed_mm_s: float = 200.0
    """Speed of the descent onto the source cell."""
    release_above_mm: float = 8.0
    """The plug's bottom hangs this far above its seat in the target cell when stripped."""
    timestep_ms: float = 1.0
    """Physics step."""
    settle_after_ms: float = 300.0
    """Time simulated after the release before the outcome is read."""
    carrier_mass_kg: float = 1.0
    """Mass of the carrier that stands in for the robot's platform."""
    carrier_kp_n_m: float = 2e5
    """Stiffness of the carrier's position servos (velocity feed-forward, critical damping)."""
    target_tolerance_mm: float = 4.0
    """A plug within this of the target cell's centre and of its seat's height has arrived."""


@dataclass
class BenchResult:
    """The outcome of one pick. `held`: the pins' substrate did not shear while the plug was
    carried; `in_target`: the plug lies seated in the target cell; `retention`: the substrate
    delivered into the target cell over the plug's initial mass (the paper's substrate
    retention; 0 for a plug that did not arrive); `mass_g`: what is left on the plug."""

    held: bool
    dropped_at_s: float | None
    retention: float
    mass0_g: float
    mass_g: float
    peak_load_n: float
    pin_capacity_n: float
    final_xyz_mm: tuple[float, float, float]
    in_target: bool
    leaf_damage: list[LeafDamage] = field(default_factory=list)
    times_s: dict[str, float] = field(default_factory=dict)
    track_mm: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    """The plug's top centre (x, y, height above the tray's top) at each of `times_s`."""
    tip_depth_mm: float = 0.0
    """How deep the claws' tips stood below the plug's top when the lift began."""
    stripper_peak_n: float = 0.0
    """The largest push of the stripper on the plug while the claws retracted."""

    def as_dict(self) -> dict:
        return {
            "held": self.held,
            "dropped_at_s": self.dropped_at_s,
            "retention": round(self.retention, 6),
            "mass0_g": round(self.mass0_g, 4),
            "mass_g": round(self.mass_g, 4),
            "peak_load_n": round(self.peak_load_n, 5),
            "pin_capacity_n": round(self.pin_capacity_n, 5),
            "in_target": self.in_target,
            "leaf_damage": [d.__dict__ for d in self.leaf_damage],
            "tip_depth_mm": round(self.tip_depth_mm, 4),
            "stripper_peak_n": round(self.stripper_peak_n, 4),
        }


def build_bench(
    plugs: PlugsConfig | None = None,
    claws: PlugClawsConfig | None = None,
    bench: BenchConfig | None = None,
    seedling: Seedling | None = None,
    models: str | Path | None = None,
) -> mujoco.MjSpec:
    """The bench's spec: a 2 x 2 block of source cells (the plug in the cell at the origin, a
    neighbour plug beside it) and a 2 x 2 block of target cells `move_mm` along +x, empty.
    `seedling` (tray frame, mm, about its cell's centre) gives the source plug its leaves."""
    plugs, claws, bench = plugs or PlugsConfig(), claws or PlugClawsConfig(), bench or BenchConfig()
    sub = Substrate(plugs)
    spec = mujoco.MjSpec.from_file(str(model_xml(models)))
    plug_claws.apply(spec, claws)
    plug_claws.add_canopy_contact(spec, claws)
    for key in list(spec.keys):
        spec.delete(key)
    spec.option.timestep = bench.timestep_ms * 1e-3
    mount = spec.body("claws_mount")
    mount.mass = bench.carrier_mass_kg  # the carrier (a robot's platform) with the mount
    mount.inertia = [2e-3, 2e-3, 3e-3]
    mount.pos = [0, 0, TRAY_TOP_M + claws.work_height_m() + bench.approach_mm * 1e-3]
    kp = bench.carrier_kp_n_m
    moving = bench.carrier_mass_kg + 0.4  # the carrier, the head and the claws
    for axis, vec in (("x", [1, 0, 0]), ("y", [0, 1, 0]), ("z", [0, 0, 1])):
        mount.add_joint(name=f"carrier_{axis}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=vec)
        spec.add_actuator(
            name=f"carrier_{axis}",
            target=f"carrier_{axis}",
            trntype=mujoco.mjtTrn.mjTRN_JOINT,
            gaintype=mujoco.mjtGain.mjGAIN_FIXED,
            biastype=mujoco.mjtBias.mjBIAS_AFFINE,
            gainprm=[kp] + [0] * 9,
            biasprm=[0, -kp, 0] + [0] * 7,
        )
        kv = 2 * math.sqrt(kp * moving)  # critically damped
        spec.add_actuator(
            name=f"carrier_{axis}_v",
            target=f"carrier_{axis}",
            trntype=mujoco.mjtTrn.mjTRN_JOINT,
            gaintype=mujoco.mjtGain.mjGAIN_FIXED,
            biastype=mujoco.mjtBias.mjBIAS_AFFINE,
            gainprm=[kv] + [0] * 9,
            biasprm=[0, 0, -kv] + [0] * 7,
        )
    mount.gravcomp = 1.0
    spec.worldbody.add_geom(
        name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0.5, 0.5, 0.01],
        contype=BIT_TRAY, conaffinity=BIT_TRAY, rgba=[0.3, 0.3, 0.32, 1],
    )  # fmt: skip
    spec.worldbody.add_light(pos=[0, 0, 1.0], dir=[0, 0, -1])
    pitch = TrayGeometry().pitch_mm * 1e-3
    for block, x0 in (("src", 0.0), ("dst", bench.move_mm * 1e-3)):
        for i in range(2):
            for j in range(2):
                add_cell(spec, f"{block}{i}{j}", x0 + i * pitch, j * pitch, TRAY_TOP_M, sub)
    add_plug(spec, "plug", 0.0, 0.0, TRAY_TOP_M, sub, claws, seedling)
    add_plug(spec, "neighbour", pitch, 0.0, TRAY_TOP_M, sub, claws, None)
    return spec


def _profile(d: float, a: float, t: float) -> tuple[float, float]:
    """Cycloidal move of length d whose acceleration peaks at a (a sine over the move: no
    jump in acceleration at either end): (position, velocity) at time t."""
    if d == 0.0:
        return 0.0, 0.0
    T = _move_time(d, a)
    u = min(max(t, 0.0), T) / T
    pos = d * (u - math.sin(2 * math.pi * u) / (2 * math.pi))
    vel = d / T * (1.0 - math.cos(2 * math.pi * u))
    return pos, vel


def _move_time(d: float, a: float) -> float:
    """Duration of a cycloidal move of length d with peak acceleration a: sqrt(2 pi d / a)."""
    return math.sqrt(2 * math.pi * abs(d) / a) if d else 0.0


def centred_seedling(cell: CellTruth, geometry: TrayGeometry) -> Seedling:
    """A drawn cell's seedling moved from the tray frame to its cell's centre (mm)."""
    cx, cy = geometry.centre(cell.row, cell.col)
    s = cell.seedling
    if s is None:
        raise ValueError(f"cell {cell.index} is empty")
    leaves = tuple(
        replace(lf, cx=lf.cx - cx, cy=lf.cy - cy, base=(lf.base[0] - cx, lf.base[1] - cy))
        for lf in s.leaves
    )
    return replace(s, stem=(s.stem[0] - cx, s.stem[1] - cy), leaves=leaves)


def run_pick(
    plugs: PlugsConfig | None = None,
    claws: PlugClawsConfig | None = None,
    bench: BenchConfig | None = None,
    seedling: Seedling | None = None,
    models: str | Path | None = None,
) -> BenchResult:
    """One pick: rotate, come down onto the source cell, extend, lift, move to the target
    cell, come down to the release height, retract (the stripper pushes the plug off), leave
    and settle. Deterministic: the same inputs give the same result bit for bit."""
    plugs, claws, bench = plugs or PlugsConfig(), claws or PlugClawsConfig(), bench or BenchConfig()
    sub = Substrate(plugs)
    spec = build_bench(plugs, claws, bench, seedling, models)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    dt = model.opt.timestep
    plug = model.body("plug").id
    physics = PlugPhysics(model, data, "plug", sub)
    leaves = LeafWatch(model, ("plug",), claws.leaf_damage_force_n)
    cycle = ClawCycle(claws)
    carrier = [model.actuator(f"carrier_{a}").id for a in "xyz"]
    carrier_v = [model.actuator(f"carrier_{a}_v").id for a in "xyz"]
    effector = [model.actuator(n).id for n in plug_claws.ACTUATORS]

    # the schedule: (start time, axis, distance, peak acceleration) of each carrier move
    approach = bench.approach_mm * 1e-3
    lift = bench.lift_mm * 1e-3
    move = bench.move_mm * 1e-3
    release = bench.release_above_mm * 1e-3
    t = cycle.rotate(0.0, bench.rotary_deg) if bench.rotary_deg else 0.0
    times = {"rotated": t}
    v_app = bench.approach_speed_mm_s * 1e-3
    t_down = approach / v_app
    moves = [(t, 2, -approach, None, t_down)]
    t += t_down
    times["down"] = t
    t_ext = t + claws.settle_ms * 1e-3
    t_lift = cycle.extend(t_ext) + claws.settle_ms * 1e-3
    times["extended"] = t_lift
    T = _move_time(lift, bench.extraction_accel_m_s2)
    moves.append((t_lift, 2, lift, bench.extraction_accel_m_s2, T))
    t = t_lift + T
    times["lifted"] = t
    T = _move_time(move, bench.move_accel_m_s2)
    moves.append((t, 0, move, bench.move_accel_m_s2, T))
    t += T
    times["moved"] = t
    T = _move_time(lift - release, bench.move_accel_m_s2)
    moves.append((t, 2, -(lift - release), bench.move_accel_m_s2, T))
    t += T
    times["lowered"] = t
    t_ret = t + claws.settle_ms * 1e-3
    times["retract"] = t_ret
    t_off = cycle.retract(t_ret) + claws.settle_ms * 1e-3
    times["released"] = t_off
    T = _move_time(lift, bench.move_accel_m_s2)
    moves.append((t_off, 2, lift, bench.move_accel_m_s2, T))
    t_end = t_off + T + bench.settle_after_ms * 1e-3
    times["end"] = t_end
    home = np.array([0.0, 0.0, 0.0])

    def carrier_ref(tt: float) -> tuple[np.ndarray, np.ndarray]:
        pos, vel = home.copy(), np.zeros(3)
        for t0, ax, dist, acc, dur in moves:
            if tt <= t0:
                continue
            if acc is None:  # constant speed
                s = min(tt - t0, dur)
                pos[ax] += dist * s / dur
                vel[ax] += dist / dur if tt - t0 < dur else 0.0
            else:
                p, v = _profile(dist, acc, tt - t0)
                pos[ax] += p
                vel[ax] += v
        return pos, vel

    track: dict[str, tuple[float, float, float]] = {}
    pending = sorted(times.items(), key=lambda kv: kv[1])
    tip = model.body("claw_right").id
    peaks = {"tip_depth": 0.0, "stripper": 0.0}
    loop = StepLoop(model, data)

    def command(tt: float) -> None:
        pos, vel = carrier_ref(tt)
        data.ctrl[carrier] = pos
        data.ctrl[carrier_v] = vel
        data.ctrl[effector] = cycle.ctrl(tt)
        physics.before_step(data)

    def watch(tt: float) -> None:
        physics.after_step(data, tt, carried=t_lift <= tt < t_ret)
        leaves.after_step(data, tt)
        if t_ret <= tt < t_off:
            peaks["stripper"] = max(peaks["stripper"], stripper_push(model, data, "plug"))
        if tt < t_lift:
            peaks["tip_depth"] = float(data.xpos[plug, 2] - data.xpos[tip, 2])
        while pending and pending[0][1] <= tt + dt / 2:
            name, _ = pending.pop(0)
            x, y, z = (float(v) for v in data.xpos[plug])
            track[name] = (x * 1e3, y * 1e3, (z - TRAY_TOP_M) * 1e3)

    loop.before_step.append(command)
    loop.after_step.append(watch)
    loop.run_steps(int(round(t_end / dt)))
    held = physics.dropped_at_s is None
    in_target = physics.seated_in(data, (move, 0.0), bench.target_tolerance_mm * 1e-3)
    mass = physics.mass_kg
    x, y, z = (float(v) for v in data.xpos[plug])
    return BenchResult(
        held=held,
        dropped_at_s=physics.dropped_at_s,
        retention=mass / physics.mass0 if (held and in_target) else 0.0,
        mass0_g=physics.mass0 * 1e3,
        mass_g=mass * 1e3,
        peak_load_n=physics.peak_load_n,
        pin_capacity_n=physics.capacity_n,
        final_xyz_mm=(x * 1e3, y * 1e3, (z - TRAY_TOP_M) * 1e3),
        in_target=in_target,
        leaf_damage=sorted(leaves.damage, key=lambda d: (d.time_s, d.leaf)),
        times_s=times,
        track_mm=track,
        tip_depth_mm=peaks["tip_depth"] * 1e3,
        stripper_peak_n=peaks["stripper"],
    )


def measure_hold(
    plugs: PlugsConfig | None = None,
    claws: PlugClawsConfig | None = None,
    timestep_ms: float = 1.0,
    ramp_n_s: float = 4.0,
    slip_mm: float = 5.0,
    lift_mm: float = 20.0,
    models: str | Path | None = None,
) -> float:
    """The pins' friction hold (N), measured in the physics: the claws go into a plug, lift it
    `lift_mm` (clear of the cell's adhesion), then a downward pull on the plug grows at
    `ramp_n_s` until the plug has slid `slip_mm` down the claws; the pull then (plus the
    plug's weight) is the hold. The substrate's shear (`Substrate.pin_capacity_n`) is not
    applied here: this is what the contact alone carries."""
    plugs, claws = plugs or PlugsConfig(), claws or PlugClawsConfig()
    bench = BenchConfig(timestep_ms=timestep_ms, approach_mm=0.0)
    spec = build_bench(plugs, claws, bench, None, models)
    model = spec.compile()
    data = mujoco.MjData(model)
    dt = model.opt.timestep
    plug = model.body("plug").id
    mount = model.body("claws_mount").id
    cycle = ClawCycle(claws)
    t_lift = cycle.extend(0.0) + claws.settle_ms * 1e-3
    lift, t_up = lift_mm * 1e-3, 0.1
    z_ctrl = model.actuator("carrier_z").id
    effector = [model.actuator(n).id for n in plug_claws.ACTUATORS]
    weight = float(model.body_mass[plug]) * -float(model.opt.gravity[2])
    t_pull = t_lift + t_up + 0.1
    state: dict[str, float] = {}
    loop = StepLoop(model, data)

    def command(tt: float) -> None:
        s = min(max((tt - t_lift) / t_up, 0.0), 1.0)
        data.ctrl[z_ctrl] = lift * (3 * s * s - 2 * s**3)
        data.ctrl[effector] = cycle.ctrl(tt)
        state["pull"] = max(tt - t_pull, 0.0) * ramp_n_s
        data.xfrc_applied[plug, 2] = -state["pull"]

    def watch(tt: float) -> None:
        gap = float(data.xpos[mount, 2] - data.xpos[plug, 2])
        if tt < t_pull:
            state["gap0"] = gap
        elif gap - state["gap0"] > slip_mm * 1e-3:
            loop.stop("slipped")

    loop.before_step.append(command)
    loop.after_step.append(watch)
    loop.run_steps(int(round((t_pull + 20.0) / dt)))
    if loop.stopped is not None:
        return state["pull"] + weight
    return math.inf
