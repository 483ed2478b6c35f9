"""Write SceneConfig()'s numbers into the robot's, its effector's and the workcell's MJCF files:
models/fivebar/fivebar.xml, models/effectors/parallel_jaw/parallel_jaw.xml and
models/workcells/conveyor_tube/conveyor_tube.xml.

Run: .venv/bin/python scripts/make_models.py          (rewrites the files in place)
     .venv/bin/python scripts/make_models.py --check  (exit status 1 if they are stale)

The XML files are edited by hand for their structure (bodies, shapes, classes, materials);
this script only rewrites the attributes that follow from transplanter.scene.SceneConfig,
with the very functions build_scene uses: it assembles the robot and the workcell into one
MjSpec, applies SceneConfig() (scene_spec: options, arm, drives, drop tube, conveyor), derives
the arm's inertials and the home keyframe (compile_with_home), and writes the resulting values
back into the attributes listed by robot_values and workcell_values (and the block of tube
walls), with repr() precision so that the files assemble to exactly the model build_scene makes
from the default config. tests/test_models.py checks that the files are up to date.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import mujoco

from transplanter.scene.build import (
    compile_with_home,
    effector_xml,
    robot_xml,
    scene_spec,
    workcell_xml,
)
from transplanter.scene.config import SceneConfig
from transplanter.scene.robots.fivebar import INERTIAL_BODIES, MOUNT

EFFECTOR_BODIES = ("gripper", "jaw_left", "jaw_right")
"""The bodies of INERTIAL_BODIES drawn in the effector's file; the others are the robot's."""
ARM_BODIES = tuple(b for b in INERTIAL_BODIES if b not in EFFECTOR_BODIES)
ROBOT_JOINTS = ("z", "theta1", "phi1", "theta2", "phi2")
EFFECTOR_JOINTS = ("wrist", "jaw_left", "jaw_right")
ROBOT_ACTUATORS = 3  # the robot's motors come first, the effector's servos next

MODELS = Path(__file__).resolve().parent.parent / "models"
JACOBIAN = {
    mujoco.mjtJacobian.mjJAC_AUTO: "auto",
    mujoco.mjtJacobian.mjJAC_DENSE: "dense",
    mujoco.mjtJacobian.mjJAC_SPARSE: "sparse",
}


def fmt(*values) -> str:
    """Numbers as MJCF text: shortest repr that parses back to the same double."""
    out = []
    for v in values:
        text = repr(float(v))
        out.append(text[:-2] if text.endswith(".0") else text)
    return " ".join(out)


def _home(spec: mujoco.MjSpec, model: mujoco.MjModel, joints) -> str:
    """The home keyframe's qpos of these (single-valued) joints, in their order."""
    qpos = list(spec.key("home").qpos)
    return fmt(*(qpos[model.joint(j).qposadr[0]] for j in joints))


def _inertials(spec: mujoco.MjSpec, bodies, with_pos: bool = True) -> list:
    out = []
    for body in bodies:
        b = spec.body(body)
        out.append(("body", body, {"pos": fmt(*b.pos)} if with_pos else {}))
        out.append(("inertial", None, {
            "pos": fmt(*b.ipos), "quat": fmt(*b.iquat), "mass": fmt(b.mass),
            "diaginertia": fmt(*b.inertia),
        }))  # fmt: skip
    return out


