"""The serial arm's trials (seed 004: Dewi, Nurmaini, Risma, Oktarina and Roriz, *Inverse
kinematic analysis of 4 DOF pick and place arm robot manipulator using fuzzy logic
controller*, IJECE 10(2), 2020), headless: `transplanter trial serial_arm`.

The chain, as on the machine:

- **Host** (the paper's microcontroller program): it reads the two HC-SR04 sensors (sensor 1
  at the pool, sensor 2 on the gripper; `machine.fuzzy_gripper.UltrasonicSensor` on MuJoCo
  rays, one measurement every 60 ms), runs the fuzzy controller of Table 2 on them and the
  base servo's angle, and sends G-code lines one at a time over the bus (waiting for each
  `ok`): `G1 X Y Z` in mm in the paper's frame (x forward, y up, z sideways), `M280 P0 S<deg>`
  for the gripper servo, `M400` to wait for the arm to arrive, `G4` dwells.
- **Controller**: the project's SGF with `Serial4Kinematics`: every interpolated point
  through the arm's IK and its servo windows, each joint counted in microseconds of pulse
  width; `machine.servo_drives.ServoOutputs` is the board's 50 Hz PWM timer.
- **Servos**: `machine.servo_drives.ServoBank`, one `HobbyServo` per channel (rated speed
  slowed by load, dead band, gear backlash, stall), their links tracked by the model's
  torque-limited position actuators.
- **Physics**: the tomatoes are free bodies, held between the fingers by friction only.

Three jobs, each in its own scene, all through this chain:

- **targets** (the paper's Tables 3-5): the ten targets, each commanded from the standby
  pose; where the grip centre comes to rest and the joints' angles, with the errors per axis
  (cm) and per joint (%) computed the paper's way.
- **gripper cases** (Table 6): the 18 trials, each a bench setting of sensor 1 (a tomato at
  the pool's station or none) and sensor 2 (a tomato on a stand at a drawn distance in the
  row's range in front of the gripper), the arm turned to a base angle the row allows; the
  controller's angle, the term it falls in and the angle the gripper reached.
- **pick and place** (Fig. 8): the tomatoes of the pool, one after another, picked at the
  station and released over the belt; success, drops, misses, squeeze force against a bruise
  threshold, cycle time.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Generator, Iterable
from dataclasses import dataclass, field, replace
from typing import Any

import mujoco
import numpy as np

from transplanter.machine.bus import ComBus
from transplanter.machine.fuzzy_gripper import (
    NO_ECHO,
    OUTPUT_RANGES_DEG,
    TABLE6,
    FuzzyGripper,
    UltrasonicSensor,
)
from transplanter.machine.gcode import format_number
from transplanter.machine.host import Call, HostProgram, Wait
from transplanter.machine.kinematics.serial4 import Serial4Kinematics
from transplanter.machine.motion import MotionConfig
from transplanter.machine.pgf import LinePhase
from transplanter.machine.rig import SimulatedEndstops
from transplanter.machine.servo import ServoMount
from transplanter.machine.servo_drives import ServoBank, ServoOutputs, frame_steps
from transplanter.machine.sgf import SGF, SGFConfig
from transplanter.scenario.assemble import require_awake
from transplanter.scene.effectors import fuzzy_gripper
from transplanter.scene.robots import serial4 as serial_robot
from transplanter.twin.loop import StepLoop
from transplanter.twin.motors import MotorMeter

__all__ = [
    "PAPER_TARGETS",
    "GripRecord",
    "GripperCase",
    "PoolToBeltJudge",
    "PickRecord",
    "SerialArmResult",
    "TargetRow",
    "run_gripper_cases",
    "run_pick_place",
    "run_serial_arm",
    "require_own_motion",
    "run_targets",
]

PAPER_TARGETS: tuple[tuple[tuple[float, float, float], tuple[float, float, float]], ...] = (
    ((9, 2, 0), (8.9, 2.1, 0)),
    ((9, 3, 0), (9.1, 3.2, 0)),
    ((9, 4, 0), (9.1, 3.8, 0)),
    ((9, 5, 1), (9.0, 4.9, 1.1)),
    ((9, 6, 1), (8.9, 6.1, 1.1)),
    ((10, 4, 1), (10.2, 3.9, 1.2)),
    ((10, 4, 5), (10.1, 3.9, 5.1)),
    ((11, 4, 5), (11.0, 3.9, 4.9)),
    ((12, 4, 5), (12.1, 4.0, 5.2)),
    ((10, 4, 5), (9.9, 4.0, 5.0)),
)
"""Table 3 (and 4): each target (x, y, z) cm in the paper's frame and where the paper measured
the gripper (Table 4's inputs 10 in rows 8-9 are typos, its errors confirm 11 and 12)."""

PAPER_MEAN_ERRORS_CM = (0.09, 0.10, 0.08)
"""The paper's mean absolute position errors per axis, recomputed from Table 3 (printed as
"0.1, 0.1, 0.04 %"; the z value does not reproduce)."""
PAPER_MEAN_JOINT_ERRORS_PCT = (0.0, 0.7, 0.3)
"""The paper's mean joint errors theta1-theta3 (%), as printed (recomputed 0, 0.66, 0.30)."""

SENSE_CYCLE_S = UltrasonicSensor().cycle_s
CASE_STAND_AWAY_M = 10.0
"""Where the bench parks a stand-in tomato it does not use: far outside every beam."""

DEFINITIONS = {
    "targets": "the ten targets of the paper's Table 3, each commanded from the standby pose",
    "reached_cm": "where the grip centre came to rest, paper frame (x forward, y up, z sideways)",
    "joints_deg": "the joints' angles at rest (the links, as the model's joints read them)",
    "error_cm": "|reached - commanded| per axis; the means are the paper's 'position error'",
    "joint_error_pct": "|measured - IK| / |IK| x 100 per joint (the paper's Eq. 8); a joint "
    "whose IK angle is 0 has no percentage (its error in deg is given)",
    "gripper_cases": "Table 6's 18 trials: sensor readings, base servo angle, the controller's "
    "angle, its term and the angle the gripper reached",
    "success": "a tomato released over the belt and resting on it at the end",
    "missed": "the tomato never left the station",
    "dropped": "the tomato left the station and came to rest neither on the belt nor held",
    "bruised": "a squeeze (the pads' normal force) above bruise_force_n while held",
    "cycle_time_s": "mean time from one pick's start to the next's",
}


# -- the scene -------------------------------------------------------------------------
def _scene(sc, workcell: str | None, tomatoes: int | None = None, seed: int = 0):
    """The serial arm with its gripper, optionally in the pool_to_belt workcell (with
    ``tomatoes`` in its pool; None: the scenario's count). Returns (spec, scene config)."""
    from transplanter.scene import serial_scene

    if workcell is None:
        cfg = serial_scene.serial_scene_config(sc)
    else:
        from transplanter.scene.workcells import pool_to_belt

        wc = pool_to_belt.pool_config(sc)
        if tomatoes is not None:
            wc = replace(wc, count=tomatoes)
        cfg = serial_scene.serial_scene_config(sc, workcell_kind=workcell, workcell=wc)
    spec = serial_scene.build_serial_spec(cfg, seed)
    return spec, cfg


def _compile(spec, cfg):
    from transplanter.scene import serial_scene

    model = serial_scene.compile_scene(spec)
    data = mujoco.MjData(model)
    data.qpos[:] = serial_scene.home_qpos(model, cfg)
    data.ctrl[:] = serial_scene.home_ctrl(model, cfg)
    mujoco.mj_forward(model, data)
    return model, data


def world_to_paper(p, base=(0.0, 0.0, 0.0), yaw_rad: float = 0.0) -> np.ndarray:
    from transplanter.scene.serial_scene import world_to_paper as w2p

    return np.asarray(w2p(p, base, yaw_rad), dtype=np.float64)


def paper_to_world(p, base=(0.0, 0.0, 0.0), yaw_rad: float = 0.0) -> np.ndarray:
    from transplanter.scene.serial_scene import paper_to_world as p2w

    return np.asarray(p2w(p, base, yaw_rad), dtype=np.float64)


# -- the sensors -----------------------------------------------------------------------
class _Ranger:
    """One HC-SR04 on a site of the model: rays along its cone (the site's +z the axis),
    the nearest echo through `UltrasonicSensor` with its own noise stream."""

    def __init__(self, model, site: str, sensor: UltrasonicSensor, rng: np.random.Generator):
        self.model, self.sensor, self.rng = model, sensor, rng
        self.site = model.site(site).id
        self.body = int(model.site_bodyid[self.site])
        self.dirs = sensor.beam_directions()
        self._geomid = np.zeros(1, dtype=np.int32)
        self.last_cm = NO_ECHO

    def measure(self, data) -> float:
        pos = data.site_xpos[self.site]
        rot = data.site_xmat[self.site].reshape(3, 3)
        dist = []
        for d in self.dirs:
            vec = rot @ d
            dist.append(mujoco.mj_ray(self.model, data, pos, vec, None, 1, self.body, self._geomid))
        self.last_cm = self.sensor.reading_cm(dist, self.rng)
        return self.last_cm


# -- the host: machine.host.HostProgram runs the program (lines, waits, calls) -------------


# -- the rig: controller, servos and physics stepped together ----------------------------
class _Rig:
    def __init__(self, sc, model, data, seed: int, flc: FuzzyGripper | None = None, cfg=None):
        job = sc.serial_arm
        self.sc, self.model, self.data = sc, model, data
        self.base = tuple(getattr(cfg, "base_pos_m", (0.0, 0.0, 0.0)))
        self.yaw = float(getattr(cfg, "base_yaw_rad", 0.0))
        self.kin = Serial4Kinematics.from_scenario(sc)
        self.flc = flc or FuzzyGripper()
        motion = MotionConfig(
            resolution_m=job.segment_m,
            accel_m_s2=job.path_accel_m_s2,
            profile="scurve",
            compute_time_per_point_s=job.point_time_s,
        )
        self.sgf_cfg = SGFConfig(
            kinematics=self.kin,
            motion=motion,
            homing=Serial4Kinematics.homing_from_scenario(sc),
            default_speed_m_s=job.travel_speed_m_s,
            command_queue_lines=4,
        )
        self.sgf = SGF(self.sgf_cfg)
        q0 = np.array(self.kin.park_rad)
        self.q0 = q0
        self.endstops = SimulatedEndstops(self.sgf_cfg, q0)
        self.gripper_mount = ServoMount(self.kin.gripper_servo, 0.0)
        self.standby_deg = self.flc.control(NO_ECHO, NO_ECHO, self.base_horn_deg(q0[0]))
        self.outputs = ServoOutputs(
            self.kin.mounts,
            self.gripper_mount,
            q0,
            [a.drive.unit_per_step for a in self.kin.axes],
            self.standby_deg,
        )
        self.bank = ServoBank(
            [*self.kin.mounts, self.gripper_mount], [*q0, math.radians(self.standby_deg)]
        )
        self.bus = ComBus(baud_bps=sc.bus.baud_bps)
        names = ("base", "shoulder", "elbow", "gripper")
        self.acts = np.array([model.actuator(n).id for n in names])
        self.motors = MotorMeter(model, serial_robot.ACTUATORS, fuzzy_gripper.ACTUATORS)
        self.joint_adr = np.array(
            [model.jnt_qposadr[model.joint(n).id] for n in ("base", "shoulder", "elbow")]
        )
        self.finger_adr = np.array(
            [model.jnt_qposadr[model.joint(n).id] for n in ("finger_left", "finger_right")]
        )
        self.grip_site = model.site("grip_center").id
        self.dt = model.opt.timestep
        self.per_frame = frame_steps(self.dt)
        self.sense_every = max(1, round(SENSE_CYCLE_S / self.dt))
        noise = UltrasonicSensor(resolution_m=job.sensor_resolution_m)
        streams = np.random.default_rng([seed, 4004]).spawn(2)
        self.rangers: dict[str, _Ranger] = {
            "gripper": _Ranger(model, "gripper_sensor", noise, streams[0])
        }
        if _has_site(model, "station_sensor"):
            self.rangers["station"] = _Ranger(model, "station_sensor", noise, streams[1])
        self.loop: StepLoop | None = None  # made with the host's program (start)
        self.last_pulses = self.outputs.frame(np.zeros(3, dtype=np.int64))
        self.pending: list[tuple[float, int, float]] = []
        self.host: HostProgram | None = None
        self.gripper_log: list[tuple[float, float]] = []  # (t, commanded theta4 deg)
        self.on_step: list[Callable[[float], None]] = []
        self.before_step: list[Callable[[float], None]] = []
        self.on_machine_event: list[Callable[[float, str], None]] = []

    def sense(self, _t: float) -> dict:
        """The host reads its sensors (a `Call`): `readings()`."""
        return self.readings()

    # the readings the host gets: the last completed measurement of each sensor
    def readings(self) -> dict:
        out = {name: r.last_cm for name, r in self.rangers.items()}
        out.setdefault("station", NO_ECHO)
        out["base_horn_deg"] = self.base_horn_deg(self.outputs.joints(self.raw)[0])
        return out

    @property
    def standby_line(self) -> str:
        """The host's line that opens the gripper to standby (the controller's angle with
        neither sensor hearing anything: Big)."""
        return f"M280 P0 S{format_number(round(self.standby_deg, 2))}"

    def base_horn_deg(self, theta1_rad: float) -> float:
        return math.degrees(float(self.kin.mounts[0].horn(theta1_rad)))

    def start(self, program: Generator) -> None:
        """The host's program over the bus and the loop that steps it with the physics
        (`twin.loop.StepLoop`): the servo board's commands and frames, the sensors, the
        servos' and the job's hooks before each step, the meter and the job's after it."""
        self.host = HostProgram(program, self.bus)
        loop = self.loop = StepLoop(
            self.model, self.data, self.host, self.bus, self.sgf, self.endstops,
            self.sgf.drain_machine_events,
        )  # fmt: skip
        loop.on_event = self.on_machine_event  # the job's hooks, as it adds them
        loop.on_servo.append(self._servo)
        loop.before_step.append(self._commands)
        loop.after_step.append(self._after)

    @property
    def k(self) -> int:
        """Physics steps taken."""
        return 0 if self.loop is None else self.loop.k

    @property
    def raw(self) -> np.ndarray:
        """The SGF's raw pulse counts at the last step's start."""
        return np.zeros(3, dtype=np.int64) if self.loop is None else self.loop.raw

    @property
    def t(self) -> float:
        return self.k * self.dt

    def _servo(self, t: float, commands: list) -> None:
        self.pending.extend(commands)
        while self.pending and self.pending[0][0] <= t:
            _, index, value = self.pending.pop(0)
            if index == 0:
                self.outputs.set_gripper(value)
                self.gripper_log.append((t, float(value)))

    def _commands(self, _t: float) -> None:
        """The board's 50 Hz frame, the sensors' measurements, the servos' commands, then the
        job's hooks."""
        data, k = self.data, self.loop.k
        if k % self.per_frame == 0:
            self.last_pulses = self.outputs.frame(self.raw)
            self.bank.command(self.last_pulses)
        if k % self.sense_every == 0:
            for ranger in self.rangers.values():
                ranger.measure(data)
        data.ctrl[self.acts] = self.bank.step(self.dt, -data.actuator_force[self.acts])
        for fn in self.before_step:  # the job's (its conveyor's drive)
            fn(_t)

    def _after(self, _t: float) -> None:
        self.motors.record(self.data)
        for fn in self.on_step:
            fn(self.k * self.dt)

    def step(self) -> None:
        self.loop.step()

    def run(self, limit_s: float, settle_s: float = 0.0) -> str | None:
        """Step until the host's program ends (then ``settle_s`` more) or ``limit_s``
        (`StepLoop.run_program`); the host's error or a time-out, None if it ended."""
        timed_out = self.loop.run_program(limit_s, settle_s)
        return timed_out if timed_out is not None else self.host.error

    @property
    def valid(self) -> bool:
        """No MuJoCo warning (a physics result to trust)."""
        return not any(int(w.number) for w in self.data.warning)

    # what the twin measures
    def grip_point_cm(self) -> np.ndarray:
        return world_to_paper(self.data.site_xpos[self.grip_site], self.base, self.yaw) * 100.0

    def joints_rad(self) -> np.ndarray:
        return self.data.qpos[self.joint_adr].copy()

    def gripper_deg(self) -> float:
        """The gripper's opening theta4 (deg): the two fingers' angles added."""
        return math.degrees(float(self.data.qpos[self.finger_adr].sum()))


def _has_site(model, name: str) -> bool:
    return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name) >= 0


