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
from dataclasses import replace
from pathlib import Path

import mujoco

from transplanter.scene import kinds
from transplanter.scene.config import (
    SceneConfig,
)
from transplanter.scene.handles import Scene
from transplanter.scene.pots import PotBatch

SCENE_MODEL = "transplanter_scene"
"""The name of the assembled model."""
ROBOT = SceneConfig.robot_kind
"""The default robot (SceneConfig().robot_kind): the five-bar."""
WORKCELL = SceneConfig.workcell_kind
"""The default workcell (SceneConfig().workcell_kind): pots on a conveyor into a drop tube."""
# Which compiler directory an asset element's `file` is relative to (MJCF: meshdir and
# texturedir, each falling back to assetdir).
_ASSET_DIRS = {"mesh": "meshdir", "hfield": "meshdir", "skin": "meshdir", "texture": "texturedir"}


def models_dir() -> Path:
    """The MJCF models shipped with the package (models/ of the repository)."""
    return Path(str(importlib.resources.files("transplanter.models")))


def robot_xml(robot: str = ROBOT, models: str | Path | None = None) -> Path:
    """A robot's MJCF: models/<MODEL>/<MODEL>.xml of its scene module (the robot only;
    scene.xml beside it adds a floor and a light)."""
    model = kinds.robot(robot).MODEL
    return Path(models if models is not None else models_dir()) / model / f"{model}.xml"


def workcell_xml(workcell: str = WORKCELL, models: str | Path | None = None) -> Path:
    """A workcell's MJCF: models/workcells/<MODEL>/<MODEL>.xml (its world without a robot)."""
    model = kinds.workcell(workcell).MODEL
    root = Path(models if models is not None else models_dir())
    return root / "workcells" / model / f"{model}.xml"


def scene_files(
    models: str | Path | None = None, cfg: SceneConfig | None = None
) -> tuple[Path, Path]:
    """The MJCF files the scene of `cfg`'s kinds is assembled from, in order: the robot's, the
    workcell's."""
    cfg = cfg if cfg is not None else SceneConfig()
    return robot_xml(cfg.robot_kind, models), workcell_xml(cfg.workcell_kind, models)


def model_files(cfg: SceneConfig | None = None, models: str | Path | None = None) -> list[Path]:
    """Every MJCF file the scene of `cfg`'s kinds is made of: the robot's, its effector's
    (where it has a folder of its own) and the workcell's."""
    cfg = cfg if cfg is not None else SceneConfig()
    robot, workcell = scene_files(models, cfg)
    effector = effector_xml(cfg.effector_kind, models)
    return [robot, *([effector] if effector is not None else []), workcell]


def merge_models(
    files: Sequence[str | Path],
    name: str = SCENE_MODEL,
    attach: Sequence[tuple[str, str | Path]] = (),
) -> mujoco.MjSpec:
    """One MjSpec from MJCF files, merged as MJCF's <include> merges them: the sections of each
    file's <mujoco>, in the order of the files, under one <mujoco model=name>. Unlike <include>,
    each file's asset files (meshes, textures) are read from its own folder: MuJoCo resolves
    every asset against the main file's meshdir, so an included file cannot bring its own
    assets/ folder (and MjSpec.attach renames every element unless given an empty prefix, which
    MuJoCo warns about). The files must agree on their compiler's asset folders (Menagerie:
    meshdir="assets"); two files may not bring different files under the same name.

    `attach`: (frame, file) pairs: the bodies of `file`'s worldbody go into the `<frame
    name=frame>` of the files before it (a robot's mount: its effector, Menagerie-style), its
    other sections after that file's (its tendons, equalities and actuators follow the
    robot's), its keyframes left out (the scene sets `home` itself)."""
    root = ET.Element("mujoco", model=name)
    assets: dict[str, bytes] = {}
    dirs: dict[str, str] | None = None
    docs = [(Path(f), None) for f in files]
    # an attached file right after the file that holds its frame
    for frame, file in attach:
        holder = next(
            (i for i, (f, _) in enumerate(docs) if _has_frame(ET.parse(f).getroot(), frame)),
            None,
        )
        if holder is None:
            raise ValueError(f"{file}: no <frame name={frame!r}> in {', '.join(map(str, files))}")
        docs.insert(holder + 1, (Path(file), frame))
    for file, frame in docs:
        doc = ET.parse(file).getroot()
        if doc.find(".//include") is not None:
            raise ValueError(f"{file}: has an <include>; merge the included file instead")
        compiler = doc.find("compiler")
        attrs = compiler.attrib if compiler is not None else {}
        these = {d: attrs.get(d, attrs.get("assetdir", "")) for d in ("meshdir", "texturedir")}
        used = {_ASSET_DIRS[e.tag] for e in doc.iter() if e.tag in _ASSET_DIRS and e.get("file")}
        if dirs is not None and any(these[d] != dirs[d] for d in used if d in dirs):
            raise ValueError(f"{file}: asset folders {these} differ from the other files' {dirs}")
        for d in used:  # a folder the file does not use need not agree (the arm has no textures)
            (dirs := dirs if dirs is not None else {}).setdefault(d, these[d])
        for element in doc.iter():
            if element.tag not in _ASSET_DIRS or element.get("file") is None:
                continue
            key = posixpath.join(these[_ASSET_DIRS[element.tag]], element.get("file"))
            data = (file.parent / key).read_bytes()
            if assets.setdefault(key, data) != data:
                raise ValueError(f"{file}: {key} is another file than the one of that name before")
        if compiler is not None and dirs is not None:  # the folders of the files that use them
            for d, value in dirs.items():
                compiler.set(d, value)
        sections = list(doc)
        if frame is not None:
            target = next(f for f in root.iter("frame") if f.get("name") == frame)
            for section in sections:
                if section.tag == "worldbody":
                    target.extend(list(section))
            sections = [s for s in sections if s.tag not in ("worldbody", "keyframe", "compiler")]
        root.extend(sections)
    spec = mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"), assets=assets)
    if attach:
        _join_keys(spec, [f for f, _ in docs])
    return spec


