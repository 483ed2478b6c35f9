"""A compiled-from-spec scene written as one MJCF file with its meshes (`transplanter
export`): any robot with its effector attached at its mount and the job's workcell. Generic:
it names no kind; a kind's scene module passes its spec, its models folder and the mount."""

from __future__ import annotations

from pathlib import Path

import mujoco

__all__ = ["effector_classes_renamed", "export_spec", "models_dir"]


def models_dir() -> Path:
    """The models folder: the checkout's `models/`, else the packaged one (a wheel)."""
    import transplanter

    here = Path(transplanter.__file__).resolve()
    for parent in here.parents:
        if (parent / "models").is_dir() and (parent / "models" / "__init__.py").is_file():
            return parent / "models"
    import models  # the packaged models (wheel)

    return Path(models.__file__).resolve().parent


def export_spec(
    spec: mujoco.MjSpec,
    out: str | Path,
    models: str | Path | None = None,
    mount: str | None = None,
) -> Path:
    """Write a scene's spec (a robot, its effector attached, the job's workcell) as one MJCF
    file, with the meshes it uses (from every model folder's `assets/`: the robot's, its
    effector's, the workcell's) in the `assets/` folder beside it (as the five-bar's
    `build.export_scene`); `mount`: the attached effector's root body, whose default
    classes are renamed where they clash with the robot's (`effector_classes_renamed`). Returns the
    XML's path. It loads in MjModel.from_xml_path and `python -m mujoco.viewer --mjcf
    OUT.xml`. MuJoCo's XML writer keeps 6 significant digits: the file's numbers match the
    built scene's to about 5e-6 relative."""
    import shutil

    from transplanter import fileio

    root = Path(models) if models is not None else models_dir()
    target = fileio.check_output(out, ".xml")
    import warnings

    with warnings.catch_warnings():  # the effector's clashing classes are renamed below
        if mount is not None:
            warnings.filterwarnings("ignore", "Attaching a spec with an empty prefix")
        xml = spec.to_xml()
    if mount is not None:
        xml = effector_classes_renamed(xml, mount)
    # the meshes into the spec's meshdir, the textures' pictures into its texturedir
    for where, files in (
        (spec.meshdir, {Path(m.file).name for m in spec.meshes if m.file}),
        (spec.texturedir, {Path(t.file).name for t in spec.textures if t.file}),
    ):
        if not files:
            continue
        assets = target.parent / where
        assets.mkdir(exist_ok=True)
        for folder in sorted(root.rglob("assets")):
            for item in sorted(folder.iterdir()):
                if item.name in files and not (assets / item.name).exists():
                    shutil.copyfile(item, assets / item.name)
    fileio.write_text_atomic(target, xml)
    return target


def effector_classes_renamed(xml: str, mount: str) -> str:
    """The MJCF of a scene whose effector was attached without a prefix, its default classes
    that share a name with the robot's (Menagerie's `visual` and `collision`: an MjSpec allows
    it, an MJCF file does not) renamed `<effector class>_<name>`, and so are the references to
    them in the effector's bodies (each element keeps its own class)."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(xml)
    top = root.find("default")
    mount_body = root.find(f".//body[@name='{mount}']")
    if top is None or mount_body is None:
        return xml
    own = mount_body.get("childclass")
    effector = next((d for d in top.iter("default") if d.get("class") == own), None)
    if effector is None:
        return xml
    inside = {id(d) for d in effector.iter("default")}
    outside = {d.get("class") for d in top.iter("default") if id(d) not in inside}
    renamed = {}
    for d in effector.iter("default"):
        name = d.get("class")
        if d is not effector and name in outside:
            renamed[name] = f"{own}_{name}"
            d.set("class", renamed[name])
    if not renamed:
        return xml
    for element in mount_body.iter():
        for attr in ("class", "childclass"):
            if element.get(attr) in renamed:
                element.set(attr, renamed[element.get(attr)])
    ET.indent(root)
    return ET.tostring(root, encoding="unicode") + "\n"
