"""The Cartesian gantry's part of the scene (models/gantry/): a portal of two X rails, a Y beam
(the `bridge`, on the X slide), a carriage on the beam (the Y slide) and a ram (the Z slide)
whose frame `tool_mount` carries the effector: the parallel jaws of
models/effectors/parallel_jaw/, their column down to the grip centre, as on the five-bar.

Each slide's joint is the grip centre's coordinate in the workcell's frame (m), so its qpos is
the machine's X, Y or Z (`machine.kinematics.gantry`). Each axis is a stepper on a general
actuator through its transmission's gear (2 pi / lead: rad of motor per m of slide; a belt's
"lead" is its travel per motor revolution), the torque law and the rotor's inertia as the
five-bar's Z slide has them (`transplanter.scene.stepper`); the X and Y guides' friction, the
lead screw's on Z from the weight it lifts. The portal's links are drawn only (they meet
nothing); the effector's geoms do the touching.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco

from transplanter.scene.config import SceneConfig
from transplanter.scene.robots.fivebar import screw_friction_n
from transplanter.scene.stepper import drive_joint

__all__ = [
    "ACTUATORS",
    "GantryParams",
    "MODEL",
    "MOTORS",
    "MOUNT",
    "ROOT",
    "SWITCH_MOTORS",
    "apply",
    "apply_inertials",
    "home_ctrl",
    "home_joints",
    "power_on",
    "scene_fields",
]

MODEL = "gantry"
"""The robot's Menagerie folder: models/gantry/gantry.xml."""
MOUNT = "tool_mount"
"""The frame under the ram where an effector attaches (the jaws' wrist servo)."""
ROOT = "bridge"
"""The robot's moving root body (what the twin counts as the machine in a contact)."""
MOTORS = ("x", "y", "z")
"""The slides' joints, each driven by the actuator of the same name (motor order)."""
ACTUATORS = MOTORS
"""The robot's drives (the kinds' interface: first in the model, the effector's next)."""
SWITCH_MOTORS = (0, 1, 2, 2)
"""The motor whose joint each of limit switches 1-4 watches: X home, Y home, Z up, Z down."""
HARD_STOP_M = 0.005
"""Each slide's hard stop, this far beyond its travel (the switches trip at the travel's ends)."""
RAIL_CLEARANCE_M = 0.05
"""The X rails sit this far outside the Y travel; the posts this far outside the X travel."""
FLOOR_Z_M = -0.16
"""The posts stand on the floor of the workcells (160 mm below the belt's top)."""


@dataclass(frozen=True)
class GantryParams:
    """The gantry's numbers the scene needs ([gantry] and the power-on pose), SI."""

    x_window_m: tuple[float, float] = (-0.150, 0.150)
    y_window_m: tuple[float, float] = (0.040, 0.300)
    z_window_m: tuple[float, float] = (0.005, 0.160)
    belt_lead_m: float = 0.040
    bridge_mass_kg: float = 1.2
    carriage_mass_kg: float = 0.6
    ram_mass_kg: float = 0.25
    guide_friction_n: float = 3.0
    beam_height_m: float = 0.400
    power_on_m: tuple[float, float, float] = (-0.140, 0.050, 0.150)
    """Where the slides are at power-on: 10 mm short of their switches (X and Y low, Z up)."""

    def __post_init__(self) -> None:
        for name, (lo, hi), q in zip(
            "xyz", (self.x_window_m, self.y_window_m, self.z_window_m), self.power_on_m,
            strict=True,
        ):  # fmt: skip
            if not lo < hi:
                raise ValueError(f"the gantry's {name} travel must have min < max")
            if not lo - HARD_STOP_M <= q <= hi + HARD_STOP_M:
                raise ValueError(f"the gantry's power-on {name} = {q} m is outside its travel")
        if self.z_window_m[0] < 0:
            raise ValueError("the gantry's Z travel must lie above the belt (z_min >= 0)")


def params(cfg: SceneConfig) -> GantryParams:
    p = cfg.robot_params
    if not isinstance(p, GantryParams):
        raise ValueError("a gantry scene needs SceneConfig.robot_params = GantryParams(...)")
    return p


def scene_fields(scenario, machine) -> dict:
    """The SceneConfig fields of a scenario's gantry: its travel and belt as the firmware's
    kinematics holds them (`machine.kinematics`), its [gantry] masses, guides and portal, and
    its power-on pose (the SGF's: `machine.config.power_on_joints`)."""
    from transplanter.machine.config import power_on_joints

    g, kin = scenario.gantry, machine.kinematics
    return {
        "robot_params": GantryParams(
            x_window_m=kin.x_window_m,
            y_window_m=kin.y_window_m,
            z_window_m=kin.z_window_m,
            belt_lead_m=kin.drives_xyz[0].lead_m,
            bridge_mass_kg=g.bridge_mass_kg,
            carriage_mass_kg=g.carriage_mass_kg,
            ram_mass_kg=g.ram_mass_kg,
            guide_friction_n=g.guide_friction_n,
            beam_height_m=g.beam_height_m,
            power_on_m=tuple(power_on_joints(machine.sgf)),
        )
    }


