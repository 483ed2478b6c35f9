"""The delta on the seedling job (`transplanter trial delta_pots`): the rotary delta of seed
002 (Zhao, Cheng, Dong, Ma, Xiong and Tong, *Research on the End Effector and Optimal Motion
Control Strategy for a Plug Seedling Transplanting Parallel Robot*) hung over the five-bar's
pot line (the `conveyor_tube` workcell of seed 000: paper pots in rows on a feeding conveyor,
a drop tube), so that its cycle and success stand beside the five-bar's and the serial arm's.

The scene: the delta (models/delta) with its base frame at `[delta_pots] base_*` over the
line, the workcell merged in as the serial arm's scene merges it, and the fuzzy gripper of
seed 004 (models/effectors/fuzzy_gripper, sized for these pots by the serial arm's scenario)
attached under the platform by MjSpec attach, its fingers pointing down and, at the default
`gripper_yaw_deg = 90`, closing across the belt (world y): the front pad meets nothing but the
pot, the back one goes down in the 10 mm gap to the next row (closing along the row, as the
serial arm's do, both pads go down between neighbours, and the cells' 3 mm play puts one on a
neighbour's rim now and then). The pot is held by the pads' friction only: the only
equalities in the scene are the delta's own six that close its parallelograms and the
gripper's finger coupling.

The chain is the delta's (`twin.delta_refill`): host over the bus, the controller
(`DeltaController`: the SGF with `DeltaKinematics` at every interpolated point and the
pre-move joint check), the pulse-train servo drives (`PulseServos`, with their
following-error alarm), MuJoCo. The gripper's SG90 is driven as on the serial arm: `M280 P0
S<deg>` sets its channel, the board's 50 Hz PWM frame carries it to a `HobbyServo`. The host
sends a fixed grip angle (`grip_deg`, the fuzzy controller's Small centroid, 22.5 deg: the
angle the controller gives every pot of the serial arm's pot trials); the controller itself
is not run, because two of its three inputs do not exist here (its sensor 2 looks along a
level gripper at the fruit, and its third input is the serial arm's base servo angle). Each
pickup cell's sensor 1 is there as in serial_pots (an HC-SR04 in front of the cell, looking
across the belt): a cell it reads empty is skipped, and a pot it still hears after the lift
is grasped again (`attempts`).

For every pot of the pickup row: over the pot at `hover_mm`, down, grip, dwell, up; over the
drop tube, down until the pot's bottom is `release_gap_mm` above the funnel, open, up. With
`motion.planner = "bspline5"` the transfers (from the lift over the pot down onto the
release, from the release down onto the next pot) are `G0` lines, the controller's
time-optimal splines (lift, arc, top, arc, descent). After each row the arm parks over the
tube and `M710` indexes the conveyor (as serial_pots).

Judged as serial_pots: a pot inside the tube below the funnel's throat is a success; one
still on the belt was missed; anywhere else it was dropped.
"""

from __future__ import annotations

import math
import time
from types import SimpleNamespace
from typing import Any

import mujoco
import numpy as np

from transplanter.machine.bus import ComBus
from transplanter.machine.delta_drives import DeltaController, PulseServos
from transplanter.machine.fuzzy_gripper import NO_ECHO, UltrasonicSensor
from transplanter.machine.gcode import format_number
from transplanter.machine.host import Call, HostProgram, Wait
from transplanter.machine.kinematics.delta import DeltaKinematics
from transplanter.machine.pgf import LinePhase
from transplanter.machine.rig import SimulatedEndstops
from transplanter.machine.servo import ServoMount, servo_class
from transplanter.machine.servo_drives import ServoBank, frame_steps
from transplanter.scenario.assemble import delta_sgf_config, judge_config
from transplanter.scene.effectors import fuzzy_gripper
from transplanter.scene.robots import delta as delta_robot
from transplanter.twin.loop import StepLoop
from transplanter.twin.motors import MotorMeter
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
from transplanter.twin.serial_arm import SENSE_CYCLE_S, _Ranger
from transplanter.twin.serial_pots import DETECTED_CM, PotRecord, line_config

__all__ = [
    "DEFINITIONS",
    "check",
    "check_placement",
    "run_delta_pots",
    "scene_spec",
]

