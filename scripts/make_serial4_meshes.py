"""Write the visual meshes of the serial 4-DOF servo arm into models/serial4/assets/
(re-runnable, deterministic: the same bytes every run).

Run: .venv/bin/python scripts/make_serial4_meshes.py

Visual only; the arm's collision shapes are MuJoCo primitives in models/serial4/serial4.xml.
Sizes in metres:
- serial4_base.stl: the base housing, a round foot 90 mm across and 8 mm tall with a column
  36 mm across up to the base servo's turntable, 50 mm tall in all; origin at the foot's
  bottom centre.
- serial4_servo.stl: a standard servo body (MG996R class: 40.7 x 19.7 x 36.8 mm with its
  mounting tabs 54 mm across), centred, its output shaft along +z.
The gripper is an effector of its own: scripts/make_fuzzy_gripper_meshes.py.
"""

from pathlib import Path

import trimesh

ASSETS = Path(__file__).resolve().parent.parent / "models" / "serial4" / "assets"


def base() -> trimesh.Trimesh:
    foot = trimesh.creation.cylinder(radius=0.045, height=0.008, sections=48)
    foot.apply_translation([0, 0, 0.004])
    column = trimesh.creation.cylinder(radius=0.018, height=0.042, sections=32)
    column.apply_translation([0, 0, 0.008 + 0.021])
    return trimesh.util.concatenate([foot, column])


def servo() -> trimesh.Trimesh:
    body = trimesh.creation.box(extents=[0.0407, 0.0197, 0.0368])
    tabs = trimesh.creation.box(extents=[0.054, 0.0197, 0.0025])
    tabs.apply_translation([0, 0, 0.0368 / 2 - 0.009])
    shaft = trimesh.creation.cylinder(radius=0.003, height=0.006, sections=16)
    shaft.apply_translation([0.01, 0, 0.0368 / 2 + 0.003])
    return trimesh.util.concatenate([body, tabs, shaft])


def meshes() -> dict[Path, trimesh.Trimesh]:
    """Every mesh by the path it is written to."""
    return {
        ASSETS / "serial4_base.stl": base(),
        ASSETS / "serial4_servo.stl": servo(),
    }


def main() -> None:
    for path, mesh in meshes().items():
        path.parent.mkdir(parents=True, exist_ok=True)
        mesh.export(path)
        print(f"wrote {path} ({len(mesh.faces)} faces)")


if __name__ == "__main__":
    main()