def effector_values(
    spec: mujoco.MjSpec, model: mujoco.MjModel
) -> list[tuple[str, str | None, dict[str, str]]]:
    """(tag, name, {attribute: text}) for models/effectors/parallel_jaw/parallel_jaw.xml (its
    root `gripper` sits at the robot's mount frame: no pos of its own)."""
    out = _inertials(spec, EFFECTOR_BODIES[:1], with_pos=False)
    out += _inertials(spec, EFFECTOR_BODIES[1:])
    for jaw in ("jaw_left", "jaw_right"):
        j = spec.joint(jaw)
        out.append(("joint", jaw, {"range": fmt(*j.range), "damping": fmt(j.damping[0])}))
    for geom in ("palm", "palm_visual", "side_plate_left", "side_plate_right"):
        g = spec.geom(geom)
        out.append(("geom", geom, {"size": fmt(*g.size), "pos": fmt(*g.pos)}))
    column = spec.geom("column")
    out.append(("geom", "column", {"size": fmt(*column.size[:2]), "pos": fmt(*column.pos)}))
    out.append(("site", "grip_center", {"pos": fmt(*spec.site("grip_center").pos)}))
    grip = spec.actuator("gripper")
    out.append(("position", "gripper", {
        "kp": fmt(grip.gainprm[0]), "forcerange": fmt(*grip.forcerange),
        "ctrlrange": fmt(*grip.ctrlrange),
    }))  # fmt: skip
    wrist = spec.actuator("wrist")
    out.append(("position", "wrist", {
        "kp": fmt(wrist.gainprm[0]), "forcerange": fmt(*wrist.forcerange),
    }))  # fmt: skip
    ctrl = list(spec.key("home").ctrl)[ROBOT_ACTUATORS : ROBOT_ACTUATORS + 2]
    out.append(("key", "home", {"qpos": _home(spec, model, EFFECTOR_JOINTS), "ctrl": fmt(*ctrl)}))
    return out


def robot_values(
    spec: mujoco.MjSpec, model: mujoco.MjModel
) -> list[tuple[str, str | None, dict[str, str]]]:
    """(tag, name, {attribute: text}) for models/fivebar/fivebar.xml. Unnamed tags (option, flag,
    inertial) are found as the first such tag after the previous entry's tag."""
    opt = spec.option
    sleep = opt.enableflags & int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    out = [
        ("option", None, {
            "timestep": fmt(opt.timestep), "impratio": fmt(opt.impratio),
            "iterations": str(opt.iterations), "tolerance": fmt(opt.tolerance),
            "jacobian": JACOBIAN[opt.jacobian], "sleep_tolerance": fmt(opt.sleep_tolerance),
        }),
        ("flag", None, {"sleep": "enable" if sleep else "disable"}),
    ]  # fmt: skip
    out += _inertials(spec, ARM_BODIES)
    out.append(("frame", MOUNT, {"pos": fmt(*spec.frame(MOUNT).pos)}))
    for joint in ("z", "theta1", "theta2"):
        j = spec.joint(joint)
        values = {"range": fmt(*j.range), "damping": fmt(j.damping[0])}
        if joint == "z":  # the lead screw's friction
            values["frictionloss"] = fmt(j.frictionloss)
        out.append(("joint", joint, {**values, "armature": fmt(j.armature)}))
    out.append(("geom", "platform", {"mass": fmt(spec.geom("platform").mass)}))
    for geom in ("motor1", "motor2"):
        out.append(("geom", geom, {"pos": fmt(*spec.geom(geom).pos)}))
    for geom in ("link1", "link2", "passive1", "passive2"):
        g = spec.geom(geom)
        out.append(("geom", geom, {"fromto": fmt(*g.fromto), "mass": fmt(g.mass)}))
    for site in ("c1", "c2"):
        out.append(("site", site, {"pos": fmt(*spec.site(site).pos)}))
    for act in ("theta1", "theta2", "z"):
        a = spec.actuator(act)
        out.append(("general", act, {
            "gear": fmt(a.gear[0]), "gainprm": fmt(a.gainprm[0]), "biasprm": fmt(*a.biasprm[:3]),
        }))  # fmt: skip
    trip = spec.numeric("limit_switch_trip")
    out.append(("numeric", "limit_switch_trip", {"data": fmt(*trip.data)}))
    ctrl = list(spec.key("home").ctrl)[:ROBOT_ACTUATORS]
    out.append(("key", "home", {"qpos": _home(spec, model, ROBOT_JOINTS), "ctrl": fmt(*ctrl)}))
    return out