PLACEMENT_KEYS = "delta_pots.base_x_mm, base_y_mm, base_z_mm"
POWER_ON_M = np.array([0.0, 0.0, -0.8])
"""The platform centre at power-on, in the delta's frame: the pose models/delta is drawn in
(delta_refill's work height), where the rods of its closed chains start consistent."""
POWER_ON_CLEARANCE_M = 0.02
"""At power-on the grip centre is at least this high above the pots' tops."""
GRIPPER_QUAT = (0.5, 0.5, 0.5, -0.5)
"""The gripper's mount under the platform at `gripper_yaw_deg = 0`: its forward axis (the
fingers) along world -z, its closing axis along world x (along the row), its sensor side
towards world -y; the yaw turns it about the vertical."""


def _rot(quat) -> np.ndarray:
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, np.asarray(quat, dtype=np.float64))
    return mat.reshape(3, 3)


def tool_drop_m(sc) -> float:
    """The grip centre below the platform's centre: the platform's half thickness, the
    mount's drop and the gripper's reach (mount to grip centre)."""
    from transplanter.scenario.assemble import fuzzy_gripper_config

    return (
        delta_robot_half_thickness()
        + sc.delta_pots.mount_drop_m
        + fuzzy_gripper.reach_m(fuzzy_gripper_config(sc))
    )


def delta_robot_half_thickness() -> float:
    from transplanter.scene.delta_scene import PLATFORM_HALF_THICKNESS_M

    return PLATFORM_HALF_THICKNESS_M


def _base(sc) -> np.ndarray:
    j = sc.delta_pots
    return np.array([j.base_x_m, j.base_y_m, j.base_z_m])


def platform_point(sc, grip_world) -> np.ndarray:
    """The platform centre in the delta's base frame (the kinematics' point) that puts the
    grip centre at ``grip_world`` (workcell frame, m)."""
    return np.asarray(grip_world, dtype=np.float64) - _base(sc) + [0.0, 0.0, tool_drop_m(sc)]


def _points(sc, line) -> dict[str, np.ndarray]:
    """The job's grip-centre points (workcell frame): each pickup cell's grasp and the
    hover point above it, the release over the tube and the hover above it."""
    from transplanter.scene.geometry import cell_columns_x

    job = sc.delta_pots
    up = np.array([0.0, 0.0, job.hover_m])
    out = {}
    for col, x in enumerate(cell_columns_x(line)):
        grasp = np.array([x, line.pickup_row_y_m, job.grasp_z_m])
        out[f"the grasp of pickup column {col + 1}"] = grasp
        out[f"the hover point above pickup column {col + 1}"] = grasp + up
    release = np.array([*line.drop_tube_xy_m, line.funnel_top_z_m + job.release_gap_m
                        + job.grasp_z_m])  # fmt: skip
    out["the release over the drop tube"] = release
    out["the hover point over the drop tube"] = release + up
    return out


def check_placement(sc) -> None:
    """ScenarioError naming the placement keys when the delta's base at `[delta_pots]
    base_*` puts a pickup cell's grasp, the hover point above it, the release over the drop
    tube or the hover above it outside the delta's workspace (each arm's chain closes, the
    arm angles in [q_min, q_max], the Jacobian's condition, the platform's Z window:
    `DeltaKinematics.check` and `limit_target`); nothing is built or run."""
    from transplanter.scenario.schema import ScenarioError

    kin = DeltaKinematics.from_scenario(sc)
    line = line_config(sc)
    where = "the delta's base at (" + ", ".join(f"{1e3 * v:g}" for v in _base(sc)) + ") mm"
    top = line.pot_height_m + POWER_ON_CLEARANCE_M
    start = _base(sc)[2] + POWER_ON_M[2] - tool_drop_m(sc)
    if start < top:
        raise ScenarioError(
            f"{where} puts the gripper into the line at power-on (the platform "
            f"{-1e3 * POWER_ON_M[2]:g} mm below the base, as models/delta is drawn: grip centre "
            f"{1e3 * start:.1f} mm above the belt, under the pots' tops + "
            f"{1e3 * POWER_ON_CLEARANCE_M:g} mm = {1e3 * top:.1f} mm); raise it "
            f"({PLACEMENT_KEYS})"
        )
    for name, grip in _points(sc, line).items():
        p = platform_point(sc, grip)
        report = kin.check(p[None, :])
        why = report.reasons[0] if not report.ok[0] else None
        if why is None:
            z = kin.limit_target(p)
            why = None if z is None else str(z.text() if hasattr(z, "text") else z)
        if why:
            raise ScenarioError(
                f"{where} cannot reach {name} (grip centre at "
                f"{', '.join(f'{1e3 * v:.1f}' for v in grip)} mm on the line; platform at "
                f"{', '.join(f'{1e3 * v:.1f}' for v in p)} mm in the delta's frame): {why}; "
                f"move it ({PLACEMENT_KEYS}) or change [delta]"
            )


