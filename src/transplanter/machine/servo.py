"""Hobby PWM position servos as they behave (SG90 and MG996R classes), pure numpy.

The command side, as a microcontroller drives one: a pulse every frame (50 Hz, 20 ms), its
width encoding the horn angle (500 us at 0 deg to 2500 us at 180 deg for these classes, in
whole microseconds as the Arduino ``Servo.writeMicroseconds`` timer gives them). The servo
side, as the servo's own electronics answer a pulse: the output shaft slews towards the
commanded angle at its rated speed (0.1 s per 60 deg for an SG90, 0.17 s for an MG996R at
4.8 V), ignores errors inside its deadband (10 us and 5 us of pulse width: about 0.9 and
0.45 deg), slows with load and stops at its stall torque; the horn and the link on it sit
anywhere within the gear backlash of the shaft, on the side the load pushes them to.

Numbers are the manufacturers' datasheet values (TowerPro SG90 and MG996R), estimates where
the datasheets are silent (backlash, the loop stiffness of the MuJoCo actuator):
``docs/serial_arm.md`` lists each with its source. In MuJoCo a servo becomes a position
actuator limited to its stall torque (:meth:`ServoClass.position_gain`); the slewing,
the deadband and the backlash of this module shape the command it tracks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "FRAME_S",
    "MG996R",
    "SERVO_CLASSES",
    "SG90",
    "HobbyServo",
    "ServoClass",
    "ServoMount",
    "servo_class",
    "pulse_frames",
]

FRAME_S = 0.020
"""The PWM frame period of a hobby servo: 50 Hz (both datasheets: "PWM period 20 ms")."""

PULSE_QUANTUM_S = 1e-6
"""The pulse width resolution of the firmware's timer (``Servo.writeMicroseconds``: 1 us)."""


@dataclass(frozen=True)
class ServoClass:
    """The numbers of one kind of hobby servo (SI: s, rad, N m, kg)."""

    name: str
    s_per_60deg: float
    """No-load time to turn 60 deg (datasheet "operating speed")."""
    stall_torque_nm: float
    """Torque at which the output stops (datasheet "stall torque", kgf cm x 0.0981)."""
    deadband_s: float
    """Pulse-width change the servo ignores (datasheet "dead band width")."""
    backlash_rad: float
    """Free play of the output gear train (no datasheet gives it: an estimate)."""
    mass_kg: float
    pulse_min_s: float = 500e-6
    """Pulse width at horn angle 0."""
    pulse_max_s: float = 2500e-6
    """Pulse width at horn angle ``travel_rad``."""
    travel_rad: float = math.pi
    """The horn's travel between the two pulse widths (180 deg)."""
    armature_kgm2: float = 0.0
    """The gear train's reflected rotor inertia at the output (an estimate; the MuJoCo
    joint's ``armature``)."""
    saturation_rad: float = math.radians(3.0)
    """Position error at which the servo's proportional loop reaches stall torque (an
    estimate; sets the MuJoCo actuator's stiffness, :meth:`position_gain`)."""

    def __post_init__(self) -> None:
        for name in ("s_per_60deg", "stall_torque_nm", "mass_kg", "travel_rad", "saturation_rad"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"ServoClass {self.name!r}: {name} must be > 0, got {value!r}")
        for name in ("deadband_s", "backlash_rad"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"ServoClass {self.name!r}: {name} must be >= 0, got {value!r}")
        if not 0 < self.pulse_min_s < self.pulse_max_s < FRAME_S:
            raise ValueError(
                f"ServoClass {self.name!r}: needs 0 < pulse_min_s < pulse_max_s < one frame"
            )

    @property
    def speed_rad_s(self) -> float:
        """No-load slew rate (rad/s): 60 deg / ``s_per_60deg``."""
        return math.radians(60.0) / self.s_per_60deg

    @property
    def s_per_rad(self) -> float:
        """Pulse width per radian of horn angle (s/rad)."""
        return (self.pulse_max_s - self.pulse_min_s) / self.travel_rad

    @property
    def deadband_rad(self) -> float:
        """The deadband as a horn angle (rad)."""
        return self.deadband_s / self.s_per_rad

    @property
    def counts_per_rev(self) -> int:
        """Whole pulse-width quanta (1 us) per horn revolution: what a step counter of this
        servo counts (4000 for 2000 us over 180 deg)."""
        return max(1, round(self.s_per_rad * 2.0 * math.pi / PULSE_QUANTUM_S))

    def pulse_us(self, horn_rad) -> np.ndarray:
        """Pulse width(s) in whole microseconds (int64) for horn angle(s), clipped to the
        travel: what the firmware's timer sends."""
        horn = np.clip(np.asarray(horn_rad, dtype=np.float64), 0.0, self.travel_rad)
        width = self.pulse_min_s + horn * self.s_per_rad
        return np.rint(width / PULSE_QUANTUM_S).astype(np.int64)

    def pulse_width(self, horn_rad) -> np.ndarray:
        """Pulse width(s) in s for horn angle(s): :meth:`pulse_us` in seconds."""
        return self.pulse_us(horn_rad) * PULSE_QUANTUM_S

    def horn_angle(self, pulse_s) -> np.ndarray:
        """Horn angle(s) in rad a pulse width commands (clipped to the pulse range)."""
        width = np.clip(np.asarray(pulse_s, dtype=np.float64), self.pulse_min_s, self.pulse_max_s)
        return (width - self.pulse_min_s) / self.s_per_rad

    def position_gain(self) -> float:
        """Stiffness (N m/rad) of the MuJoCo position actuator standing for this servo: stall
        torque at ``saturation_rad`` of error."""
        return self.stall_torque_nm / self.saturation_rad