def gears(cfg: SceneConfig) -> tuple[float, float, float]:
    """Motor rad per m of each slide: 2 pi over the belt's or the screw's lead."""
    p = params(cfg)
    return (2 * math.pi / p.belt_lead_m, 2 * math.pi / p.belt_lead_m, cfg.screw_gear_rad_m)


def apply(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """The portal's size, the slides' travel and masses, the steppers, the switches."""
    p = params(cfg)
    (x0, x1), (y0, y1), (z0, z1) = p.x_window_m, p.y_window_m, p.z_window_m
    h = p.beam_height_m
    yr0, yr1 = y0 - RAIL_CLEARANCE_M, y1 + RAIL_CLEARANCE_M
    xp0, xp1 = x0 - RAIL_CLEARANCE_M, x1 + RAIL_CLEARANCE_M
    x_half = 0.5 * (xp1 - xp0)
    for rail, y in (("rail_front", yr0), ("rail_back", yr1)):
        spec.geom(rail).pos = [0.5 * (xp0 + xp1), y, h]
        spec.geom(rail).size = [x_half, 0.010, 0.020]
    post_half = 0.5 * (h - FLOOR_Z_M)
    corners = ((xp0, yr0), (xp1, yr0), (xp0, yr1), (xp1, yr1))
    for post, (x, y) in zip(("post_1", "post_2", "post_3", "post_4"), corners, strict=True):
        spec.geom(post).pos = [x, y, FLOOR_Z_M + post_half]
        spec.geom(post).size = [0.010, 0.010, post_half]
    beam = spec.geom("beam")
    beam.pos = [0, 0.5 * (yr0 + yr1), h + 0.030]
    beam.size = [0.020, 0.5 * (yr1 - yr0), 0.010]
    beam.mass = p.bridge_mass_kg
    spec.geom("x_motor").pos = [0, yr0 - 0.030, h + 0.030]
    plate = spec.geom("carriage_plate")
    plate.pos = [0, 0, h + 0.005]
    plate.mass = p.carriage_mass_kg
    spec.geom("z_motor").pos = [0, -0.040, h + 0.060]
    # the ram: from the mount (column_height_m above the grip centre) up past the carriage
    ram = spec.geom("ram")
    ram_bottom = cfg.column_height_m
    ram_top = h + 0.080 - z0
    ram.pos = [0, -0.025, 0.5 * (ram_bottom + ram_top)]
    ram.size = [0.015, 0.010, 0.5 * (ram_top - ram_bottom)]
    ram.mass = p.ram_mass_kg
    spec.frame(MOUNT).pos = [0, 0, cfg.column_height_m]
    travel = (
        (x0 - HARD_STOP_M, x1 + HARD_STOP_M),
        (y0 - HARD_STOP_M, y1 + HARD_STOP_M),
        (0.0, z1 + HARD_STOP_M),
    )
    for joint_name, gear, window, motor in zip(
        MOTORS, gears(cfg), travel, cfg.stepper_params(), strict=True
    ):
        drive_joint(spec, joint_name, gear, window, motor, cfg.rotor_inertia_kgm2)
    for joint_name in ("x", "y"):
        spec.joint(joint_name).frictionloss = p.guide_friction_n
    spec.numeric("limit_switch_trip").data = [x0, y0, z1, z0]


def apply_inertials(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """The lead screw's friction on the Z slide, from the weight it carries (the ram and the
    effector); the bodies' inertias are MuJoCo's from their geoms."""
    model = spec.copy().compile()
    weight = model.body_subtreemass[model.body("ram").id] * -model.opt.gravity[2]
    spec.joint("z").frictionloss = screw_friction_n(weight, cfg.screw_efficiency)


def power_on(cfg: SceneConfig) -> list[float]:
    """The slides' positions at power-on (m), in motor order."""
    return list(params(cfg).power_on_m)


def home_joints(cfg: SceneConfig) -> dict[str, float]:
    """The power-on pose of the slides."""
    return dict(zip(MOTORS, power_on(cfg), strict=True))


def home_ctrl(cfg: SceneConfig) -> list[float]:
    """The motors' commands at power-on: no torque until the twin's drives compute it."""
    return [0.0, 0.0, 0.0]