def _subtree_mass(body) -> float:
    return float(body.mass) + sum(_subtree_mass(c) for c in body.bodies)


def scene_spec(sc, seed: int, decor: bool = False):
    """The job's scene: the delta over the pot line with the fuzzy gripper under its
    platform and each pickup cell's sensor 1 (the pots' decor only with `decor`: a drawing's,
    never the physics'). Returns (spec, line config, gripper config, the pots drawn: a
    PotBatch)."""
    from transplanter.scenario.assemble import fuzzy_gripper_config
    from transplanter.scene import kinds
    from transplanter.scene.build import merge_models, workcell_xml
    from transplanter.scene.delta_scene import models_dir
    from transplanter.scene.geometry import cell_columns_x

    job, d = sc.delta_pots, sc.delta
    root = models_dir()
    line = line_config(sc)
    grip = fuzzy_gripper_config(sc)
    robot_file = root / delta_robot.MODEL / f"{delta_robot.MODEL}.xml"
    spec = merge_models([robot_file, workcell_xml("conveyor_tube", root)], "delta_pots_scene")
    for key in list(spec.keys):  # the scene's power-on state is set by the job
        spec.delete(key)
    spec.body("base").pos = list(_base(sc))
    gripper = mujoco.MjSpec.from_file(str(root / delta_robot.EFFECTOR_MODEL.replace(
        "plug_claws/plug_claws", "fuzzy_gripper/fuzzy_gripper")))  # fmt: skip
    for key in list(gripper.keys):
        gripper.delete(key)
    spec.option.impratio = gripper.option.impratio  # the gripper's friction-cone setting
    half = float(spec.geom("platform").size[1])
    turn = np.array(
        [math.cos(job.gripper_yaw_rad / 2), 0.0, 0.0, math.sin(job.gripper_yaw_rad / 2)]
    )
    quat = np.zeros(4)
    mujoco.mju_mulQuat(quat, turn, np.asarray(GRIPPER_QUAT, dtype=np.float64))
    frame = spec.body("platform").add_frame(
        pos=[0.0, 0.0, -half - job.mount_drop_m], quat=quat.tolist()
    )
    with delta_robot.quiet_prefix_note():
        frame.attach_body(gripper.body(fuzzy_gripper.MOUNT), "", "")
    fuzzy_gripper.apply(spec, grip)
    delta_robot.apply(spec, d)
    mount = _subtree_mass(spec.body(fuzzy_gripper.MOUNT))
    spec.geom("platform").mass = max(float(d.platform_mass_kg) - mount, 0.05)
    spec.option.timestep = sc.physics.timestep_s
    cell = kinds.workcell("conveyor_tube")
    cell.apply(spec, line)
    pots = cell.populate(spec, line, seed, decor=decor)
    y = line.pickup_row_y_m - line.pot_diameter_m / 2 - job.sensor_gap_m
    for c, x in enumerate(cell_columns_x(line)):
        body = spec.worldbody.add_body(name=f"station_sensor_c{c}", pos=[x, y, job.sensor_z_m])
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.0225, 0.001, 0.01], contype=0,
                      conaffinity=0, group=2, rgba=[0.1, 0.45, 0.2, 1])  # fmt: skip
        body.add_site(name=f"station_sensor_c{c}", zaxis=[0, 1, 0], size=[0.002, 0, 0])
    return spec, line, grip, pots


