"""build_scene: assemble the robot and its workcell from models/, apply a SceneConfig, add
ribs and pots, compile.

The models are MuJoCo Menagerie folders (models/README.md): the robot models/fivebar/
(fivebar.xml: arm, Z slide, gripper, their actuators and `home` keyframe) and the workcell
models/workcells/conveyor_tube/ (conveyor_tube.xml: floor, light, cameras, belt table, conveyor
carriage, drop tube). `scene_spec` merges the two files into one MjSpec as MJCF's <include>
would (robot first), each file's meshes read from its own assets/ folder. The files hold the
numbers of SceneConfig() (scripts/make_models.py writes them with the functions below), so for
the default config the `apply_*` steps change nothing; any other config is applied here: link
lengths and masses, stepper drives, gripper, solver, drop tube, conveyor layout, and the arm's
inertials derived from its geoms. Then the conveyor ribs and the rows x cols paper pots with
seedlings (a PotBatch drawn from the seed) are added, the `home` keyframe is set and the spec
is compiled into a Scene.

Frames and joint conventions: models/fivebar/README.md and docs/architecture.md.
"""

from __future__ import annotations

import importlib.resources
import posixpath
import shutil
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

import mujoco
import numpy as np

from transplanter.scene.config import (
    BIT_CANOPY,
    BIT_GRIPPER,
    BIT_POT,
    BIT_WORLD,
    CROOKED_FOOT_HEIGHT,
    JAW_HALF_THICKNESS,
    LEAF_BASE_LOW,
    LEAF_BASE_STEP,
    LEAF_PITCH_RAD,
    LEAF_PROXY_CENTRE,
    LEAF_PROXY_RGBA,
    PASSIVE_DROP,
    POT_COLLISION_RGBA,
    RIB_RGBA,
    ROLLING_FRICTION,
    SOFT_WALL_IMPEDANCE,
    STATIC_COLLISION_RGBA,
    TORSIONAL_FRICTION,
    SceneConfig,
    row_bit,
)
from transplanter.scene.geometry import (
    belt_table,
    cell_columns_x,
    column_box,
    drop_tube_boxes,
    pot_inertia,
    rib_boxes,
    row_y,
)
from transplanter.scene.handles import LeafProxies, Scene
from transplanter.scene.pots import PotBatch

# Bodies whose inertial is derived from their geoms (masses and shapes follow the config);
# models/fivebar/fivebar.xml carries the result for the default config as explicit <inertial>.
ARM_BODIES = (
    "platform", "link1", "passive1", "gripper", "jaw_left", "jaw_right", "link2", "passive2",
)  # fmt: skip
# Quaternion turning a capsule's axis (local z) onto local x.
BOND_PAD_HALF_THICKNESS = 0.0005  # m: the bonding pad at a bonded pot's base
BOND_PAD_RADIUS_SHARE = 0.7  # of the pot's radius: the pad stays inside the pot's footprint
BOND_REACH = 0.001  # m: how far a bond stretches before it tears (estimate: paper fibres, roots)
_CAPSULE_Z_TO_X = np.array([np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0])


# The robot and the workcell the scene is assembled from (folders of models/), and the name of
# the assembled model.
ROBOT = "fivebar"
WORKCELL = "conveyor_tube"
SCENE_MODEL = "transplanter_scene"
# Which compiler directory an asset element's `file` is relative to (MJCF: meshdir and
# texturedir, each falling back to assetdir).
_ASSET_DIRS = {"mesh": "meshdir", "hfield": "meshdir", "skin": "meshdir", "texture": "texturedir"}


def models_dir() -> Path:
    """The MJCF models shipped with the package (models/ of the repository)."""
    return Path(str(importlib.resources.files("transplanter.models")))


def robot_xml(robot: str = ROBOT, models: str | Path | None = None) -> Path:
    """A robot's MJCF: models/<robot>/<robot>.xml (the robot only; scene.xml beside it adds a
    floor and a light)."""
    return Path(models if models is not None else models_dir()) / robot / f"{robot}.xml"