def _mm(v_m: float) -> str:
    return format_number(round(v_m * 1e3, 3))


def _g1(p_m, speed_m_s: float) -> str:
    x, y, z = (_mm(v) for v in p_m)
    return f"G1 X{x} Y{y} Z{z} S{_mm(speed_m_s)}"


def _park_point(kin: Serial4Kinematics) -> np.ndarray:
    return kin.point(np.array(kin.park_rad))


def _ms(seconds: float) -> str:
    return format_number(round(seconds * 1e3, 3))


def grasp_items(rig: _Rig, rec, grasp, sense, on_grip=None, phase=None):
    """Host items of one grasp (a generator for ``yield from``): over ``grasp`` (paper
    frame, m) at the hover height, down, both sensors read (``sense``: the host item that
    answers them), the fuzzy controller's angle sent and dwelt on, where the fingers stopped
    noted in ``rec`` (a GripRecord), back up. ``on_grip(t, readings, angle)``: called once
    the record has taken the grip. ``phase(LinePhase)``: the host item that reports a phase
    of the pick cycle done (`twin.pot_job`): the approach, the close."""
    job = rig.sc.serial_arm
    up = np.array([0.0, job.hover_m, 0.0])
    yield _g1(grasp + up, job.travel_speed_m_s)
    yield _g1(grasp, job.approach_speed_m_s)
    yield "M400"
    if phase is not None:
        yield phase(LinePhase.APPROACH)
    yield Wait(2 * SENSE_CYCLE_S)
    readings = yield sense
    angle = rig.flc.control(readings["station"], readings["gripper"], readings["base_horn_deg"])

    def took(t: float) -> None:
        rec.take_grip(readings, angle)
        if on_grip is not None:
            on_grip(t, readings, angle)

    yield Call(took)
    yield f"M280 P0 S{format_number(round(angle, 2))}"
    if phase is not None:
        yield phase(LinePhase.CLOSE)
    yield f"G4 P{_ms(job.grip_settle_s)}"
    yield "M400"
    yield Call(lambda _t: setattr(rec, "gripper_reached_deg", rig.gripper_deg()))
    yield _g1(grasp + up, job.approach_speed_m_s)