def power_on(sc, model: mujoco.MjModel, data: mujoco.MjData, grip) -> np.ndarray:
    """The scene's power-on state in `data`: the delta as drawn (its closed chains' rods
    consistent, as delta_refill's), its drives holding it, the gripper open at its standby;
    returns the arm angles (rad)."""
    d = sc.delta
    q0 = DeltaKinematics.from_scenario(sc).joints(POWER_ON_M)
    cfg = SimpleNamespace(gear_ratio=d.gear_ratio, home_q_rad=tuple(float(v) for v in q0))
    data.qpos[:] = delta_robot.home_qpos(model, cfg, _base(sc) + POWER_ON_M)
    for name, q in fuzzy_gripper.home_joints(grip).items():
        data.qpos[model.jnt_qposadr[model.joint(name).id]] = q
    data.ctrl[[model.actuator(n).id for n in delta_robot.ACTUATORS]] = delta_robot.home_ctrl(cfg)
    data.ctrl[model.actuator(fuzzy_gripper.ACTUATOR).id] = fuzzy_gripper.home_ctrl(grip)[0]
    mujoco.mj_forward(model, data)
    return q0


def _mm(v: float) -> str:
    """Metres (or m/s) as a G-code word's mm (mm/s), to the micrometre."""
    return format_number(round(float(v) * 1e3, 3))


def _ms(seconds: float) -> str:
    """Seconds as a `G4 P` word's milliseconds."""
    return format_number(round(float(seconds) * 1e3, 3))


def require_delta_gripper(sc) -> None:
    """ScenarioError naming the key unless the scenario runs the delta with the fuzzy
    gripper (the job's scene and host are built around them)."""
    from transplanter.scenario.assemble import require_kinds

    require_kinds(
        sc,
        "the delta's pot job",
        "delta",
        "fuzzy_gripper",
        "its scene hangs the fuzzy gripper under the delta's platform over the pot line",
    )


def check(sc) -> None:
    """ScenarioError (or ValueError: a timestep the servos' PWM frame cannot divide) for what
    the delta's pot job cannot run: its robot and gripper, its placement; nothing is built."""
    frame_steps(sc.physics.timestep_s)
    require_delta_gripper(sc)
    check_placement(sc)


