"""Write the fuzzy gripper's visual meshes into models/effectors/fuzzy_gripper/assets/
(re-runnable, deterministic: the same bytes every run).

Run:   .venv/bin/python scripts/make_fuzzy_gripper_meshes.py
Check: .venv/bin/python scripts/make_fuzzy_gripper_meshes.py --check  (exit status 1 if stale)

Visual only; the gripper's collision shapes (palm, pads) are MuJoCo primitives in
models/effectors/fuzzy_gripper/fuzzy_gripper.xml, and its fingers' beams are primitives too
(their length is a scenario key). Sizes in metres:
- fuzzy_gripper_sg90.stl: the SG90 micro servo (datasheet 22.2 x 11.8 x 22.7 mm, mounting
  tabs 32.2 mm across, 2.5 mm thick, 4.7 mm below the top), its output shaft along +z, offset
  5.9 mm along +x from the body's centre; origin at the body's bottom centre.
- fuzzy_gripper_hcsr04.stl: the HC-SR04 ultrasonic module (board 45 x 20 x 1.6 mm, two
  transducers 16 mm across, 12 mm tall, 26 mm apart), the board in the y-z plane and the
  transducers along +x; origin at the board's front face centre.
"""

import io
import sys
from pathlib import Path

import trimesh

ASSETS = (
    Path(__file__).resolve().parent.parent / "models" / "effectors" / "fuzzy_gripper" / "assets"
)


def sg90() -> trimesh.Trimesh:
    body = trimesh.creation.box(extents=[0.0222, 0.0118, 0.0227])
    body.apply_translation([0, 0, 0.0227 / 2])
    tabs = trimesh.creation.box(extents=[0.0322, 0.0118, 0.0025])
    tabs.apply_translation([0, 0, 0.0227 - 0.0047])
    boss = trimesh.creation.cylinder(radius=0.0059, height=0.004, sections=24)
    boss.apply_translation([0.0059, 0, 0.0227 + 0.002])
    shaft = trimesh.creation.cylinder(radius=0.0024, height=0.003, sections=16)
    shaft.apply_translation([0.0059, 0, 0.0227 + 0.004 + 0.0015])
    return trimesh.util.concatenate([body, tabs, boss, shaft])


def hcsr04() -> trimesh.Trimesh:
    board = trimesh.creation.box(extents=[0.0016, 0.045, 0.020])
    board.apply_translation([-0.0008, 0, 0])
    parts = [board]
    for y in (-0.013, 0.013):
        can = trimesh.creation.cylinder(radius=0.008, height=0.012, sections=32)
        can.apply_transform(trimesh.transformations.rotation_matrix(1.5707963267948966, [0, 1, 0]))
        can.apply_translation([0.006, y, 0])
        parts.append(can)
    return trimesh.util.concatenate(parts)


def meshes() -> dict[Path, trimesh.Trimesh]:
    """Every mesh by the path it is written to."""
    return {
        ASSETS / "fuzzy_gripper_sg90.stl": sg90(),
        ASSETS / "fuzzy_gripper_hcsr04.stl": hcsr04(),
    }


def stl_bytes(mesh: trimesh.Trimesh) -> bytes:
    out = io.BytesIO()
    mesh.export(out, file_type="stl")
    return out.getvalue()


def main(argv: list[str]) -> int:
    files = {path: stl_bytes(mesh) for path, mesh in meshes().items()}
    if "--check" in argv:
        stale = [p for p, data in files.items() if not p.exists() or p.read_bytes() != data]
        for p in stale:
            print(f"stale: {p}")
        return 1 if stale else 0
    for path, data in files.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
        print(f"wrote {path} ({len(data)} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