def workcell_values(spec: mujoco.MjSpec) -> list[tuple[str, str | None, dict[str, str]]]:
    """(tag, name, {attribute: text}) for models/workcells/conveyor_tube/conveyor_tube.xml."""
    table = spec.geom("belt_table")
    return [
        ("geom", "belt_table", {"size": fmt(*table.size), "pos": fmt(*table.pos)}),
        ("body", "conveyor", {}),
        (
            "joint",
            "conveyor",
            {
                "frictionloss": fmt(spec.joint("conveyor").frictionloss),
                "stiffness": fmt(spec.joint("conveyor").stiffness[0]),
                "damping": fmt(spec.joint("conveyor").damping[0]),
            },
        ),  # fmt: skip
        ("inertial", None, {"mass": fmt(spec.body("conveyor").mass)}),
        ("body", "drop_tube", {"pos": fmt(*spec.body("drop_tube").pos)}),
        ("geom", "planting_plate", {"pos": fmt(*spec.geom("planting_plate").pos)}),
    ]


def tube_walls(spec: mujoco.MjSpec) -> str:
    """The drop tube's wall geoms, one line each (class static carries their collision bits)."""
    lines = []
    for geom in spec.body("drop_tube").geoms:
        if geom.name.startswith("tube_wall_"):
            lines.append(
                f'      <geom name="{geom.name}" class="static" type="box" '
                f'size="{fmt(*geom.size)}" pos="{fmt(*geom.pos)}" quat="{fmt(*geom.quat)}"/>\n'
            )
    return "".join(lines)


def _tag_at(text: str, tag: str, name: str | None, start: int) -> re.Match:
    name_part = rf'[^>]*?\bname="{re.escape(name)}"' if name is not None else ""
    match = re.compile(rf"<{tag}\b{name_part}[^>]*?/?>", re.S).search(text, start)
    if match is None:
        raise ValueError(f"no <{tag} name={name!r}> in the model file")
    return match


def set_attributes(text: str, entries) -> str:
    """Replace (or add) the attributes of each entry's tag, in the order of the entries."""
    position = 0
    for tag, name, attributes in entries:
        match = _tag_at(text, tag, name, position if name is None else 0)
        element = match.group(0)
        for attr, value in attributes.items():
            pattern = re.compile(rf'(\s){attr}="[^"]*"')
            if pattern.search(element):
                element = pattern.sub(lambda m, a=attr, v=value: f'{m.group(1)}{a}="{v}"', element)
            else:
                end = -2 if element.endswith("/>") else -1
                element = f'{element[:end].rstrip()} {attr}="{value}"{element[end:]}'
        text = text[: match.start()] + element + text[match.end() :]
        position = match.start() + len(element)
    return text


def set_tube_walls(text: str, walls: str) -> str:
    begin = re.search(r"[ \t]*<!-- BEGIN tube walls[^\n]*\n", text)
    end = re.search(r"[ \t]*<!-- END tube walls -->", text)
    if begin is None or end is None:
        raise ValueError("the workcell's MJCF lacks the BEGIN/END tube walls comments")
    return text[: begin.end()] + walls + text[end.start() :]


def generate(models: Path = MODELS) -> dict[str, str]:
    """The up-to-date text of each model file (path relative to `models` -> text), from the
    files in `models`."""
    cfg = SceneConfig()
    spec = scene_spec(cfg, models)
    model = compile_with_home(spec, cfg)
    robot, workcell = robot_xml(models=models), workcell_xml(models=models)
    effector = effector_xml(cfg.effector_kind, models)
    robot_text = set_attributes(robot.read_text(), robot_values(spec, model))
    effector_text = set_attributes(effector.read_text(), effector_values(spec, model))
    workcell_text = set_attributes(workcell.read_text(), workcell_values(spec))
    return {
        robot.relative_to(models).as_posix(): robot_text,
        effector.relative_to(models).as_posix(): effector_text,
        workcell.relative_to(models).as_posix(): set_tube_walls(workcell_text, tube_walls(spec)),
    }


def main(argv: list[str]) -> int:
    stale = []
    for name, text in generate().items():
        path = MODELS / name
        if path.read_text() != text:
            stale.append(name)
            if "--check" not in argv:
                path.write_text(text)
                print(f"wrote {path}")
    if "--check" in argv and stale:
        print(f"stale: {', '.join(stale)} (run scripts/make_models.py)")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