def run_delta_pots(sc, seed: int | None = None, progress=None, observers=()) -> PotJobResult:
    """`scenario.seedlings` pots of the scenario's pot line (seed `seed`, default the
    scenario's), picked row by row into the drop tube by the delta (module docstring).
    `progress(done, sim_t)`: called once a simulated second with the pots done; `observers`
    (`viewing.loop_recording.LoopRecording`) watch the loop without changing it."""
    from transplanter.scene.geometry import cell_columns_x

    require_delta_gripper(sc)
    check_placement(sc)
    wall0 = time.perf_counter()
    seed = sc.seed if seed is None else seed
    job, d = sc.delta_pots, sc.delta
    dt = sc.physics.timestep_s
    per_frame = frame_steps(dt)  # ValueError: the servos' PWM frame needs a dividing step
    spec, line, grip, pots = scene_spec(sc, seed)
    with delta_robot.quiet_prefix_note():
        model = spec.compile()
    data = mujoco.MjData(model)
    kin = DeltaKinematics.from_scenario(sc)
    xs = cell_columns_x(line)
    pts = _points(sc, line)
    release = pts["the release over the drop tube"]
    up = np.array([0.0, 0.0, job.hover_m])
    park = release + up

    def plat(grip_world) -> np.ndarray:
        return platform_point(sc, grip_world)

    q0 = power_on(sc, model, data, grip)
    arm_acts = [model.actuator(n).id for n in delta_robot.ACTUATORS]
    grip_act = model.actuator(fuzzy_gripper.ACTUATOR).id
    meter = MotorMeter(model, delta_robot.ACTUATORS, fuzzy_gripper.ACTUATORS)

    sgf_cfg = delta_sgf_config(sc, job, kin, conveyor_index_s=sc.conveyor.index_time_s)
    controller = DeltaController(sgf_cfg)
    endstops = SimulatedEndstops(sgf_cfg, q0)
    drives = PulseServos(kin, q0, job.following_error_limit_rad)
    bus = ComBus(baud_bps=sc.bus.baud_bps)
    # the gripper's SG90 on the controller's servo output: its angle theta4 as the horn's
    gripper_mount = ServoMount(servo_class(grip.servo), 0.0)
    standby_deg = grip.open_angle_deg
    gripper_rad = [math.radians(standby_deg)]
    bank = ServoBank([gripper_mount], [gripper_rad[0]])
    travel = gripper_mount.servo.travel_rad

    # sensor 1 of each pickup cell (as serial_pots): one reading every SENSE_CYCLE_S
    sensor = UltrasonicSensor(resolution_m=sc.serial_arm.sensor_resolution_m)
    streams = np.random.default_rng([seed, 4005]).spawn(line.cols)
    rangers = [_Ranger(model, f"station_sensor_c{c}", sensor, streams[c]) for c in range(line.cols)]
    sense_every = max(1, round(SENSE_CYCLE_S / dt))

    n = min(sc.meta.seedlings, line.rows * line.cols)
    grips = [PotRecord(i, f"pot_{i // line.cols}_{i % line.cols}", *divmod(i, line.cols))
             for i in range(n)]  # fmt: skip
    finger_adr = [model.jnt_qposadr[model.joint(f).id] for f in fuzzy_gripper.FINGERS]

    def station(col: int):
        return lambda _t: rangers[col].last_cm

    spline = sc.motion.planner == "bspline5"
    v_travel, v_app = _mm(job.travel_speed_m_s), _mm(job.approach_speed_m_s)
    open_line = f"M280 P0 S{format_number(round(standby_deg, 2))}"
    grip_line = f"M280 P0 S{format_number(round(math.degrees(job.grip_rad), 2))}"

    def g1(grip_world, speed: str) -> str:
        x, y, z = (_mm(v) for v in plat(grip_world))
        return f"G1 X{x} Y{y} Z{z} S{speed}"

    def g0(grip_world) -> str:
        x, y, z = (_mm(v) for v in plat(grip_world))
        return f"G0 X{x} Y{y} Z{z}"

    def onto(grip_world):
        """Host lines onto ``grip_world`` from wherever the gripper is: one spline (bspline5:
        its lift, arc, top, arc and descent, straight down its last `exit_mm`), or a travel
        line to the hover point over it and the approach line down."""
        if spline:
            yield g0(grip_world)
        else:
            yield g1(grip_world + up, v_travel)
            yield g1(grip_world, v_app)

    def mark(i: int, key: str):
        def fn(t: float) -> None:
            setattr(grips[i], key, t)

        return fn

    def took(rec: PotRecord):
        def fn(_t: float) -> None:
            rec.grip_deg = math.degrees(job.grip_rad)
            rec.gripper_reached_deg = math.degrees(float(data.qpos[finger_adr].sum()))

        return fn

    def program():
        yield "G28"
        yield "G90"
        yield open_line
        yield g1(park, v_travel)
        for row in range(line.rows):
            for col in range(line.cols):
                i = row * line.cols + col
                if i >= n:
                    break
                yield "M400"
                yield Wait(2 * SENSE_CYCLE_S)
                reading = yield Call(station(col))
                if reading == NO_ECHO or reading > DETECTED_CM:
                    grips[i].outcome = "no pot"
                    yield pot_job.skipped(i)
                    continue
                grasp = np.array([xs[col], line.pickup_row_y_m, job.grasp_z_m])
                yield Call(mark(i, "start_s"))
                yield pot_job.sent(LinePhase.APPROACH, i)
                for attempt in range(1, job.attempts + 1):
                    grips[i].attempts = attempt
                    yield from onto(grasp)
                    yield "M400"
                    yield pot_job.done(LinePhase.APPROACH, i)
                    yield grip_line
                    yield pot_job.done(LinePhase.CLOSE, i)
                    yield f"G4 P{_ms(job.grip_settle_s)}"
                    yield "M400"
                    yield Call(took(grips[i]))
                    yield g1(grasp + up, v_app)
                    yield "M400"
                    yield pot_job.done(LinePhase.LIFT, i)
                    yield Wait(2 * SENSE_CYCLE_S)
                    reading = yield Call(station(col))
                    if reading > DETECTED_CM:  # the cell is empty: the pot is up
                        break
                    yield open_line  # sensor 1 still hears the pot in its cell: missed
                    yield f"G4 P{_ms(job.release_settle_s)}"
                else:
                    yield Call(mark(i, "end_s"))
                    yield pot_job.give_up(i, f"sensor 1 still heard it after {job.attempts} "
                                          "grasps")  # fmt: skip
                    continue
                yield from onto(release)  # its ok: the move's last step is out
                yield pot_job.done(LinePhase.TO_DROP, i)
                yield open_line
                yield pot_job.done(LinePhase.RELEASE, i)
                yield f"G4 P{_ms(job.release_settle_s)}"
                if not spline:  # a spline leaves the release upwards itself
                    yield g1(release + up, v_app)
                yield "M400"
                yield Call(mark(i, "end_s"))
                yield pot_job.done(LinePhase.RELEASE_WAIT, i)
            if (row + 1) * line.cols >= n:
                break
            yield g1(park, v_travel)
            yield "M710"
            yield "M400"
            yield pot_job.done(LinePhase.INDEX, min(n, (row + 1) * line.cols) - 1)
        yield g1(park, v_travel)
        yield "M400"

    host = HostProgram(program(), bus)
    loop = StepLoop(
        model, data, host, bus, controller, endstops, controller.sgf.drain_machine_events
    )
    scene = pot_line(model, line, pots, fuzzy_gripper.PARTS)
    pickups = [(x, line.pickup_row_y_m) for x in xs]
    pot_job = PotJob(loop, scene, judge_config(sc), pickups, job.hover_m, n,
                     event_sink(observers), seed)  # fmt: skip
    drive = pot_job.conveyor
    arms = [model.jnt_qposadr[model.joint(name).id] for name in delta_robot.ARMS]
    gear = d.gear_ratio
    limit_s = 60.0 + 20.0 * n
    pending: list[tuple[float, int, float]] = []
    state: dict[str, Any] = {"fault": None}

    def index_conveyor(t_event: float, name: str) -> None:
        if name == "conveyor_index":
            pot_job.index(t_event, sgf_cfg.conveyor_index_s)

    def servo(t: float, commands: list) -> None:
        pending.extend(commands)
        while pending and pending[0][0] <= t:
            _, index, value = pending.pop(0)
            if index == 0:
                gripper_rad[0] = min(max(math.radians(float(value)), 0.0), travel)

    def commands(t: float) -> None:
        k = loop.k
        if k % per_frame == 0:
            bank.command([int(gripper_mount.pulse_us(gripper_rad[0]))])
        if k % sense_every == 0:
            for ranger in rangers:
                ranger.measure(data)
        command = drives.command(loop.raw)
        measured = data.qpos[arms]
        if drives.watch(t, command, measured) is not None and state["fault"] is None:
            state["fault"] = drives.alarm.text()
            loop.settle_until(t + 1.0)
        data.ctrl[arm_acts] = gear * (measured if state["fault"] else command)
        data.ctrl[grip_act] = bank.step(dt, [-data.actuator_force[grip_act]])[0]
        if drive.armed(data):
            drive.apply(data, t)

    report = reporter(progress, pot_job, dt) if progress is not None else None

    def watch(_t: float) -> None:
        meter.record(data)
        if report is not None:
            report(loop.time)

    loop.on_event.append(index_conveyor)
    loop.on_servo.append(servo)
    loop.before_step.append(commands)
    loop.after_step.append(watch)
    for observer in observers:
        observer.attach(loop)
    try:
        timed_out = loop.run_program(limit_s, settle_s=1.0)
    except BaseException:
        for observer in observers:
            observer.abort()
        raise
    fault, t, k = state["fault"] or timed_out, loop.last_t, loop.k
    if fault is None and host.error is not None:
        fault = host.error
    valid = t <= limit_s and not any(int(w.number) for w in data.warning)
    pot_job.finish(k * dt, valid)
    for grip_rec, rec in zip(grips, pot_job.records, strict=True):
        grip_rec.outcome = str(rec.outcome)
    result = PotJobResult(
        scenario=sc.meta.name,
        seed=seed,
        per_seedling=pot_job.records,
        sim_time_s=k * dt,
        wall_time_s=0.0,
        valid=valid,
        invalid_reason=None if valid else INVALID,
        fault=fault,
        overrides=dict(sc.overrides),
        motors=meter.report().to_dict(),
        trial="delta_pots",
        pots=grips,
        extra={
            "planner": sc.motion.planner,
            "refused": list(controller.refused),
            "peak_following_error_deg": [round(math.degrees(v), 6) for v in drives.peak_error_rad],
        },
        definitions=DEFINITIONS,
    )
    result.recording_error = close_observers(observers, k * dt)
    result.wall_time_s = time.perf_counter() - wall0
    return result