KGF_CM = 9.80665e-2
"""N m per kgf cm (the datasheets' torque unit)."""

SG90 = ServoClass(
    name="sg90",
    s_per_60deg=0.10,  # datasheet: 0.1 s/60 deg at 4.8 V
    stall_torque_nm=1.8 * KGF_CM,  # datasheet: 1.8 kgf cm at 4.8 V
    deadband_s=10e-6,  # datasheet: dead band width 10 us
    backlash_rad=math.radians(1.0),  # estimate (plastic gears)
    mass_kg=0.009,  # datasheet: 9 g
    armature_kgm2=0.0002,  # estimate: 0.2 g m^2 reflected rotor inertia
)
"""TowerPro SG90 micro servo (plastic gears): the base and gripper class."""

MG996R = ServoClass(
    name="mg996r",
    s_per_60deg=0.17,  # datasheet: 0.17 s/60 deg at 4.8 V (0.14 s at 6 V)
    stall_torque_nm=9.4 * KGF_CM,  # datasheet: 9.4 kgf cm at 4.8 V (11 kgf cm at 6 V)
    deadband_s=5e-6,  # datasheet: dead band width 5 us
    backlash_rad=math.radians(0.5),  # estimate (metal gears)
    mass_kg=0.055,  # datasheet: 55 g
    armature_kgm2=0.001,  # estimate: 1 g m^2 reflected rotor inertia
)
"""TowerPro MG996R standard servo (metal gears): the shoulder and elbow class."""

SERVO_CLASSES: dict[str, ServoClass] = {c.name: c for c in (SG90, MG996R)}
"""The servo classes by name (a scenario's ``[serial4] *_servo`` keys)."""


def servo_class(name: str) -> ServoClass:
    """The servo class of a name; ValueError naming the known ones otherwise."""
    if name not in SERVO_CLASSES:
        raise ValueError(f"unknown servo class {name!r}; known: {', '.join(SERVO_CLASSES)}")
    return SERVO_CLASSES[name]


@dataclass(frozen=True)
class ServoMount:
    """How a servo's horn angle relates to the joint it drives: joint = ``zero_rad`` +
    ``direction`` x horn. The joint's window is the horn's travel mapped this way."""

    servo: ServoClass
    zero_rad: float
    """The joint angle at horn angle 0 (pulse ``pulse_min_s``)."""
    direction: int = 1

    def __post_init__(self) -> None:
        if self.direction not in (-1, 1):
            raise ValueError(f"ServoMount.direction must be +1 or -1, got {self.direction!r}")
        if not math.isfinite(self.zero_rad):
            raise ValueError("ServoMount.zero_rad must be finite")

    def horn(self, joint_rad) -> np.ndarray:
        """Horn angle(s) of joint angle(s)."""
        return (np.asarray(joint_rad, dtype=np.float64) - self.zero_rad) * self.direction

    def joint(self, horn_rad) -> np.ndarray:
        """Joint angle(s) of horn angle(s)."""
        return self.zero_rad + self.direction * np.asarray(horn_rad, dtype=np.float64)

    @property
    def window(self) -> tuple[float, float]:
        """(min, max) joint angle the horn's travel reaches."""
        a, b = self.zero_rad, float(self.joint(self.servo.travel_rad))
        return (min(a, b), max(a, b))

    def pulse_us(self, joint_rad) -> np.ndarray:
        """The pulse width(s) in whole microseconds (int64) that command joint angle(s)."""
        return self.servo.pulse_us(self.horn(joint_rad))

    def pulse_width(self, joint_rad) -> np.ndarray:
        """The pulse width(s) in s that command joint angle(s)."""
        return self.servo.pulse_width(self.horn(joint_rad))


