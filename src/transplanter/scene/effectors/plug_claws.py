"""The plug-in claws of seed 002 (Zhao, Cheng, Dong, Ma, Xiong and Tong, *Research on the End
Effector and Optimal Motion Control Strategy for a Plug Seedling Transplanting Parallel
Robot*, Agriculture 2022, Sec. 2.2, Fig. 4-5) as an effector kind: a rotary cylinder that turns
the unit 0 or 90 deg, a double-acting cylinder that drives two claws on slides inclined from
vertical into the substrate from opposite sides, and the seedling stopper (stripper) that the
retracting claws pass through, so that the plug is pushed off them.

The bodies are drawn in models/effectors/plug_claws/plug_claws.xml; `apply` sets their numbers
from a `PlugClawsConfig` (the `[plug_claws]` keys). The cylinder is a velocity actuator per
claw: its control is the flow-limited stroke speed (a meter-out throttle: stroke / stroke
time), its force is capped at pressure x piston area (the rod side on the return), shared by
the claws. `ClawCycle` is the valve sequence of one pick (rotate, extend, retract) with its
timings, pure Python: the job (a robot's lift and move in between) asks it for the controls.

Nothing here glues a plug to a claw: the plug is held by contact only (the plug's pin socket,
transplanter.scene.plug_bench, docs/plug_claws.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from transplanter.errors import TransplanterError

__all__ = [
    "ACTUATORS",
    "CLAWS",
    "STRIPPERS",
    "ClawCycle",
    "ClawsNotInScene",
    "PlugClawsConfig",
    "add_canopy_contact",
    "apply",
    "claws_config",
    "home_ctrl",
    "home_joints",
]

CLAWS = ("claw_left", "claw_right")
STRIPPERS = ("stripper_left", "stripper_right", "stripper_bridge")
ACTUATORS = ("rotary", "cylinder_left", "cylinder_right")
BIT_PIN = 4  # the claws' contype: the plugs' pin sockets have it in their conaffinity
BIT_CANOPY = 8  # leaves (as transplanter.scene.config.BIT_CANOPY)
BIT_STRIPPER = 16  # the stopper's contype: the plugs' outer shape has it in its conaffinity


@dataclass(frozen=True)
class PlugClawsConfig:
    """The `[plug_claws]` keys (file units in the names). The paper gives none of these numbers
    (docs/plug_claws.md: each is an estimate, with what it rests on)."""

    insertion_angle_deg: float = 12.0
    """Each claw's slide from vertical (the claws converge downwards)."""
    insertion_depth_mm: float = 32.0
    """Depth of the claws' tips below the substrate surface at full stroke."""
    tip_offset_mm: float = 7.0
    """Distance of each tip from the cell's centre line at full stroke."""
    tip_recess_mm: float = 3.0
    """How far the retracted tips sit up inside the stripper."""
    stripper_drop_mm: float = 60.0
    """The stripper's underside below the mount."""
    work_gap_mm: float = 2.0
    """The stripper's underside above the tray's top while the claws go in."""
    tray_substrate_below_top_mm: float = 3.0
    """Substrate surface below the tray's top in the trays the stroke is set for."""
    claw_radius_mm: float = 1.0
    """Radius of the claw's collision capsule."""
    pin_interference_mm: float = 1.5
    """How far each claw's surface presses into the plug's core at full stroke (the
    substrate it displaces sideways: the squeeze)."""
    pressure_mpa: float = 0.5
    """Supply pressure (gauge) of the double-acting cylinder."""
    bore_mm: float = 10.0
    """Cylinder bore."""
    rod_mm: float = 4.0
    """Cylinder rod diameter (the return stroke pushes on the annulus)."""
    cylinder_stroke_ms: float = 150.0
    """Time of a full stroke at the throttled (flow-limited) speed."""
    cylinder_kv_n_s_m: float = 20.0
    """Stiffness of the flow limit: force per speed error along the slide."""
    rotary_stroke_ms: float = 250.0
    """Time of the rotary cylinder's 90 deg swing."""
    rotary_torque_nm: float = 0.3
    """Torque of the rotary cylinder at the supply pressure."""
    rotary_kp_nm_rad: float = 2.0
    """Stiffness with which the rotary cylinder follows its swing."""
    settle_ms: float = 30.0
    """Dwell after a stroke ends before the next step (magnetic switch and valve delay)."""
    leaf_damage_force_n: float = 0.5
    """A claw or the stripper pressing a leaf harder than this tears it."""

    @property
    def angle_rad(self) -> float:
        return math.radians(self.insertion_angle_deg)

    @property
    def tip_travel_m(self) -> float:
        """Vertical travel of a tip from retracted to full stroke."""
        mm = (
            self.tip_recess_mm
            + self.work_gap_mm
            + self.tray_substrate_below_top_mm
            + self.insertion_depth_mm
        )
        return mm * 1e-3

    @property
    def stroke_m(self) -> float:
        """The slide's stroke along its inclined axis."""
        return self.tip_travel_m / math.cos(self.angle_rad)

    @property
    def stroke_speed_m_s(self) -> float:
        return self.stroke_m / (self.cylinder_stroke_ms * 1e-3)

    @property
    def extend_force_n(self) -> float:
        """Pressure x bore area: the cylinder's push, shared by the two claws."""
        return self.pressure_mpa * 1e6 * math.pi / 4 * (self.bore_mm * 1e-3) ** 2

    @property
    def retract_force_n(self) -> float:
        """Pressure x (bore - rod) area."""
        area = math.pi / 4 * ((self.bore_mm * 1e-3) ** 2 - (self.rod_mm * 1e-3) ** 2)
        return self.pressure_mpa * 1e6 * area

    def tip_retracted_m(self) -> tuple[float, float]:
        """(x, z) of the right claw's retracted tip in the head's frame (the left mirrors x)."""
        x = self.tip_offset_mm * 1e-3 + self.tip_travel_m * math.tan(self.angle_rad)
        z = -self.stripper_drop_mm * 1e-3 + self.tip_recess_mm * 1e-3
        return x, z

    def stripper_x_m(self) -> float:
        """Where each claw crosses the stripper's underside at full stroke (the blocks'
        centre)."""
        below = self.tip_travel_m - self.tip_recess_mm * 1e-3
        return self.tip_offset_mm * 1e-3 + below * math.tan(self.angle_rad)

    def work_height_m(self) -> float:
        """The mount's height above the tray's top while the claws go in."""
        return (self.stripper_drop_mm + self.work_gap_mm) * 1e-3