def _join_keys(spec: mujoco.MjSpec, files: Sequence[Path]) -> None:
    """The merged spec's `home` keyframe made of every file's own `home` (a robot's and its
    attached effector's: each holds its joints and actuators, in that file's order), the other
    joints at qpos0: the one keyframe MJCF would give a single file holding them all."""
    key = next((k for k in spec.keys if k.name == "home"), None)
    if key is None:
        return
    model = spec.compile()
    qpos, ctrl = model.qpos0.copy(), [0.0] * model.nu
    for file in files:
        own = mujoco.MjModel.from_xml_path(str(file))
        if own.nkey == 0 or mujoco.mj_name2id(own, mujoco.mjtObj.mjOBJ_KEY, "home") < 0:
            continue
        home = own.key("home")
        for j in range(own.njnt):
            size = {0: 7, 1: 4}.get(int(own.jnt_type[j]), 1)  # free, ball, slide or hinge
            src, dst = int(own.jnt_qposadr[j]), int(model.joint(own.joint(j).name).qposadr[0])
            qpos[dst : dst + size] = home.qpos[src : src + size]
        for a in range(own.nu):
            ctrl[model.actuator(own.actuator(a).name).id] = float(home.ctrl[a])
    key.qpos = qpos.tolist()
    key.ctrl = ctrl


def _has_frame(doc: ET.Element, name: str) -> bool:
    return any(f.get("name") == name for f in doc.iter("frame"))


def build_scene(config: SceneConfig | None = None, seed: int = 0) -> Scene:
    """Build and compile the full scene: machine, conveyor with ribs, pots, drop tube.

    The physics model leaves out the pots' decor (paper mesh, stem, leaves and the leaf
    proxies: massless geoms outside collision detection) because MuJoCo's broadphase walks
    every geom of every body at every step, sleeping or not; the scene builds the decorated
    model, with the same bodies and joints, only when something draws it
    (`Scene.render_model`). A windowed scene (config.live_rows < rows) is drawn with a body
    per pot, each placed where the window says it is (`Scene.render_data`)."""
    cfg = config if config is not None else SceneConfig()
    spec, pots = full_spec(cfg, seed, decor=False)

    def decorated() -> mujoco.MjModel:
        # a windowed scene is drawn with a body per pot (Scene.render_data places them)
        drawn = replace(cfg, live_rows=cfg.rows) if cfg.windowed else cfg
        return compile_with_home(full_spec(drawn, seed, decor=True)[0], drawn)

    proxies = kinds.workcell(cfg.workcell_kind).leaf_proxies(cfg, pots)
    return Scene(compile_with_home(spec, cfg), cfg, pots, proxies, decorated)


def full_spec(cfg: SceneConfig, seed: int, decor: bool = True) -> tuple[mujoco.MjSpec, PotBatch]:
    """The whole scene's MjSpec (before the home keyframe is set) and its pots; without
    `decor`, the pots carry only their collision geoms (same bodies, joints, masses)."""
    spec = scene_spec(cfg)
    pots = kinds.workcell(cfg.workcell_kind).populate(spec, cfg, seed, decor)
    kinds.effector(cfg.effector_kind).add_canopy_contact(spec, cfg)
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
    for xml_file in model_files(cfg):  # every folder's meshes (the model's mesh files are unique)
        folder = xml_file.parent / spec.meshdir
        for mesh in sorted(folder.iterdir()) if folder.is_dir() else ():
            if mesh.suffix == ".stl":
                shutil.copyfile(mesh, assets / mesh.name)
    fileio.write_text_atomic(target, xml)
    return target


