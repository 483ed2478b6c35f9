"""The models as MuJoCo Menagerie folders, after Menagerie's test/model_dir_test.py and
test/model_test.py: every robot (models/<robot>/) and workcell (models/workcells/<workcell>/)
has README.md, CHANGELOG.md, LICENSE, its MJCF <folder>.xml and assets/ holding exactly the
meshes its XML names; a robot also has scene.xml (the robot in a minimal world), its XML holds
the robot only, with a `home` keyframe and default classes for visual and collision geoms;
every scene.xml and workcell compiles and steps with noisy controls without a MuJoCo warning.
An effector (models/effectors/<effector>/) is held to a robot's rules, except that its
scene.xml may add the world it works in (a tray cell, a plug)."""

import warnings
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest

from conftest import ROOT
from transplanter.scene.build import ROBOT, WORKCELL, robot_xml, workcell_xml

MODELS = ROOT / "models"
SKIP = {"workcells", "effectors", "__pycache__"}
ROBOTS = sorted(p for p in MODELS.iterdir() if p.is_dir() and p.name not in SKIP)
WORKCELLS = sorted(p for p in (MODELS / "workcells").iterdir() if p.is_dir() and p.name not in SKIP)
EFFECTORS = sorted(p for p in (MODELS / "effectors").iterdir() if p.is_dir() and p.name not in SKIP)
FOLDERS = ROBOTS + WORKCELLS + EFFECTORS
TOOLED = ROBOTS + EFFECTORS  # a home keyframe, classes, a scene.xml
ids = [p.relative_to(MODELS).as_posix() for p in FOLDERS]


def main_xml(folder):
    return folder / f"{folder.name}.xml"


def load(path) -> mujoco.MjModel:
    """Compile a model file; any warning of MuJoCo's compiler fails the test."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return mujoco.MjModel.from_xml_path(str(path))


def test_the_scene_is_made_of_a_robot_and_a_workcell_from_these_folders():
    assert MODELS / ROBOT in ROBOTS
    assert MODELS / "workcells" / WORKCELL in WORKCELLS
    assert robot_xml(models=MODELS) == main_xml(MODELS / ROBOT)
    assert workcell_xml(models=MODELS) == main_xml(MODELS / "workcells" / WORKCELL)
    # nothing else at the top: the index README, the package marker and the folders
    files = {p.name for p in MODELS.iterdir() if p.is_file()}
    assert files == {"README.md", "__init__.py"}


def _named_files(folder) -> set[str]:
    """The mesh and texture files the folder's XML names."""
    spec = mujoco.MjSpec.from_file(str(main_xml(folder)))
    return {mesh.file for mesh in spec.meshes} | {t.file for t in spec.textures if t.file}


def _assets(folder) -> list:
    return sorted((folder / "assets").iterdir()) if (folder / "assets").is_dir() else []


@pytest.mark.parametrize("folder", FOLDERS, ids=ids)
def test_folder_has_the_menagerie_files(folder):
    expected = ["README.md", "CHANGELOG.md", "LICENSE", f"{folder.name}.xml", "scene.xml"]
    if _named_files(folder):  # assets/ holds its meshes (the five-bar's are its effector's)
        expected.append("assets")
    missing = [name for name in expected if not (folder / name).exists()]
    assert missing == []
    assert (folder / "LICENSE").read_text().startswith("MIT License")  # as pyproject.toml's
    assert folder.name in (folder / "README.md").read_text()


@pytest.mark.parametrize("folder", FOLDERS, ids=ids)
def test_assets_are_exactly_the_meshes_the_xml_names(folder):
    spec = mujoco.MjSpec.from_file(str(main_xml(folder)))
    assert spec.meshdir == "assets"
    assert _named_files(folder) == {p.name for p in _assets(folder)}


def test_asset_file_names_are_unique_across_folders():
    """The scene merges the folders' assets under one meshdir (and `transplanter export`
    writes them into one assets/ folder)."""
    names = [p.name for folder in FOLDERS for p in _assets(folder)]
    assert len(names) == len(set(names))


@pytest.mark.parametrize("robot", TOOLED, ids=[p.name for p in TOOLED])
def test_robot_has_a_home_keyframe_and_visual_and_collision_classes(robot):
    model = load(main_xml(robot))
    home = model.key("home").id
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, home)
    mujoco.mj_forward(model, data)
    assert np.all(np.isfinite(data.qacc))
    # every geom is in the visual or the collision class or a class nested in one of them
    # (named `visual` and `collision`, or `<part>_visual` and `<part>_collision` where the
    # file is merged into a robot's scene beside classes of those names: the parallel jaws)
    root = ET.parse(main_xml(robot)).getroot()
    under = {}
    for kind in ("visual", "collision"):
        names = {kind} | {c for c in (d.get("class") or "" for d in root.iter("default"))
                          if c.endswith(f"_{kind}")}  # fmt: skip
        tops = [d for d in root.iter("default") if d.get("class") in names]
        assert len(tops) <= 1 and (tops or kind == "collision")  # a robot may collide nowhere
        for top in tops:
            under.update({d.get("class"): kind for d in top.iter("default")})
    spec = mujoco.MjSpec.from_file(str(main_xml(robot)))
    strays = [g.name or g.meshname for g in spec.geoms if g.classname.name not in under]
    assert strays == []