class ClawsNotInScene(TransplanterError, ValueError):
    """The scene has no plug claws to set: their model was not merged into it."""


def claws_config(cfg) -> PlugClawsConfig:
    """The claws' config from what a caller holds: a PlugClawsConfig, or a config with a
    `plug_claws` attribute (the scene's config once the delta job carries one); else the
    defaults."""
    if isinstance(cfg, PlugClawsConfig):
        return cfg
    return getattr(cfg, "plug_claws", None) or PlugClawsConfig()


def _quat_y(angle: float) -> list[float]:
    return [math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0]


def apply(spec: mujoco.MjSpec, cfg) -> None:
    """The claws' slides (angle, stroke, where the tips sit), the stripper blocks over the
    claws' exits, the cylinder (stroke speed, pressure x area) and the rotary cylinder."""
    c = claws_config(cfg)
    if spec.body("claws_mount") is None:
        raise ClawsNotInScene(
            "effector.kind plug_claws: the scene has no body 'claws_mount'; the claws' model "
            "(models/effectors/plug_claws/plug_claws.xml) must be merged under the robot's "
            "platform (the delta's job does; the five-bar's scene carries its parallel jaws)"
        )
    x, z = c.tip_retracted_m()
    for name, side in (("claw_left", -1.0), ("claw_right", 1.0)):
        body = spec.body(name)
        body.pos = [side * x, 0.0, z]
        body.quat = _quat_y(side * c.angle_rad)
        spec.joint(name).range = [0.0, c.stroke_m]
        spec.geom(name).size = [c.claw_radius_mm * 1e-3, 0, 0]
    xs = c.stripper_x_m()
    drop = c.stripper_drop_mm * 1e-3
    for name, side in (("stripper_left", -1.0), ("stripper_right", 1.0)):
        g = spec.geom(name)
        g.pos = [side * xs, 0.0, -drop + g.size[2]]
    bridge = spec.geom("stripper_bridge")
    left = spec.geom("stripper_left")
    bridge.size = [xs + left.size[0], bridge.size[1], bridge.size[2]]
    bridge.pos = [0.0, 0.0, -drop + 2 * left.size[2] + bridge.size[2]]
    v = c.stroke_speed_m_s
    for act in ("cylinder_left", "cylinder_right"):
        a = spec.actuator(act)
        a.gainprm = [c.cylinder_kv_n_s_m] + [0] * 9
        a.biasprm = [0, 0, -c.cylinder_kv_n_s_m] + [0] * 7
        a.ctrlrange = [-v, v]
        a.forcerange = [-c.retract_force_n / 2, c.extend_force_n / 2]
    rot = spec.actuator("rotary")
    rot.gainprm = [c.rotary_kp_nm_rad] + [0] * 9
    rot.biasprm = [0, -c.rotary_kp_nm_rad, rot.biasprm[2]] + [0] * 7
    rot.forcerange = [-c.rotary_torque_nm, c.rotary_torque_nm]