def pulse_frames(mount: ServoMount, times_s, joints_rad, duration_s: float) -> np.ndarray:
    """The firmware's side: the pulse width (whole us, int64) sent in every 50 Hz frame of
    ``duration_s``, each frame carrying the joint target of the latest command at or before
    the frame's start (sample and hold; ``times_s`` sorted, the first at or before 0)."""
    times = np.asarray(times_s, dtype=np.float64)
    joints = np.asarray(joints_rad, dtype=np.float64)
    if times.ndim != 1 or times.shape != joints.shape or times.size == 0:
        raise ValueError("times_s and joints_rad must be 1-D, non-empty and of equal length")
    if np.any(np.diff(times) < 0) or times[0] > 0:
        raise ValueError("times_s must be sorted and start at or before 0")
    starts = np.arange(int(math.ceil(duration_s / FRAME_S - 1e-9))) * FRAME_S
    index = np.searchsorted(times, starts + 1e-12, side="right") - 1
    return mount.pulse_us(joints[index])


class HobbyServo:
    """One servo's output shaft and the link on it, stepped in time.

    :meth:`command` is a pulse arriving (the target is read once per frame); :meth:`step`
    advances ``dt``: the shaft slews towards the target at the rated speed scaled by
    (1 - |load| / stall torque) when the target lies outside the deadband, and does not move
    while the load opposes it with at least the stall torque. The link (:attr:`link_rad`)
    follows the shaft within the backlash: where a load torque acts it rests against the
    side the load pushes it to; with no load it stays where the shaft last pushed it.
    Angles here are horn angles (rad).
    """

    def __init__(self, servo: ServoClass, horn_rad: float = 0.0):
        self.servo = servo
        self.shaft_rad = float(horn_rad)
        """Where the output shaft (and the servo's potentiometer) is."""
        self.target_rad = float(horn_rad)
        """The horn angle of the last pulse received."""
        self.link_rad = float(horn_rad)
        """Where the horn and the link on it are (within the backlash of the shaft)."""
        self._moving = False
        # the class's constants as `step` uses them (a ServoClass is frozen): the same
        # values it would compute at every step
        self._half_band = 0.5 * servo.deadband_rad
        self._speed = servo.speed_rad_s
        self._stall = servo.stall_torque_nm
        self._half_play = 0.5 * servo.backlash_rad

    def command(self, pulse_s: float) -> None:
        """A pulse of width ``pulse_s`` arrives: its angle becomes the target."""
        self.target_rad = float(self.servo.horn_angle(pulse_s))

    def step(self, dt: float, load_torque_nm: float = 0.0) -> float:
        """Advance ``dt`` seconds under a load torque on the output (N m, positive pushing
        the horn angle up); returns the link angle."""
        error = self.target_rad - self.shaft_rad
        # the deadband: a servo at rest starts only for an error beyond half the band; once
        # moving it drives on until it is at the target
        if self._moving or abs(error) > self._half_band:
            direction = math.copysign(1.0, error)
            opposing = max(0.0, -direction * load_torque_nm)
            factor = max(0.0, 1.0 - opposing / self._stall)
            travel = min(abs(error), self._speed * factor * dt)
            self.shaft_rad += direction * travel
            self._moving = abs(self.target_rad - self.shaft_rad) > 1e-12 and factor > 0.0
        half = self._half_play
        if load_torque_nm > 0.0:
            self.link_rad = self.shaft_rad + half
        elif load_torque_nm < 0.0:
            self.link_rad = self.shaft_rad - half
        else:  # the play operator: the shaft drags the link only at the ends of the play
            self.link_rad = min(max(self.link_rad, self.shaft_rad - half), self.shaft_rad + half)
        return self.link_rad

    def run(self, pulses_s, dt: float, load_torque_nm: float = 0.0) -> np.ndarray:
        """Feed one pulse per frame and step ``dt`` at a time through the frames; the link
        angle after every step (``len(pulses) * FRAME_S / dt`` values)."""
        per_frame = round(FRAME_S / dt)
        if per_frame < 1 or not math.isclose(per_frame * dt, FRAME_S, rel_tol=1e-9):
            raise ValueError(f"dt must divide the {FRAME_S * 1e3:g} ms frame, got {dt}")
        out = []
        for pulse in np.asarray(pulses_s, dtype=np.float64):
            self.command(float(pulse))
            for _ in range(per_frame):
                out.append(self.step(dt, load_torque_nm))
        return np.array(out)