def release_items(rig: _Rig, point, phase=None):
    """Host items of one release: over ``point`` at the hover height, down, the gripper
    opened to standby and dwelt on, back up. ``phase(LinePhase)``: as `grasp_items`'s (the
    arrival over the point, when the move down has answered ok: its last step is out, and
    the open); the phases add no line, so the machine runs as without them."""
    job = rig.sc.serial_arm
    up = np.array([0.0, job.hover_m, 0.0])
    yield _g1(point + up, job.travel_speed_m_s)
    yield _g1(point, job.approach_speed_m_s)
    if phase is not None:  # the move's ok came once its last step was out: over the point
        yield phase(LinePhase.TO_DROP)
    yield rig.standby_line
    if phase is not None:
        yield phase(LinePhase.RELEASE)
    yield f"G4 P{_ms(job.release_settle_s)}"
    yield _g1(point + up, job.approach_speed_m_s)


# -- Tables 3-5: the ten targets --------------------------------------------------------
@dataclass
class TargetRow:
    commanded_cm: list[float]
    reached_cm: list[float]
    joints_deg: list[float]
    ik_deg: list[float]
    paper_reached_cm: list[float]

    @property
    def error_cm(self) -> list[float]:
        return [abs(a - b) for a, b in zip(self.reached_cm, self.commanded_cm, strict=True)]

    @property
    def joint_error_deg(self) -> list[float]:
        return [abs(a - b) for a, b in zip(self.joints_deg, self.ik_deg, strict=True)]

    @property
    def joint_error_pct(self) -> list[float | None]:
        return [
            None if abs(ik) < 1e-9 else 100.0 * abs(m - ik) / abs(ik)
            for m, ik in zip(self.joints_deg, self.ik_deg, strict=True)
        ]

    def as_dict(self) -> dict:
        r4 = lambda v: None if v is None else round(float(v), 4)  # noqa: E731
        return {
            "commanded_cm": [r4(v) for v in self.commanded_cm],
            "reached_cm": [r4(v) for v in self.reached_cm],
            "error_cm": [r4(v) for v in self.error_cm],
            "joints_deg": [r4(v) for v in self.joints_deg],
            "ik_deg": [r4(v) for v in self.ik_deg],
            "joint_error_deg": [r4(v) for v in self.joint_error_deg],
            "joint_error_pct": [r4(v) for v in self.joint_error_pct],
            "paper_reached_cm": list(self.paper_reached_cm),
        }