def add_canopy_contact(spec: mujoco.MjSpec, cfg) -> None:
    """The claws and the stripper always meet leaves (collision bit 8): their strikes are the
    leaf damage the paper counts."""
    for name in (*CLAWS, *STRIPPERS):
        spec.geom(name).conaffinity |= BIT_CANOPY


def home_joints(cfg) -> dict[str, float]:
    """Rotary cylinder at 0, claws retracted inside the stripper."""
    return {"rotary": 0.0, "claw_left": 0.0, "claw_right": 0.0}


def home_ctrl(cfg) -> list[float]:
    """The valves at power-on: rotary at 0 deg, the cylinder held retracted."""
    v = claws_config(cfg).stroke_speed_m_s
    return [0.0, -v, -v]


class ClawCycle:
    """The valve sequence of one pick: `rotate(t, deg)`, `extend(t)`, `retract(t)` schedule
    the strokes (in any order of calls, now or ahead); `ctrl(t)` gives the actuators'
    controls (rotary target rad, the two claws' throttled speeds); `ready(t)` says the last
    stroke begun by `t` has ended and settled (the robot may lift or leave). The rotary target
    swings at the rotary's rate (90 deg per `rotary_stroke_ms`); the cylinder's valve switches
    at once and the flow limit sets its speed."""

    def __init__(self, cfg: PlugClawsConfig | None = None) -> None:
        self.cfg = cfg or PlugClawsConfig()
        self._swings: list[tuple[float, float, float, float]] = []  # t0, t1, from, to
        self._valves: list[tuple[float, float]] = [(-math.inf, -1.0)]  # t, +1 extend / -1
        self.events: list[tuple[float, str]] = []

    def rotate(self, t: float, deg: float) -> float:
        """Swing the rotary cylinder to `deg` (0 or 90) from `t`; returns when it arrives."""
        if deg not in (0.0, 90.0):
            raise ValueError(f"the rotary cylinder stops at 0 or 90 deg, not {deg}")
        start = self._rotary_at(t)
        to = math.radians(deg)
        t1 = t + abs(to - start) / (math.pi / 2) * self.cfg.rotary_stroke_ms * 1e-3
        self._swings = [s for s in self._swings if s[0] < t] + [(t, t1, start, to)]
        self.events.append((t, f"rotate {deg:g}"))
        return t1

    def _valve(self, t: float, state: float, name: str) -> float:
        self._valves = [v for v in self._valves if v[0] < t] + [(t, state)]
        self.events.append((t, name))
        return t + self.cfg.cylinder_stroke_ms * 1e-3

    def extend(self, t: float) -> float:
        """Open the valve to extend (claws into the substrate) at `t`; returns when the
        stroke ends."""
        return self._valve(t, 1.0, "extend")

    def retract(self, t: float) -> float:
        """Open the valve to retract at `t` (the stripper pushes the plug off); returns when
        the stroke ends."""
        return self._valve(t, -1.0, "retract")

    def _rotary_at(self, t: float) -> float:
        angle = 0.0
        for t0, t1, start, to in self._swings:
            if t < t0:
                break
            if t >= t1:
                angle = to
            else:
                angle = start + (t - t0) / (t1 - t0) * (to - start)
        return angle

    def _valve_at(self, t: float) -> tuple[float, float]:
        current = self._valves[0]
        for v in self._valves:
            if v[0] <= t:
                current = v
        return current

    def ctrl(self, t: float) -> np.ndarray:
        v = self.cfg.stroke_speed_m_s * self._valve_at(t)[1]
        return np.array([self._rotary_at(t), v, v])

    def ready(self, t: float) -> bool:
        """The strokes begun by `t` (rotary and cylinder) have ended and settled."""
        settle = self.cfg.settle_ms * 1e-3
        stroke_end = self._valve_at(t)[0] + self.cfg.cylinder_stroke_ms * 1e-3
        swing_end = max((s[1] for s in self._swings if s[0] <= t), default=-math.inf)
        return t >= max(swing_end, stroke_end) + settle

    def phase(self, t: float) -> str:
        """What the effector is doing: rotating, extending, extended, retracting, retracted."""
        if any(t0 <= t < t1 for t0, t1, _, _ in self._swings):
            return "rotating"
        t0, state = self._valve_at(t)
        moving = t < t0 + self.cfg.cylinder_stroke_ms * 1e-3
        if state > 0:
            return "extending" if moving else "extended"
        return "retracting" if moving else "retracted"