def effector_xml(effector: str, models: str | Path | None = None) -> Path | None:
    """An effector's MJCF: models/effectors/<MODEL>/<MODEL>.xml of its scene module (None for
    an effector drawn in its robot's file)."""
    model = getattr(kinds.effector(effector), "MODEL", "")
    if not model:
        return None
    root = Path(models if models is not None else models_dir())
    return root / "effectors" / model / f"{model}.xml"


def mounts(cfg: SceneConfig, models: str | Path | None = None) -> tuple[tuple[str, Path], ...]:
    """(the robot's mount frame, the effector's MJCF) for `merge_models`: the config's
    effector attached at its robot's ``MOUNT``; () for an effector drawn in the robot's own
    file."""
    path = effector_xml(cfg.effector_kind, models)
    return () if path is None else ((kinds.robot(cfg.robot_kind).MOUNT, path),)


def scene_spec(cfg: SceneConfig, models: str | Path | None = None) -> mujoco.MjSpec:
    """The robot and the workcell of the config's kinds from `models` (default: the package's
    models/) merged into one spec (`merge_models`), the effector attached at the robot's mount
    (`mounts`), with the config applied by each kind's scene module (robot,
    effector, workcell): all but what the job puts in (ribs and pots)."""
    robot = kinds.robot(cfg.robot_kind)
    spec = merge_models(scene_files(models, cfg), attach=mounts(cfg, models))
    apply_options(spec, cfg)
    robot.apply(spec, cfg)
    kinds.effector(cfg.effector_kind).apply(spec, cfg)
    kinds.workcell(cfg.workcell_kind).apply(spec, cfg)
    robot.apply_inertials(spec, cfg)
    return spec


def robot_spec(cfg: SceneConfig, models: str | Path | None = None) -> mujoco.MjSpec:
    """The robot of the config's kind alone: its MJCF with the robot's and the effector's
    config applied and its inertials derived, as :func:`scene_spec` does, without the
    workcell; its masses and inertias are the scene's."""
    robot = kinds.robot(cfg.robot_kind)
    spec = merge_models([robot_xml(cfg.robot_kind, models)], cfg.robot_kind,
                        attach=mounts(cfg, models))  # fmt: skip
    apply_options(spec, cfg)
    robot.apply(spec, cfg)
    kinds.effector(cfg.effector_kind).apply(spec, cfg)
    robot.apply_inertials(spec, cfg)
    return spec


def robot_model(cfg: SceneConfig, models: str | Path | None = None) -> mujoco.MjModel:
    """:func:`robot_spec` compiled."""
    return robot_spec(cfg, models).compile()


def compile_with_home(spec: mujoco.MjSpec, cfg: SceneConfig) -> mujoco.MjModel:
    """Set the `home` keyframe (qpos0 for the joints it does not name) and compile."""
    model0 = spec.compile()
    qpos = model0.qpos0.copy()
    for joint_name, value in home_joint_positions(cfg).items():
        qpos[model0.joint(joint_name).qposadr[0]] = value
    key = spec.key("home")
    key.qpos = qpos
    ctrl = home_ctrl(cfg)
    bonds = model0.nu - len(ctrl)  # adhesion of bonded pots: off until loaded
    key.ctrl = ctrl + [0.0] * bonds
    return spec.compile()


def home_joint_positions(cfg: SceneConfig) -> dict[str, float]:
    """The `home` keyframe (power-on pose) by joint, from the robot, effector and workcell."""
    return {
        **kinds.robot(cfg.robot_kind).home_joints(cfg),
        **kinds.effector(cfg.effector_kind).home_joints(cfg),
        **kinds.workcell(cfg.workcell_kind).home_joints(cfg),
    }


def home_ctrl(cfg: SceneConfig) -> list[float]:
    """Actuator commands of the `home` keyframe: the robot's motors, then the effector's."""
    return kinds.robot(cfg.robot_kind).home_ctrl(cfg) + kinds.effector(cfg.effector_kind).home_ctrl(
        cfg
    )


def apply_options(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    opt = spec.option
    opt.timestep = cfg.timestep_s
    opt.impratio = cfg.impratio
    opt.iterations = cfg.solver_iterations
    opt.tolerance = cfg.solver_tolerance
    opt.jacobian = {
        "auto": mujoco.mjtJacobian.mjJAC_AUTO,
        "dense": mujoco.mjtJacobian.mjJAC_DENSE,
        "sparse": mujoco.mjtJacobian.mjJAC_SPARSE,
    }[cfg.jacobian]
    apply_sleep(spec, cfg)


def apply_sleep(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """Whether resting bodies sleep (`cfg.sleep`, scenario `physics.sleep`) and below what
    speed (`cfg.sleep_tolerance_m_s`): the pot line's workcell applies it for whatever robot
    works the line (`workcells.conveyor_tube.apply`), the five-bar's scene with its solver."""
    opt = spec.option
    opt.sleep_tolerance = cfg.sleep_tolerance_m_s
    bit = int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    opt.enableflags = (opt.enableflags | bit) if cfg.sleep else (opt.enableflags & ~bit)