def require_own_motion(sc, job: str) -> None:
    """A serial job runs the serial arm with its fuzzy gripper (another `[robot]` or
    `[effector] kind` is refused, naming it). The arm's controller takes its motion from
    `[serial_arm]` (speeds, path acceleration, grid, IK time); `[motion]` is the five-bar's
    and the delta's. A `--set motion.*` given for a serial job is refused (ScenarioError
    naming the keys and the ones to use), never ignored; so is a `[motion]` section in the
    scenario's own file."""
    from transplanter.scenario.assemble import require_kinds
    from transplanter.scenario.schema import ScenarioError, file_keys

    require_kinds(
        sc,
        job,
        "serial4",
        "fuzzy_gripper",
        "the arm's host drives the fuzzy gripper from its two ultrasonic sensors, attached at "
        "the forearm's tool_mount",
    )
    given = [k for k, _ in sc.overrides if k.split(".", 1)[0] == "motion"]
    given += [f"motion.{k}" for k in file_keys(sc, "motion") if f"motion.{k}" not in given]
    if given:
        raise ScenarioError(
            f"{', '.join(given)}: {job} does not read [motion] (the five-bar's and the "
            "delta's controllers do); its motion is [serial_arm] travel_speed_mm_s, "
            "approach_speed_mm_s, path_accel_mm_s2, segment_mm, point_time_us: remove the "
            "[motion] section from the scenario file and set those instead"
        )


