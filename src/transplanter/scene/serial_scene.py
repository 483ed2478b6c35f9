"""The serial arm's scene (seed 004: Dewi, Nurmaini, Risma, Oktarina and Roriz, *Inverse
kinematic analysis of 4 DOF pick and place arm robot manipulator using fuzzy logic
controller*, IJECE 10(2), 2020): the serial 4-DOF servo arm (models/serial4, robot kind
'serial4') with the fuzzy gripper (models/effectors/fuzzy_gripper, effector kind
'fuzzy_gripper') attached at its forearm's `tool_mount` by MjSpec attach, on a floor, and the
workcell of the job where one is named (its module, found through `scene.kinds`, places what
the job needs).

World frame: the arm's base stands on the floor (z = 0) at the origin, z up; the shoulder axis
is `SHOULDER_HEIGHT_M` above the floor. The kinematics (`transplanter.machine.kinematics.
serial4`) works in the paper's frame (origin at the shoulder, x forward, y up, z sideways to
the right): its point (x, y, z) is the world point (x, -z, 0.060 + y) (`paper_to_world`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import mujoco
import numpy as np

from transplanter.machine.servo import servo_class
from transplanter.scene import kinds
from transplanter.scene.delta_scene import models_dir
from transplanter.scene.effectors.fuzzy_gripper import FuzzyGripperConfig

__all__ = [
    "EFFECTOR",
    "ROBOT",
    "CAMERAS",
    "SHOULDER_HEIGHT_M",
    "SerialSceneConfig",
    "add_cameras",
    "build_serial_spec",
    "compile_scene",
    "home_ctrl",
    "home_qpos",
    "paper_to_world",
    "serial_scene_config",
    "world_to_paper",
]

ROBOT = "serial4"
EFFECTOR = "fuzzy_gripper"
SHOULDER_HEIGHT_M = 0.060
"""The shoulder axis above the floor (models/serial4: the turntable's height)."""
CAMERAS = {
    # name: (body, position, point looked at (both in the body's frame), vertical field of
    # view deg)
    "overview": ("world", (0.34, 0.28, 0.33), (0.08, -0.05, 0.07), 42.0),
    "gripper_closeup": ("gripper_mount", (0.0, 0.11, 0.07), (0.06, 0.0, 0.0), 50.0),
}
"""The scene's named cameras (`transplanter render serial_arm`): the arm with the pool and
the belt (a workcell's own `overview` is moved here), and the fingers seen from above the
gripper's side, riding on it."""


@dataclass(frozen=True)
class SerialSceneConfig:
    """What the serial arm's scene is built from (SI). The arm's numbers come from `[serial4]`,
    the gripper's from `[fuzzy_gripper]` (docs/serial_arm.md)."""

    l1_m: float = 0.080
    """Shoulder axis to elbow axis."""
    l2_m: float = 0.080
    """Elbow axis to the grip centre (the forearm is l2 less the gripper's reach)."""
    servos: tuple[str, str, str, str] = ("sg90", "mg996r", "mg996r", "sg90")
    """The servo classes of base, shoulder, elbow and gripper (the last one is the gripper's:
    it replaces `gripper.servo`)."""
    park_rad: tuple[float, float, float] = (0.0, np.pi / 2, -np.pi / 2)
    """The park pose (base, shoulder, elbow) at power-on."""
    timestep_s: float = 0.001
    gripper: FuzzyGripperConfig = field(default_factory=FuzzyGripperConfig)
    workcell_kind: str | None = None
    """The workcell of the job (`scene.kinds.workcell`), or none: the arm on a bare floor."""
    workcell: object | None = None
    """The workcell module's config (its `apply` and `populate` take it)."""
    base_pos_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Where the arm's base plate stands in the world (the workcell's frame): the origin for
    the pool_to_belt cell, a pedestal beside another job's line (its scene adds the pedestal)."""
    base_yaw_rad: float = 0.0
    """The base turned about the vertical: the arm's forward (theta1 = 0) along world +x
    turned by this much."""
    decor: bool = True
    """The workcell's decor (a pot's seedling, its paper mesh) built too; off for physics only."""

    def __post_init__(self) -> None:
        if len(self.servos) != 4:
            raise ValueError("SerialSceneConfig.servos: four servo classes (base, shoulder, "
                             "elbow, gripper)")  # fmt: skip
        for name in self.servos:
            servo_class(name)
        if self.gripper.servo != self.servos[3]:
            object.__setattr__(self, "gripper", replace(self.gripper, servo=self.servos[3]))