def workcell_xml(workcell: str = WORKCELL, models: str | Path | None = None) -> Path:
    """A workcell's MJCF: models/workcells/<workcell>/<workcell>.xml (its world without a robot)."""
    root = Path(models if models is not None else models_dir())
    return root / "workcells" / workcell / f"{workcell}.xml"


def scene_files(models: str | Path | None = None) -> tuple[Path, Path]:
    """The MJCF files the scene is assembled from, in order: the robot's, the workcell's."""
    return robot_xml(models=models), workcell_xml(models=models)


def merge_models(files: Sequence[str | Path], name: str = SCENE_MODEL) -> mujoco.MjSpec:
    """One MjSpec from MJCF files, merged as MJCF's <include> merges them: the sections of each
    file's <mujoco>, in the order of the files, under one <mujoco model=name>. Unlike <include>,
    each file's asset files (meshes, textures) are read from its own folder: MuJoCo resolves
    every asset against the main file's meshdir, so an included file cannot bring its own
    assets/ folder (and MjSpec.attach renames every element unless given an empty prefix, which
    MuJoCo warns about). The files must agree on their compiler's asset folders (Menagerie:
    meshdir="assets"); two files may not bring different files under the same name."""
    root = ET.Element("mujoco", model=name)
    assets: dict[str, bytes] = {}
    dirs: dict[str, str] | None = None
    for file in map(Path, files):
        doc = ET.parse(file).getroot()
        if doc.find(".//include") is not None:
            raise ValueError(f"{file}: has an <include>; merge the included file instead")
        compiler = doc.find("compiler")
        attrs = compiler.attrib if compiler is not None else {}
        these = {d: attrs.get(d, attrs.get("assetdir", "")) for d in ("meshdir", "texturedir")}
        if dirs is not None and these != dirs:
            raise ValueError(f"{file}: asset folders {these} differ from the other files' {dirs}")
        dirs = these
        for element in doc.iter():
            if element.tag not in _ASSET_DIRS or element.get("file") is None:
                continue
            key = posixpath.join(these[_ASSET_DIRS[element.tag]], element.get("file"))
            data = (file.parent / key).read_bytes()
            if assets.setdefault(key, data) != data:
                raise ValueError(f"{file}: {key} is another file than the one of that name before")
        root.extend(list(doc))
    return mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"), assets=assets)


def build_scene(config: SceneConfig | None = None, seed: int = 0) -> Scene:
    """Build and compile the full scene: machine, conveyor with ribs, pots, drop tube.

    The physics model leaves out the pots' decor (paper mesh, stem, leaves and the leaf
    proxies: massless geoms outside collision detection) because MuJoCo's broadphase walks
    every geom of every body at every step, sleeping or not; the scene builds the decorated
    model, with the same bodies and joints, only when something draws it
    (`Scene.render_model`)."""
    cfg = config if config is not None else SceneConfig()
    spec, pots = full_spec(cfg, seed, decor=False)

    def decorated() -> mujoco.MjModel:
        return compile_with_home(full_spec(cfg, seed, decor=True)[0], cfg)

    return Scene(compile_with_home(spec, cfg), cfg, pots, leaf_proxies(cfg, pots), decorated)


def full_spec(cfg: SceneConfig, seed: int, decor: bool = True) -> tuple[mujoco.MjSpec, PotBatch]:
    """The whole scene's MjSpec (before the home keyframe is set) and its pots; without
    `decor`, the pots carry only their collision geoms (same bodies, joints, masses)."""
    spec = scene_spec(cfg)
    pots = PotBatch.draw(cfg, seed)
    add_ribs(spec, cfg)
    add_pots(spec, cfg, pots, decor)
    if cfg.canopy_contact:
        for jaw in ("jaw_left", "jaw_right"):
            spec.geom(jaw).conaffinity |= BIT_CANOPY
    return spec, pots