def run_targets(sc, seed: int | None = None) -> tuple[list[TargetRow], str | None, bool]:
    """The paper's ten targets on the arm alone (no workcell): G28 to the standby pose, then
    for each target a G1 there, M400, the settle dwell, the grip centre and joints measured,
    back to standby."""
    require_awake(sc, "the serial arm's targets")
    require_own_motion(sc, "the serial arm's targets")
    seed = sc.seed if seed is None else seed
    job = sc.serial_arm
    spec, cfg = _scene(sc, None, seed=seed)
    model, data = _compile(spec, cfg)
    rig = _Rig(sc, model, data, seed, cfg=cfg)
    rows: list[TargetRow] = []
    park = _park_point(rig.kin)

    def measure(i: int):
        def fn(_t: float) -> None:
            commanded, paper = PAPER_TARGETS[i]
            ik = rig.kin.joints(np.array(commanded, dtype=np.float64) / 100.0)
            rows.append(
                TargetRow(
                    commanded_cm=[float(v) for v in commanded],
                    reached_cm=[float(v) for v in rig.grip_point_cm()],
                    joints_deg=[math.degrees(v) for v in rig.joints_rad()],
                    ik_deg=[math.degrees(float(v)) for v in ik],
                    paper_reached_cm=[float(v) for v in paper],
                )
            )

        return fn

    def program():
        yield "G28"
        yield "G90"
        for i, (target, _) in enumerate(PAPER_TARGETS):
            yield _g1(np.array(target, dtype=np.float64) / 100.0, job.target_speed_m_s)
            yield "M400"
            yield Wait(job.target_settle_s)
            yield Call(measure(i))
            yield _g1(park, job.target_speed_m_s)
        yield "M400"

    rig.start(program())
    error = rig.run(limit_s=60.0 + 10.0 * len(PAPER_TARGETS) * (1 + job.target_settle_s))
    return rows, error, rig.valid


# -- Table 6: the 18 gripper trials -----------------------------------------------------
BASE_HORN_CORES_DEG = {"small": (0.0, 30.0), "medium": (60.0, 120.0), "any": (0.0, 180.0)}
"""Where the bench turns the base for a trial (the base servo's horn angle): row 4 needs a
Small base angle (rule 4), rows 5-6 a Medium one (rules 5-6); every other row gives its term
whatever the base angle (its three rules agree)."""
ARC_STEP_DEG = 20.0
"""The bench turns the base in lines of at most this much of the circle (at the bench's 80 mm
radius a 20 deg chord passes 1.2 mm inside the circle)."""
SENSOR2_MARGIN_CM = 1.0
"""The stand-in tomato is set this far inside the row's range (the reading's noise, 3 mm sd,
may still carry it across: 1 cm is 3.3 sd)."""


@dataclass
class GripperCase:
    row: int
    sensor1_detected: bool
    sensor1_cm: float | None
    sensor2_set_cm: float
    sensor2_cm: float | None
    base_deg: float
    angle_deg: float
    term: str | None
    expected_term: str
    gripper_deg: float

    @property
    def in_range(self) -> bool:
        lo, hi = OUTPUT_RANGES_DEG[self.expected_term]
        return lo <= self.angle_deg <= hi

    def as_dict(self) -> dict:
        r = lambda v: None if v is None else round(float(v), 3)  # noqa: E731
        return {
            "row": self.row,
            "sensor1_detected": self.sensor1_detected,
            "sensor1_cm": r(self.sensor1_cm),
            "sensor2_set_cm": r(self.sensor2_set_cm),
            "sensor2_cm": r(self.sensor2_cm),
            "base_deg": r(self.base_deg),
            "angle_deg": r(self.angle_deg),
            "term": self.term,
            "expected_term": self.expected_term,
            "in_range": self.in_range,
            "gripper_deg": r(self.gripper_deg),
        }


def _finite_cm(v: float) -> float | None:
    return None if v == NO_ECHO else float(v)


def _reading(cm: float | None) -> str:
    return "no echo" if cm is None else f"{cm:.1f} cm"