def serial_scene_config(sc, workcell_kind: str | None = None, workcell: object | None = None):
    """The scene's config from a scenario: `[serial4]` (links, servos, park pose),
    `[fuzzy_gripper]` and `[physics] timestep`; the workcell as given (its module reads its
    own section)."""
    from transplanter.scenario.assemble import fuzzy_gripper_config

    s = sc.serial4
    servos = (s.base_servo, s.shoulder_servo, s.elbow_servo, s.gripper_servo)
    return SerialSceneConfig(
        l1_m=s.l1_m,
        l2_m=s.l2_m,
        servos=servos,
        park_rad=(s.park_base_rad, s.park_shoulder_rad, s.park_elbow_rad),
        timestep_s=sc.physics.timestep_s,
        gripper=replace(fuzzy_gripper_config(sc), servo=s.gripper_servo),
        workcell_kind=workcell_kind,
        workcell=workcell,
    )


def _yaw(yaw_rad: float) -> np.ndarray:
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def paper_to_world(p, base=(0.0, 0.0, 0.0), yaw_rad: float = 0.0) -> np.ndarray:
    """(..., 3) points of the paper's frame (x forward, y up, z to the right; origin at the
    shoulder) in the world (z up): (x, -z, 0.060 + y) from the arm's base plate, turned by
    ``yaw_rad`` about the vertical and standing at ``base`` (the world origin, no turn, on a
    bare floor and in the pool_to_belt cell; `SerialSceneConfig.base_pos_m` and
    `base_yaw_rad` beside another job's line)."""
    p = np.asarray(p, dtype=np.float64)
    local = np.stack([p[..., 0], -p[..., 2], SHOULDER_HEIGHT_M + p[..., 1]], axis=-1)
    return local @ _yaw(yaw_rad).T + np.asarray(base, dtype=np.float64)


def world_to_paper(w, base=(0.0, 0.0, 0.0), yaw_rad: float = 0.0) -> np.ndarray:
    """The inverse of `paper_to_world`."""
    w = np.asarray(w, dtype=np.float64) - np.asarray(base, dtype=np.float64)
    local = w @ _yaw(yaw_rad)
    return np.stack([local[..., 0], local[..., 2] - SHOULDER_HEIGHT_M, -local[..., 1]], axis=-1)