@pytest.mark.parametrize("robot", ROBOTS, ids=[p.name for p in ROBOTS])
def test_robot_xml_holds_the_robot_only_and_scene_xml_includes_it(robot):
    """No world geoms, lights or cameras in the robot's XML: the world is scene.xml's (or a
    workcell's)."""
    spec = mujoco.MjSpec.from_file(str(main_xml(robot)))
    world = spec.worldbody
    assert (len(world.geoms), len(world.lights), len(world.cameras)) == (0, 0, 0)
    includes = [i.get("file") for i in ET.parse(robot / "scene.xml").getroot().iter("include")]
    assert includes == [f"{robot.name}.xml"]
    robot_alone, in_scene = load(main_xml(robot)), load(robot / "scene.xml")
    assert (in_scene.nbody, in_scene.nu, in_scene.nkey) == (
        robot_alone.nbody,
        robot_alone.nu,
        robot_alone.nkey,
    )


@pytest.mark.parametrize("workcell", WORKCELLS, ids=[p.name for p in WORKCELLS])
def test_a_workcells_scene_xml_includes_it_and_adds_only_static_drawings(workcell):
    """Every workcell folder has a scene.xml (Menagerie): its XML, plus what is only drawn."""
    includes = [i.get("file") for i in ET.parse(workcell / "scene.xml").getroot().iter("include")]
    assert includes == [f"{workcell.name}.xml"]
    alone, in_scene = load(main_xml(workcell)), load(workcell / "scene.xml")
    assert (in_scene.nbody, in_scene.nq, in_scene.nu) == (alone.nbody, alone.nq, alone.nu)


@pytest.mark.parametrize("effector", EFFECTORS, ids=[p.name for p in EFFECTORS])
def test_effector_xml_holds_the_effector_only_and_scene_xml_includes_it(effector):
    """No world geoms, lights or cameras in the effector's XML; its scene.xml includes it and
    keeps its joints, actuators and keyframe (what it adds is static)."""
    spec = mujoco.MjSpec.from_file(str(main_xml(effector)))
    world = spec.worldbody
    assert (len(world.geoms), len(world.lights), len(world.cameras)) == (0, 0, 0)
    includes = [i.get("file") for i in ET.parse(effector / "scene.xml").getroot().iter("include")]
    assert includes == [f"{effector.name}.xml"]
    alone, in_scene = load(main_xml(effector)), load(effector / "scene.xml")
    assert (in_scene.nq, in_scene.nu, in_scene.nkey) == (alone.nq, alone.nu, alone.nkey)


def step_noisy(model, seconds=1.0, seed=0):
    """Step from every keyframe (or qpos0 without one) with Gaussian noise on the controls
    (5 % of each limited actuator's range, else 0.05), as Menagerie's model test does."""
    rng = np.random.default_rng(seed)
    lo, hi = model.actuator_ctrlrange.T
    limited = model.actuator_ctrllimited.astype(bool)
    scale = np.where(limited, 0.05 * (hi - lo), 0.05)
    data = mujoco.MjData(model)
    for key in range(max(model.nkey, 1)):
        if model.nkey:
            mujoco.mj_resetDataKeyframe(model, data, key)
        else:
            mujoco.mj_resetData(model, data)
        base = data.ctrl.copy()
        for _ in range(int(seconds / model.opt.timestep)):
            data.ctrl[:] = base + scale * rng.standard_normal(model.nu)
            data.ctrl[limited] = np.clip(data.ctrl[limited], lo[limited], hi[limited])
            mujoco.mj_step(model, data)
        assert np.all(np.isfinite(data.qpos))
    return data


SCENES = [p / "scene.xml" for p in FOLDERS] + [main_xml(p) for p in WORKCELLS]


@pytest.mark.parametrize("xml", SCENES, ids=[p.relative_to(MODELS).as_posix() for p in SCENES])
def test_scene_steps_with_noisy_controls_without_warnings(xml):
    data = step_noisy(load(xml))
    warned = {mujoco.mjtWarning(i).name: int(n) for i, n in enumerate(data.warning.number) if n}
    assert warned == {}