def run_gripper_cases(sc, seed: int | None = None) -> tuple[list[GripperCase], str | None, bool]:
    """Table 6 on a bench: the pool_to_belt workcell with its lane empty, a stand-in tomato
    that the bench sets at the pool's station or takes away (sensor 1) and another on a stand
    in front of the gripper's sensor at a drawn distance in the row's range (sensor 2); the
    arm turned to the row's base angle with the gripper at the bench height. The host reads
    both sensors, runs the controller and sends its angle; the gripper's reached angle is
    measured after the grip dwell."""
    require_awake(sc, "the serial arm's gripper bench")
    require_own_motion(sc, "the serial arm's gripper bench")
    from transplanter.scene.workcells import pool_to_belt

    seed = sc.seed if seed is None else seed
    job = sc.serial_arm
    spec, cfg = _scene(sc, "pool_to_belt", tomatoes=0, seed=seed)
    diameter = cfg.workcell.nominal_diameter_m
    stands = {}
    for name in ("station_stand_in", "sensor2_stand_in"):
        body = spec.worldbody.add_body(name=name, mocap=True, pos=[CASE_STAND_AWAY_M, 0, 0])
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            size=[diameter / 2, 0, 0],
            contype=0,
            conaffinity=0,
            rgba=[0.85, 0.15, 0.1, 1],
        )
        stands[name] = body
    model, data = _compile(spec, cfg)
    mocap = {n: int(model.body_mocapid[model.body(n).id]) for n in stands}
    rig = _Rig(sc, model, data, seed)
    rng = np.random.default_rng([seed, 6006])
    station = np.asarray(pool_to_belt.station_xyz(cfg.workcell, diameter), dtype=np.float64)
    cases: list[GripperCase] = []
    plan = []
    for trial in TABLE6:
        core = "small" if trial.row == 4 else "medium" if trial.row in (5, 6) else "any"
        lo, hi = BASE_HORN_CORES_DEG[core]
        horn = float(rng.uniform(lo, hi))
        s_lo, s_hi = trial.sensor2_cm
        s_lo = max(s_lo, rig.rangers["gripper"].sensor.min_range_m * 100.0)
        d2 = float(rng.uniform(s_lo + SENSOR2_MARGIN_CM, s_hi - SENSOR2_MARGIN_CM))
        plan.append((trial, horn, d2))

    def pose_point(horn_deg: float) -> np.ndarray:
        theta1 = float(rig.kin.mounts[0].joint(math.radians(horn_deg)))
        r, h = job.bench_radius_m, job.bench_height_m
        return np.array([r * math.cos(theta1), h, r * math.sin(theta1)])

    def set_bench(i: int):
        def fn(_t: float) -> None:
            trial, _, d2 = plan[i]
            site = model.site("gripper_sensor").id
            axis = data.site_xmat[site].reshape(3, 3)[:, 2]
            centre = data.site_xpos[site] + axis * (d2 / 100.0 + diameter / 2)
            data.mocap_pos[mocap["sensor2_stand_in"]] = centre
            data.mocap_pos[mocap["station_stand_in"]] = (
                station if trial.sensor1_detected else [CASE_STAND_AWAY_M, 0, 0]
            )
            mujoco.mj_forward(model, data)

        return fn

    def record(i: int, readings: dict, angle: float):
        def fn(_t: float) -> None:
            trial, horn, d2 = plan[i]
            cases.append(
                GripperCase(
                    row=trial.row,
                    sensor1_detected=trial.sensor1_detected,
                    sensor1_cm=_finite_cm(readings["station"]),
                    sensor2_set_cm=d2,
                    sensor2_cm=_finite_cm(readings["gripper"]),
                    base_deg=readings["base_horn_deg"],
                    angle_deg=angle,
                    term=FuzzyGripper.term_of(angle),
                    expected_term=trial.term,
                    gripper_deg=rig.gripper_deg(),
                )
            )

        return fn

    def program():
        yield "G28"
        yield "G90"
        here = rig.base_horn_deg(rig.q0[0])
        for i, (_, horn, _) in enumerate(plan):
            yield rig.standby_line
            # round the base along the bench's circle: a straight line between two far
            # base angles would pass over the base axis, where the IK refuses
            steps = max(1, math.ceil(abs(horn - here) / ARC_STEP_DEG))
            for a in np.linspace(here, horn, steps + 1)[1:]:
                yield _g1(pose_point(float(a)), job.travel_speed_m_s)
            here = horn
            yield "M400"
            yield Wait(job.target_settle_s)
            yield Call(set_bench(i))
            yield Wait(3 * SENSE_CYCLE_S)  # two whole measurements of each sensor
            readings = yield Call(rig.sense)
            angle = rig.flc.control(
                readings["station"], readings["gripper"], readings["base_horn_deg"]
            )
            yield f"M280 P0 S{format_number(round(angle, 2))}"
            yield "M400"
            yield Wait(job.grip_settle_s)
            yield Call(record(i, readings, angle))
            yield Call(lambda _t: data.mocap_pos.__setitem__(slice(None), CASE_STAND_AWAY_M))
        yield "M400"

    rig.start(program())
    error = rig.run(limit_s=60.0 + 8.0 * len(plan))
    return cases, error, rig.valid


# -- Fig. 8: pick and place ---------------------------------------------------------------
@dataclass(kw_only=True)
class GripRecord:
    """One object's pick as the host and the physics saw it: when it started and ended, the
    controller's inputs and output at the grasp, where the fingers stopped, the squeeze."""

    outcome: str = "not picked"
    start_s: float | None = None
    end_s: float | None = None
    grip_inputs: dict | None = None
    grip_deg: float | None = None
    grip_term: str | None = None
    gripper_reached_deg: float | None = None
    peak_squeeze_n: float = 0.0

    def take_grip(self, readings: dict, angle: float) -> None:
        """The host's grasp: the sensors it read (station: sensor 1, gripper: sensor 2, in cm;
        no echo: None), the base servo's angle and the controller's angle."""
        self.grip_inputs = {
            "sensor1_cm": _finite_cm(readings["station"]),
            "sensor2_cm": _finite_cm(readings["gripper"]),
            "base_deg": round(readings["base_horn_deg"], 3),
        }
        self.grip_deg, self.grip_term = angle, FuzzyGripper.term_of(angle)

    def grip_dict(self) -> dict:
        r = lambda v: None if v is None else round(float(v), 4)  # noqa: E731
        return {
            "outcome": self.outcome,
            "start_s": r(self.start_s),
            "end_s": r(self.end_s),
            "grip_inputs": self.grip_inputs,
            "grip_deg": r(self.grip_deg),
            "grip_term": self.grip_term,
            "gripper_reached_deg": r(self.gripper_reached_deg),
            "peak_squeeze_n": r(self.peak_squeeze_n),
        }


@dataclass
class PickRecord(GripRecord):
    index: int
    diameter_mm: float
    mass_g: float
    friction: float

    def as_dict(self) -> dict:
        r = lambda v: round(float(v), 4)  # noqa: E731
        return {
            "index": self.index,
            "diameter_mm": r(self.diameter_mm),
            "mass_g": r(self.mass_g),
            "friction": r(self.friction),
            **self.grip_dict(),
        }


class _Squeeze:
    """The pads' normal force on each tomato, every step while the gripper is shut on one
    (the contacts between a pad geom and a tomato's geoms)."""

    def __init__(self, model, tomatoes: dict[str, int]):
        self.model = model
        self.pads = {model.geom(n).id for n in ("finger_left_pad", "finger_right_pad")}
        self.body_of = {int(model.body(n).id): n for n in tomatoes}
        self.peak = dict.fromkeys(tomatoes, 0.0)
        self.now = 0.0
        """One pad's normal force on the tomato in the gripper at the last step (N)."""
        self._f = np.zeros(6)

    def after_step(self, data) -> None:
        total: dict[str, float] = {}
        for i in range(data.ncon):
            c = data.contact[i]
            g1, g2 = int(c.geom1), int(c.geom2)
            if g1 in self.pads:
                other = g2
            elif g2 in self.pads:
                other = g1
            else:
                continue
            name = self.body_of.get(int(self.model.geom_bodyid[other]))
            if name is None:
                continue
            mujoco.mj_contactForce(self.model, data, i, self._f)
            total[name] = total.get(name, 0.0) + abs(float(self._f[0]))
        self.now = 0.0
        for name, f in total.items():
            # one pad's normal force: the two pads squeeze the tomato between them
            self.now = max(self.now, f / 2)
            if f / 2 > self.peak[name]:
                self.peak[name] = f / 2