def export_scene(cfg: SceneConfig, seed: int, out: str | Path) -> Path:
    """Write the scene exactly as build_scene(cfg, seed) builds it as one MJCF file, with
    the meshes in an `assets/` folder beside it; returns the XML's path. It loads in
    `python -m mujoco.viewer --mjcf OUT.xml`, MuJoCo Studio and MjModel.from_xml_path.
    MuJoCo's XML writer keeps 6 significant digits, so the file's numbers match the built
    scene's to about 5e-6 relative (a 1 s rollout agrees within 0.1 mm), not bit for bit."""
    from transplanter import fileio

    target = fileio.check_output(out, ".xml")
    spec, _ = full_spec(cfg, seed, decor=True)
    compile_with_home(spec, cfg)
    xml = spec.to_xml()
    assets = target.parent / spec.meshdir
    assets.mkdir(exist_ok=True)
    for xml_file in scene_files():  # every folder's meshes (the model's mesh files are unique)
        for mesh in sorted((xml_file.parent / spec.meshdir).iterdir()):
            if mesh.suffix == ".stl":
                shutil.copyfile(mesh, assets / mesh.name)
    fileio.write_text_atomic(target, xml)
    return target


def scene_spec(cfg: SceneConfig, models: str | Path | None = None) -> mujoco.MjSpec:
    """The robot and the workcell of `models` (default: the package's models/) merged into one
    spec (`merge_models`), with the config applied: all but the ribs and pots."""
    spec = merge_models(scene_files(models))
    apply_options(spec, cfg)
    apply_arm(spec, cfg)
    apply_drop_tube(spec, cfg)
    apply_conveyor_layout(spec, cfg)
    apply_arm_inertials(spec)
    return spec


def apply_arm_inertials(spec: mujoco.MjSpec) -> None:
    """Explicit inertials of the arm's bodies, computed by MuJoCo from their geoms (masses
    and shapes follow the config), exactly as the compiler would without an <inertial>."""
    probe = spec.copy()
    probe.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE
    model = probe.compile()
    for body in ARM_BODIES:
        b, i = spec.body(body), model.body(body).id
        b.mass = model.body_mass[i]
        b.ipos = model.body_ipos[i]
        b.iquat = model.body_iquat[i]
        b.inertia = model.body_inertia[i]
        b.explicitinertial = True


def compile_with_home(spec: mujoco.MjSpec, cfg: SceneConfig) -> mujoco.MjModel:
    """Set the `home` keyframe (qpos0 for the joints it does not name) and compile."""
    model0 = spec.compile()
    qpos = model0.qpos0.copy()
    for joint_name, value in home_joint_positions(cfg).items():
        qpos[model0.joint(joint_name).qposadr[0]] = value
    key = spec.key("home")
    key.qpos = qpos
    bonds = model0.nu - len(home_ctrl(cfg))  # adhesion of bonded pots: off until loaded
    key.ctrl = home_ctrl(cfg) + [0.0] * bonds
    return spec.compile()


def home_joint_positions(cfg: SceneConfig) -> dict[str, float]:
    """The `home` keyframe (power-on pose) by joint: the passive angles close the chain,
    the gripper is fully open, the conveyor at 0."""
    phi1, phi2 = (
        float(a) for a in cfg.kinematics().passive_angles(cfg.power_on_theta1, cfg.power_on_theta2)
    )
    return {
        "z": cfg.power_on_z,
        "theta1": cfg.power_on_theta1,
        "theta2": cfg.power_on_theta2,
        "phi1": phi1,
        "phi2": phi2,
        "wrist": 0.0,
        "jaw_left": cfg.gripper_max_opening / 2,
        "jaw_right": cfg.gripper_max_opening / 2,
        "conveyor": 0.0,
    }