def _add_floor(spec: mujoco.MjSpec) -> None:
    spec.add_texture(
        name="groundplane", type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, mark=mujoco.mjtMark.mjMARK_EDGE,
        rgb1=[0.2, 0.3, 0.4], rgb2=[0.1, 0.2, 0.3], markrgb=[0.8, 0.8, 0.8], width=300,
        height=300,
    )  # fmt: skip
    mat = spec.add_material(name="groundplane", texuniform=True, texrepeat=[5, 5],
                            reflectance=0.2)  # fmt: skip
    mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "groundplane"
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05],
                            material="groundplane")  # fmt: skip
    spec.worldbody.add_light(
        pos=[0, 0, 1.5], dir=[0, 0, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
    )
    spec.add_texture(
        name="skybox", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, rgb1=[0.3, 0.5, 0.7], rgb2=[0, 0, 0],
        width=512, height=3072,
    )  # fmt: skip


def _look_at_quat(pos, target) -> list[float]:
    """The quaternion of a camera at `pos` looking at `target`, its x axis level."""
    forward = np.asarray(target, float) - np.asarray(pos, float)
    forward /= np.linalg.norm(forward)
    x = np.cross(forward, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(x, forward)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.column_stack([x, y, -forward]).ravel())
    return quat.tolist()


def add_cameras(spec: mujoco.MjSpec) -> None:
    """The named cameras of CAMERAS (a camera of that name already there, the workcell's
    `overview`, is replaced), the headlight of models/serial4/scene.xml and a skybox: all
    only drawn, no physics changes."""
    for name, (body, pos, target, fovy) in CAMERAS.items():
        old = spec.camera(name)
        if old is not None:  # its orientation may be given another way (xyaxes)
            spec.delete(old)
        parent = spec.worldbody if body == "world" else spec.body(body)
        parent.add_camera(name=name, pos=list(pos), quat=_look_at_quat(pos, target), fovy=fovy)
    head = spec.visual.headlight  # as models/serial4/scene.xml: drawn only
    head.diffuse, head.ambient, head.specular = [0.6] * 3, [0.3] * 3, [0.0] * 3
    if not any(t.type == mujoco.mjtTexture.mjTEXTURE_SKYBOX for t in spec.textures):
        spec.add_texture(
            name="skybox", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
            builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, rgb1=[0.3, 0.5, 0.7], rgb2=[0, 0, 0],
            width=512, height=3072,
        )  # fmt: skip


def build_serial_spec(
    cfg: SerialSceneConfig, seed: int | None = None, models: str | Path | None = None
) -> mujoco.MjSpec:
    """The scene's spec: a floor and a light, the serial arm (robot kind 'serial4') with the
    fuzzy gripper attached at its `tool_mount` (effector kind 'fuzzy_gripper'), both made
    the config's; and, where `cfg.workcell_kind` names one, that workcell (`apply`, then
    `populate(spec, cfg.workcell, seed, decor=cfg.decor)`). No keyframe: `home_qpos` and
    `home_ctrl` give the power-on state."""
    root = Path(models) if models is not None else models_dir()
    robot = kinds.robot(ROBOT)
    robot_file = root / robot.MODEL / f"{robot.MODEL}.xml"
    if cfg.workcell_kind:  # the workcell's world merged in, as the five-bar's scene does
        from transplanter.scene.build import merge_models, workcell_xml

        spec = merge_models([robot_file, workcell_xml(cfg.workcell_kind, root)], "serial_scene")
    else:
        spec = mujoco.MjSpec.from_file(str(robot_file))
    robot.attach_effector(spec, root)
    effector = kinds.effector(EFFECTOR)
    effector.apply(spec, cfg.gripper)
    effector.add_canopy_contact(spec, cfg.gripper)
    robot.apply(spec, cfg)  # after the effector's: the forearm is l2 less its reach
    robot.apply_inertials(spec, cfg)
    spec.option.timestep = cfg.timestep_s
    if not any(g.type == mujoco.mjtGeom.mjGEOM_PLANE for g in spec.worldbody.geoms):
        _add_floor(spec)
    if cfg.workcell_kind:
        cell = kinds.workcell(cfg.workcell_kind)
        cell.apply(spec, cfg.workcell)
        cell.populate(spec, cfg.workcell, seed, decor=cfg.decor)
    add_cameras(spec)
    return spec


def compile_scene(spec: mujoco.MjSpec) -> mujoco.MjModel:
    """Compile the scene (MuJoCo's note on the gripper attached without a name prefix
    silenced: `robots.delta.quiet_prefix_note`)."""
    with kinds.robot(ROBOT).quiet_prefix_note():
        return spec.compile()


def home_joints(cfg: SerialSceneConfig) -> dict[str, float]:
    """The arm's park pose and the fingers at half the standby servo angle (rad)."""
    return {**kinds.robot(ROBOT).home_joints(cfg), **kinds.effector(EFFECTOR).home_joints(cfg)}


def home_qpos(model: mujoco.MjModel, cfg: SerialSceneConfig) -> np.ndarray:
    """The scene's qpos at power-on: the arm parked, the gripper open at its standby angle
    (48 deg by default), everything else where its body is drawn."""
    qpos = model.qpos0.copy()
    for name, q in home_joints(cfg).items():
        qpos[model.jnt_qposadr[model.joint(name).id]] = q
    return qpos


def home_ctrl(model: mujoco.MjModel, cfg: SerialSceneConfig) -> np.ndarray:
    """The actuators' power-on commands: base, shoulder, elbow at the park pose, gripper at
    its standby angle; any other actuator (a workcell's) at 0."""
    ctrl = np.zeros(model.nu)
    names = ("base", "shoulder", "elbow", "gripper")
    values = [*kinds.robot(ROBOT).home_ctrl(cfg), *kinds.effector(EFFECTOR).home_ctrl(cfg)]
    for name, value in zip(names, values, strict=True):
        ctrl[model.actuator(name).id] = value
    return ctrl