def run_pick_place(
    sc, seed: int | None = None, recording=None, progress=None
) -> tuple[list[PickRecord], dict, str | None, bool]:
    """The pool_to_belt job: every tomato of the pool picked at the station and released
    over the belt (module docstring). Returns the records, the job's totals, the host's
    error (None when the program ended) and whether the physics stayed valid.
    ``recording``: an observer, `viewing.serial_arm.SerialRecording` or `SerialVideo` (it only
    reads the state; it is told the tomato in progress, the controller's output and the
    squeeze). ``progress(done, sim_t)``: called once a simulated second with the tomatoes
    whose pick has ended."""
    require_awake(sc, "the serial arm's pick and place")
    require_own_motion(sc, "the serial arm's pick and place")
    from transplanter.scene.workcells import pool_to_belt

    seed = sc.seed if seed is None else seed
    job = sc.serial_arm
    spec, cfg = _scene(sc, "pool_to_belt", seed=seed)
    wc = cfg.workcell
    drawn = pool_to_belt.draw_tomatoes(wc, seed)
    model, data = _compile(spec, cfg)
    rig = _Rig(sc, model, data, seed, cfg=cfg)
    names = [f"tomato{i:02d}" for i in range(len(drawn))]
    records = [
        PickRecord(i, t.diameter_m * 1e3, t.mass_kg * 1e3, t.friction) for i, t in enumerate(drawn)
    ]
    body_ids = {n: model.body(n).id for n in names}
    squeeze = _Squeeze(model, body_ids)
    holding: list[int] = []  # the record being picked (squeeze counted while shut on it)

    def watch(t: float) -> None:
        if holding:
            squeeze.after_step(data)
        if recording is not None:
            recording.squeeze_n = squeeze.now
            recording.look(t)

    rig.on_step.append(watch)
    if progress is not None:
        every = max(1, round(1.0 / rig.dt))

        def report(t: float) -> None:
            if rig.k % every == 0:
                progress(sum(r.end_s is not None for r in records), t)

        rig.on_step.append(report)
    if recording is not None:
        recording.attach(rig)
    pool_to_belt.start_belt(data)
    # the host knows the layout, not each tomato: it grips at a middle tomato's centre and
    # releases a middle tomato's height over the belt
    grasp = world_to_paper(pool_to_belt.station_xyz(wc))
    release = world_to_paper(pool_to_belt.place_xyz(wc))
    park = _park_point(rig.kin)

    def mark(i: int, key: str):
        def fn(t: float) -> None:
            setattr(records[i], key, t)
            if key == "start_s":
                holding[:] = [i]
                if recording is not None:
                    recording.tomato = i

        return fn

    def controller_event(i: int):
        def fn(t: float, readings: dict, angle: float) -> None:
            if recording is None:
                return
            recording.fuzzy_deg = angle
            g = records[i].grip_inputs
            s1, s2 = (_reading(g[k]) for k in ("sensor1_cm", "sensor2_cm"))
            text = (
                f"tomato {i}: sensor 1 {s1}, sensor 2 {s2}, base {g['base_deg']:.1f} deg "
                f"-> gripper {angle:.2f} deg ({records[i].grip_term})"
            )
            recording.event(t, "controller", text)

        return fn

    def program():
        yield "G28"
        yield "G90"
        yield rig.standby_line
        for i in range(len(drawn)):
            yield "M400"
            yield Wait(2 * SENSE_CYCLE_S)
            readings = yield Call(rig.sense)
            if readings["station"] == NO_ECHO:  # the pool is empty: standby
                break
            yield Call(mark(i, "start_s"))
            yield from grasp_items(rig, records[i], grasp, Call(rig.sense), controller_event(i))
            yield from release_items(rig, release)
            yield _g1(park, job.travel_speed_m_s)
            yield "M400"
            yield Call(mark(i, "end_s"))
        yield "M400"

    rig.start(program())
    error = rig.run(limit_s=60.0 + 20.0 * len(drawn), settle_s=2.0)
    judge = PoolToBeltJudge(model, wc, job.bruise_force_n)
    for rec, name in zip(records, names, strict=True):
        rec.peak_squeeze_n = squeeze.peak[name]
        if rec.start_s is not None:
            rec.outcome = judge.outcome(data, name, rec.peak_squeeze_n)
    if recording is not None:
        for rec in records:
            if rec.start_s is not None:
                kind = "tomato" if rec.outcome == "success" else "failure"
                recording.event(rig.t, kind, f"tomato {rec.index}: {rec.outcome}")
        recording.finish(rig.t)
    totals = _pick_totals(records)
    totals["belt_travel_mm"] = round(float(pool_to_belt.belt_travel_m(data)) * 1e3, 3)
    totals["motors"] = rig.motors.report().to_dict()
    return records, totals, error, rig.valid