def home_ctrl(cfg: SceneConfig) -> list[float]:
    """Actuator commands of the `home` keyframe: motor angles = gear * joint position."""
    return [
        cfg.arm_belt_ratio * cfg.power_on_theta1,
        cfg.arm_belt_ratio * cfg.power_on_theta2,
        cfg.screw_gear * cfg.power_on_z,
        cfg.gripper_max_opening,
        0.0,
    ]


def apply_options(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    opt = spec.option
    opt.timestep = cfg.timestep
    opt.impratio = cfg.impratio
    opt.iterations = cfg.solver_iterations
    opt.tolerance = cfg.solver_tolerance
    opt.jacobian = {
        "auto": mujoco.mjtJacobian.mjJAC_AUTO,
        "dense": mujoco.mjtJacobian.mjJAC_DENSE,
        "sparse": mujoco.mjtJacobian.mjJAC_SPARSE,
    }[cfg.jacobian]
    opt.sleep_tolerance = cfg.sleep_tolerance
    bit = int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    opt.enableflags = (opt.enableflags | bit) if cfg.sleep else (opt.enableflags & ~bit)


def apply_arm(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """Five-bar links, column, gripper, stepper drives, servos and limit switches."""
    spec.body("link1").pos = [-cfg.l0, 0, 0]
    spec.body("link2").pos = [cfg.l0, 0, 0]
    spec.geom("motor1").pos = [-cfg.l0, 0, spec.geom("motor1").pos[2]]
    spec.geom("motor2").pos = [cfg.l0, 0, spec.geom("motor2").pos[2]]
    for i in (1, 2):
        spec.geom(f"link{i}").fromto = [0, 0, 0, cfg.l1, 0, 0]
        spec.geom(f"link{i}").mass = cfg.active_link_mass
        spec.body(f"passive{i}").pos = [cfg.l1, 0, -PASSIVE_DROP]
        spec.geom(f"passive{i}").fromto = [0, 0, 0, cfg.l2, 0, 0]
        spec.geom(f"passive{i}").mass = cfg.passive_link_mass
        spec.site(f"c{i}").pos = [cfg.l2, 0, 0]
    spec.body("gripper").pos = [cfg.l2, 0, PASSIVE_DROP]
    spec.geom("platform").mass = cfg.platform_mass
    # Column: arm plane at column_height above the grip centre. The palm is laid out for the
    # column height the file is drawn for (the platform's height there) and moves with it.
    platform = spec.body("platform")
    shift = cfg.column_height - platform.pos[2]
    platform.pos = [0, 0, cfg.column_height]
    for geom_name in ("palm", "palm_visual"):
        g = spec.geom(geom_name)
        g.pos = [g.pos[0], g.pos[1], g.pos[2] - shift]
    column = spec.geom("column")
    half_length, centre_z = column_box(cfg)
    column.size = [column.size[0], half_length, 0]
    column.pos = [0, 0, centre_z]
    spec.site("grip_center").pos = [0, 0, -cfg.column_height]
    spec.body("jaw_left").pos = [-JAW_HALF_THICKNESS, 0, -cfg.column_height]
    spec.body("jaw_right").pos = [JAW_HALF_THICKNESS, 0, -cfg.column_height]

    # Stepper drives: position servos on the motor shaft through the gear, torque-limited,
    # with the pull-out curve as joint damping (models/fivebar/README.md).
    arm_gear, screw_gear = cfg.arm_belt_ratio, cfg.screw_gear
    screw_torque = cfg.holding_torque * cfg.screw_efficiency
    for joint_name, gear, torque, scale in (
        ("theta1", arm_gear, cfg.holding_torque, cfg.arm_stiffness_scale),
        ("theta2", arm_gear, cfg.holding_torque, cfg.arm_stiffness_scale),
        ("z", screw_gear, screw_torque, cfg.z_stiffness_scale),
    ):
        act = spec.actuator(joint_name)
        kp = scale * torque / cfg.full_step_rad
        act.gear = [gear, 0, 0, 0, 0, 0]
        act.gainprm = [kp] + [0] * 9
        act.biasprm = [0, -kp, cfg.stepper_dampratio] + [0] * 7
        act.forcerange = [-torque, torque]
        joint = spec.joint(joint_name)
        joint.range = list(getattr(cfg, f"{joint_name}_range"))
        joint.damping = [torque / cfg.pullout_zero_speed * gear**2, 0, 0]
        joint.armature = cfg.rotor_inertia * gear**2

    grip = spec.actuator("gripper")
    grip.gainprm = [cfg.gripper_kp] + [0] * 9
    grip.biasprm = [0, -cfg.gripper_kp, 0] + [0] * 7
    grip.forcerange = [-cfg.grip_force, cfg.grip_force]
    grip.ctrlrange = [0, cfg.gripper_max_opening]
    for jaw in ("jaw_left", "jaw_right"):
        spec.joint(jaw).range = [0, cfg.gripper_max_opening / 2]
        spec.joint(jaw).damping = [cfg.jaw_damping, 0, 0]
    wrist = spec.actuator("wrist")
    wrist.gainprm = [cfg.wrist_kp] + [0] * 9
    wrist.biasprm = [0, -cfg.wrist_kp, 0] + [0] * 7
    wrist.forcerange = [-cfg.wrist_torque, cfg.wrist_torque]

    spec.numeric("limit_switch_trip").data = [
        cfg.switch1_theta1_min,
        cfg.switch2_theta2_max,
        cfg.switch3_z_min,
        cfg.switch4_z_max,
    ]


def apply_drop_tube(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """Funnel position, its tube walls (regenerated: drop_tube_boxes) and the plate."""
    body = spec.body("drop_tube")
    x, y = cfg.drop_tube_xy
    body.pos = [x, y, cfg.funnel_top_z]
    for geom in list(body.geoms):
        if geom.name.startswith("tube_wall_"):
            spec.delete(geom)
    for k, (half, pos, quat) in enumerate(drop_tube_boxes(cfg)):
        _add_static_box(body, f"tube_wall_{k}", half, pos, quat)
    bottom_z = -cfg.funnel_height - cfg.tube_length
    plate = spec.geom("planting_plate")
    plate.pos = [0, 0, bottom_z - plate.size[2]]


def _add_static_box(body, name, half, pos, quat) -> None:
    geom = body.add_geom()
    geom.name = name
    geom.type = mujoco.mjtGeom.mjGEOM_BOX
    geom.size = half
    geom.pos = pos
    geom.quat = quat
    geom.contype = BIT_WORLD
    geom.conaffinity = BIT_POT | BIT_GRIPPER
    geom.group = 3
    geom.rgba = list(STATIC_COLLISION_RGBA)


def apply_conveyor_layout(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """Carriage mass, slide friction and drive hold, and the belt table sized for rows x cols."""
    joint = spec.joint("conveyor")
    joint.frictionloss = cfg.conveyor_frictionloss
    joint.stiffness = [cfg.conveyor_hold_stiffness, 0.0, 0.0]  # held by its drive at springref 0
    joint.damping = [cfg.conveyor_hold_damping, 0.0, 0.0]
    spec.body("conveyor").mass = cfg.conveyor_mass
    table = spec.geom("belt_table")
    table.size, table.pos = belt_table(cfg, table.size[2])


def add_ribs(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """The ribs of every row on the conveyor carriage (they push only their row's pots)."""
    conveyor = spec.body("conveyor")
    for r in range(cfg.rows):
        bit = row_bit(r)
        for k, (size, pos) in enumerate(rib_boxes(cfg, r)):
            g = conveyor.add_geom()
            g.name = f"rib_{r}_{k}"
            g.type = mujoco.mjtGeom.mjGEOM_BOX
            g.size = size
            g.pos = pos
            g.contype = 0
            g.conaffinity = bit
            g.priority = 2
            g.friction = [cfg.rib_friction, TORSIONAL_FRICTION, ROLLING_FRICTION]
            g.mass = 0
            g.rgba = list(RIB_RGBA)


def add_pots(spec: mujoco.MjSpec, cfg: SceneConfig, pots: PotBatch, decor: bool = True) -> None:
    """A free body per pot: collision cylinder and (decor) visual mesh, stem, leaves and
    leaf proxies."""
    xs, ys = cell_columns_x(cfg), row_y(cfg)
    for i in range(len(pots)):
        r, c = divmod(i, cfg.cols)
        radius, h = pots.diameter[i] / 2, pots.height[i]
        body = spec.worldbody.add_body()
        body.name = f"pot_{r}_{c}"
        body.pos = [xs[c] + pots.offset[i, 0], ys[r] + pots.offset[i, 1], h / 2]
        body.add_freejoint()
        total_mass = pots.mass[i] + cfg.seedling_mass
        body.mass = total_mass
        body.ipos = [0, 0, 0.0 - pots.fill_gap[i] / 2]  # the soil sits below the gap
        body.inertia = pot_inertia(total_mass, radius, h)
        body.explicitinertial = True
        crook = pots.wall_frame(i)
        soil = pots.soil_z(i)  # the seedling stands on the soil (pot frame)
        if crook is None:
            _add_pot_geom(body, cfg, pots, i, f"pot_{r}_{c}", [0, 0, 0], h / 2)
        else:  # a flat foot, the wall leaning over it; the wall's mass leans with it
            pivot, rot, quat = crook
            foot = CROOKED_FOOT_HEIGHT
            _add_pot_geom(body, cfg, pots, i, f"pot_foot_{r}_{c}", pivot - [0, 0, foot / 2],
                          foot / 2)  # fmt: skip
            wall_half = (h - foot) / 2
            centre = pivot + rot @ [0, 0, wall_half]
            wall = _add_pot_geom(body, cfg, pots, i, f"pot_{r}_{c}", centre, wall_half)
            wall.quat = quat
            body.ipos += (h - foot) / h * (centre - (pivot + [0, 0, wall_half]))
        if decor:
            vis = body.add_geom()
            vis.type = mujoco.mjtGeom.mjGEOM_MESH
            vis.meshname = "paper_pot"
            vis.pos, vis.quat = _crooked([0, 0, -h / 2], [1, 0, 0, 0], crook)
            vis.contype = vis.conaffinity = 0
            vis.group = 2
            vis.mass = 0
            vis.material = "paper"
            _add_seedling(body, cfg, r, c, soil, pots.stem_length[i], pots.n_leaves[i],
                          pots.leaf_yaw0[i], crook)  # fmt: skip
        elif cfg.canopy_contact:  # the physics keeps the proxies that touch the jaws
            frames = _leaf_frames(
                soil, pots.stem_length[i], pots.n_leaves[i], pots.leaf_yaw0[i], crook
            )
            for k, (_, _, centre, along_x) in enumerate(frames):
                _add_leaf_proxy(body, cfg, f"leaf_{r}_{c}_{k}", centre, along_x)
        if pots.bond_force[i] > 0:
            _add_bond(spec, cfg, body, r, c, radius, h, pots.bond_force[i])


def _add_pot_geom(body, cfg: SceneConfig, pots: PotBatch, i: int, name, pos, half_height):
    """A collision cylinder of pot i (its radius, friction and wall softness)."""
    r = i // cfg.cols
    g = body.add_geom()
    g.name = name
    g.type = mujoco.mjtGeom.mjGEOM_CYLINDER
    g.size = [pots.diameter[i] / 2, half_height, 0]
    g.pos = list(pos)
    g.contype = BIT_POT | row_bit(r)
    g.conaffinity = BIT_WORLD | BIT_POT | BIT_GRIPPER
    g.condim = 4
    g.priority = 1
    g.friction = [pots.friction[i], TORSIONAL_FRICTION, ROLLING_FRICTION]
    g.solref = list(cfg.contact_solref)
    g.solimp = list(cfg.contact_solimp)
    if pots.soft[i]:  # soaked: the wall gives over pot_soft_wall before it resists
        g.solimp = [*SOFT_WALL_IMPEDANCE, cfg.pot_soft_wall, *cfg.contact_solimp[3:]]
    g.group = 3
    g.rgba = list(POT_COLLISION_RGBA)
    return g


def _crooked(pos, quat, crook):
    """A frame (pos, quat) of the straight pot above its foot, on the crooked pot."""
    if crook is None:
        return np.asarray(pos, dtype=float), np.asarray(quat, dtype=float)
    pivot, rot, q = crook
    out = np.zeros(4)
    mujoco.mju_mulQuat(out, q, np.asarray(quat, dtype=float))
    return pivot + rot @ (np.asarray(pos, dtype=float) - pivot), out


def _add_bond(spec: mujoco.MjSpec, cfg: SceneConfig, body, r, c, radius, h, force) -> None:
    """The pot's bond to the belt: MuJoCo adhesion on a thin pad flush with the pot's base
    (a child body without a joint: part of the pot) that touches only the belt, so the bond
    pulls the pot onto the belt, never onto the jaws, and acts only while the base touches
    it. A bond carries load only when something pulls the pot, and only the jaws do: the
    twin switches the adhesion on while the jaws touch the pot (`Scene.bond_actuators`;
    switched on at rest, MuJoCo's stiff adhesion against the soft contact keeps the pot
    rocking and awake). The pot's tree may sleep (an actuated tree never would by default)."""
    body.sleep = mujoco.mjtSleepPolicy.mjSLEEP_ALLOWED
    base = body.add_body()
    base.name = f"pot_base_{r}_{c}"
    base.pos = [0, 0, -h / 2 + BOND_PAD_HALF_THICKNESS]
    pad = base.add_geom()
    pad.name = f"pot_base_{r}_{c}"
    pad.type = mujoco.mjtGeom.mjGEOM_CYLINDER
    pad.size = [BOND_PAD_RADIUS_SHARE * radius, BOND_PAD_HALF_THICKNESS, 0]
    pad.contype = BIT_POT
    pad.conaffinity = 0
    pad.mass = 0
    pad.group = 3
    pad.rgba = list(POT_COLLISION_RGBA)
    pad.solref, pad.solimp = list(cfg.contact_solref), list(cfg.contact_solimp)  # as the pot's
    # contacts are kept (inactive) up to BOND_REACH above the belt, so the adhesion keeps
    # pulling while the bond stretches; beyond it the bond has torn
    pad.margin = pad.gap = BOND_REACH
    act = spec.add_actuator()
    act.name = f"bond_{r}_{c}"
    act.set_to_adhesion(gain=float(force))
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.ctrlrange = [0.0, 1.0]
    act.trntype = mujoco.mjtTrn.mjTRN_BODY
    act.target = base.name


def _add_seedling(body, cfg: SceneConfig, r, c, top, stem, n_leaves, leaf_yaw0, crook) -> None:
    """Stem and leaves (visual) and a capsule proxy per leaf (leaf_hit_pots) on a pot."""
    stem_geom = body.add_geom()
    stem_geom.type = mujoco.mjtGeom.mjGEOM_CAPSULE
    base, _ = _crooked([0, 0, top], [1, 0, 0, 0], crook)
    tip, _ = _crooked([0, 0, top + stem], [1, 0, 0, 0], crook)
    stem_geom.fromto = [*base, *tip]
    stem_geom.size = [cfg.stem_radius, 0, 0]
    stem_geom.contype = stem_geom.conaffinity = 0
    stem_geom.group = 2
    stem_geom.mass = 0
    stem_geom.material = "leaf"
    frames = _leaf_frames(top, stem, n_leaves, leaf_yaw0, crook)
    for k, (base, quat, centre, along_x) in enumerate(frames):
        leaf_vis = body.add_geom()
        leaf_vis.type = mujoco.mjtGeom.mjGEOM_MESH
        leaf_vis.meshname = "seedling_leaf"
        leaf_vis.pos = base
        leaf_vis.quat = quat
        leaf_vis.contype = leaf_vis.conaffinity = 0
        leaf_vis.group = 2
        leaf_vis.mass = 0
        leaf_vis.material = "leaf"
        _add_leaf_proxy(body, cfg, f"leaf_{r}_{c}_{k}", centre, along_x)


def _add_leaf_proxy(body, cfg: SceneConfig, name: str, centre, along_x) -> None:
    """A leaf's capsule proxy: tested geometrically (leaf_hit_pots) and, with
    cfg.canopy_contact, a soft contact with the jaws and nothing else."""
    proxy = body.add_geom()
    proxy.name = name
    # A capsule along the leaf's length: capsule-box contacts with the gripper are
    # analytic, ellipsoids would take the general convex solver (3x the narrowphase).
    proxy.type = mujoco.mjtGeom.mjGEOM_CAPSULE
    proxy.size = [cfg.leaf_radius, cfg.leaf_half_length, 0]
    proxy.pos = centre
    proxy.quat = along_x
    proxy.contype = proxy.conaffinity = 0
    if cfg.canopy_contact:  # touches the jaws (their conaffinity has the bit), nothing else
        proxy.contype = BIT_CANOPY
        proxy.condim = 3
        proxy.priority = 3  # the leaf's softness and friction decide the contact
        proxy.friction = [cfg.canopy_friction, TORSIONAL_FRICTION, ROLLING_FRICTION]
        proxy.solref = [cfg.canopy_timeconst, 1.0]
    proxy.group = 4
    proxy.mass = 0
    proxy.rgba = list(LEAF_PROXY_RGBA)


def _leaf_frames(top: float, stem: float, n_leaves: int, leaf_yaw0: float, crook=None):
    """Per leaf of a seedling, in its pot's frame: the leaf mesh's base and quaternion and
    its capsule proxy's centre and quaternion (capsule axis along the leaf); on a crooked
    pot (crook: its crook_frame) they lean with the wall."""
    for k in range(int(n_leaves)):
        yaw = leaf_yaw0 + 2 * np.pi * k / n_leaves
        base = np.array([0, 0, top + stem * (LEAF_BASE_LOW + LEAF_BASE_STEP * (k % 2))])
        quat = np.zeros(4)
        mujoco.mju_euler2Quat(quat, np.array([0.0, LEAF_PITCH_RAD, yaw]), "xyz")
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, quat)
        centre = base + rot.reshape(3, 3) @ np.array(LEAF_PROXY_CENTRE)
        along_x = np.zeros(4)
        mujoco.mju_mulQuat(along_x, quat, _CAPSULE_Z_TO_X)
        base, quat = _crooked(base, quat, crook)
        centre, along_x = _crooked(centre, along_x, crook)
        yield base, quat, centre, along_x


def leaf_proxies(cfg: SceneConfig, pots: PotBatch) -> LeafProxies:
    """Every leaf's capsule proxy in its pot's frame, as the decorated model places it."""
    pot, centre, axis = [], [], []
    for i in range(len(pots)):
        frames = _leaf_frames(
            pots.soil_z(i), pots.stem_length[i], pots.n_leaves[i], pots.leaf_yaw0[i],
            pots.wall_frame(i),
        )  # fmt: skip
        for _, _, c, along_x in frames:
            rot = np.zeros(9)
            mujoco.mju_quat2Mat(rot, along_x)
            pot.append(i)
            centre.append(c)
            axis.append(rot.reshape(3, 3)[:, 2])
    return LeafProxies(
        pot=np.array(pot, dtype=int),
        centre=np.array(centre, dtype=float).reshape(-1, 3),
        axis=np.array(axis, dtype=float).reshape(-1, 3),
        radius=cfg.leaf_radius,
        half_length=cfg.leaf_half_length,
    )