class PoolToBeltJudge:
    """The pool_to_belt job's judge (the workcell's ``JUDGE``): where a picked tomato came to
    rest, and whether the pads squeezed it past the bruise threshold."""

    def __init__(self, model, wc, bruise_force_n: float) -> None:
        self.model, self.wc, self.bruise_force_n = model, wc, float(bruise_force_n)

    def in_pool(self, xyz) -> bool:
        """A point over the pool's lane (the station and the queue behind it)."""
        from transplanter.scene.workcells import pool_to_belt

        wc = self.wc
        station = np.asarray(pool_to_belt.station_xyz(wc), dtype=np.float64)
        x, y, z = (float(v) for v in xyz)
        return (
            abs(y - station[1]) <= wc.lane_half_width_m
            and station[0] - wc.diameter_max_m <= x <= station[0] + wc.lane_length_m
            and z <= station[2] + wc.diameter_max_m
        )

    def outcome(self, data, name: str, peak_squeeze_n: float) -> str:
        """success, bruised (on the belt, squeezed too hard), missed (still in the pool) or
        dropped (anywhere else)."""
        from transplanter.scene.workcells import pool_to_belt

        if pool_to_belt.on_belt(self.model, data, self.wc, name):
            return "bruised" if peak_squeeze_n > self.bruise_force_n else "success"
        if self.in_pool(data.xpos[self.model.body(name).id]):
            return "missed"
        return "dropped"


def _pick_totals(records: Iterable[PickRecord]) -> dict:
    recs = [r for r in records if r.start_s is not None]
    kinds: dict[str, int] = {}
    for r in recs:
        kinds[r.outcome] = kinds.get(r.outcome, 0) + 1
    starts = [r.start_s for r in recs]
    cycles = np.diff(starts) if len(starts) > 1 else np.array([])
    done = [r for r in recs if r.end_s is not None]
    if not cycles.size and done:
        cycles = np.array([done[0].end_s - done[0].start_s])
    ok = kinds.get("success", 0)
    mean_cycle = float(cycles.mean()) if cycles.size else math.nan
    return {
        "picked": len(recs),
        "successes": ok,
        "success_rate": ok / len(recs) if recs else math.nan,
        "outcomes": dict(sorted(kinds.items())),
        "cycle_time_s": round(mean_cycle, 4),
        "tomatoes_per_hour": round(3600.0 / mean_cycle, 1) if cycles.size else math.nan,
        "peak_squeeze_n": round(max((r.peak_squeeze_n for r in recs), default=0.0), 4),
    }


# -- the whole trial ----------------------------------------------------------------------
@dataclass
class SerialArmResult:
    scenario: str
    seed: int
    targets: list[TargetRow] = field(default_factory=list)
    gripper_cases: list[GripperCase] = field(default_factory=list)
    picks: list[PickRecord] = field(default_factory=list)
    pick_totals: dict = field(default_factory=dict)
    errors: dict = field(default_factory=dict)
    wall_s: float = 0.0
    valid: bool = True
    """No MuJoCo warning in any of the jobs."""
    recording_error: str | None = None

    @property
    def successes(self) -> int:
        """Tomatoes placed on the belt."""
        return int(self.pick_totals.get("successes", 0))

    @property
    def seedlings(self) -> int:
        """Tomatoes picked (the job's units: `trial --seeds` pools successes over these)."""
        return int(self.pick_totals.get("picked", 0))

    @property
    def fault(self) -> str | None:
        """The first job's error (a refused line, a time-out), None if all ended."""
        return next(iter(self.errors.values()), None)

    @property
    def mean_error_cm(self) -> list[float]:
        if not self.targets:
            return [math.nan] * 3
        return [float(np.mean([r.error_cm[a] for r in self.targets])) for a in range(3)]

    @property
    def mean_joint_error_pct(self) -> list[float | None]:
        out = []
        for j in range(3):
            values = [r.joint_error_pct[j] for r in self.targets]
            values = [v for v in values if v is not None]
            out.append(float(np.mean(values)) if values else None)
        return out

    @property
    def cases_in_range(self) -> int:
        return sum(c.in_range for c in self.gripper_cases)

    def to_dict(self) -> dict[str, Any]:
        r4 = lambda v: None if v is None else round(float(v), 4)  # noqa: E731
        return {
            "scenario": self.scenario,
            "seed": self.seed,
            "targets": [r.as_dict() for r in self.targets],
            "mean_error_cm": [r4(v) for v in self.mean_error_cm],
            "paper_mean_error_cm": list(PAPER_MEAN_ERRORS_CM),
            "mean_joint_error_pct": [r4(v) for v in self.mean_joint_error_pct],
            "paper_mean_joint_error_pct": list(PAPER_MEAN_JOINT_ERRORS_PCT),
            "gripper_cases": [c.as_dict() for c in self.gripper_cases],
            "gripper_cases_in_range": self.cases_in_range,
            "pick_place": {**self.pick_totals, "tomatoes": [p.as_dict() for p in self.picks]},
            "errors": self.errors,
            "valid": self.valid,
            "definitions": DEFINITIONS,
            "wall_time_s": round(self.wall_s, 3),
        }


def run_serial_arm(
    sc, seed: int | None = None, jobs=("targets", "gripper", "pick"), recording=None,
    progress=None,
):  # fmt: skip
    """The serial arm's trial: the jobs named (all three by default), each in its scene;
    ``recording`` (`viewing.serial_arm.SerialRecording`) films the pick and place;
    ``progress(done, sim_t)`` follows its tomatoes."""
    wall0 = time.perf_counter()
    seed = sc.seed if seed is None else seed
    result = SerialArmResult(sc.meta.name, seed)
    valid = []
    if "targets" in jobs:
        result.targets, err, ok = run_targets(sc, seed)
        valid.append(ok)
        if err:
            result.errors["targets"] = err
    if "gripper" in jobs:
        result.gripper_cases, err, ok = run_gripper_cases(sc, seed)
        valid.append(ok)
        if err:
            result.errors["gripper_cases"] = err
    if "pick" in jobs:
        result.picks, result.pick_totals, err, ok = run_pick_place(sc, seed, recording, progress)
        if recording is not None:
            result.recording_error = recording.error
        valid.append(ok)
        if err:
            result.errors["pick_place"] = err
    result.valid = all(valid)
    result.wall_s = time.perf_counter() - wall0
    return result
