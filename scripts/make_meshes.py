"""Write the visual meshes of the twin into the assets/ folders of models/ (re-runnable,
deterministic): the parallel jaws' to models/effectors/parallel_jaw/assets/, the workcell's to
models/workcells/conveyor_tube/assets/.

Run: .venv/bin/python scripts/make_meshes.py

Meshes are visual only; every collision shape is a MuJoCo primitive (the models' XML and
transplanter.scene.build). Sizes are the design defaults (docs/sources.md) in metres, and
the meshes are drawn at that size: build_scene does not scale them (a pot's collision
cylinder follows its drawn size, its mesh stays the nominal pot; the stem is a capsule).
Workcell conveyor_tube (the pots build_scene adds on its conveyor, its drop tube):
- paper_pot.stl: tapered paper pot, 35 mm rim, 32 mm base, 52 mm tall, base at z=0.
- seedling_leaf.stl: one leaf blade that starts at the origin and extends along +x (45 mm),
  curving up.
- funnel.stl: funnel (60 mm top dia at z=0, 42 mm throat 20 mm lower) and the tube below it,
  down to 160 mm below the funnel top (the collision walls are boxes: drop_tube_boxes).
Robot fivebar:
- jaw.stl: one jaw plate, 3 x 20 x 45 mm, centred, with a ribbed inner face.
Robot delta (models/delta/assets/):
- delta_base.stl: the static platform, a hexagonal plate 260 mm in circumradius, 20 mm thick,
  its underside at z=0 (the base frame's origin on the plate's underside, at its centre).
- delta_platform.stl: the moving platform, a hexagonal plate 75 mm in circumradius, 20 mm
  thick, centred on the origin, with a 30 mm boss below it for the end effector.
"""

from pathlib import Path

import numpy as np
import trimesh

MODELS = Path(__file__).resolve().parent.parent / "models"
EFFECTOR_ASSETS = MODELS / "effectors" / "parallel_jaw" / "assets"
DELTA_ASSETS = MODELS / "delta" / "assets"
WORKCELL_ASSETS = MODELS / "workcells" / "conveyor_tube" / "assets"


def paper_pot() -> trimesh.Trimesh:
    """Slightly tapered cylinder, top rim 35 mm, bottom 32 mm, 52 mm tall, base at z=0."""
    sections = 32
    angles = np.linspace(0.0, 2 * np.pi, sections, endpoint=False)
    bottom = np.c_[0.016 * np.cos(angles), 0.016 * np.sin(angles), np.zeros(sections)]
    top = np.c_[0.0175 * np.cos(angles), 0.0175 * np.sin(angles), np.full(sections, 0.052)]
    vertices = np.vstack([bottom, top, [[0, 0, 0]], [[0, 0, 0.052]]])
    faces = []
    for i in range(sections):
        j = (i + 1) % sections
        faces += [[i, j, sections + j], [i, sections + j, sections + i]]
        faces += [[2 * sections, j, i], [2 * sections + 1, sections + i, sections + j]]
    return trimesh.Trimesh(vertices, np.array(faces), process=True)


def seedling_leaf() -> trimesh.Trimesh:
    """Thin leaf blade along +x from the origin, 45 mm long, 18 mm wide, bending upwards."""
    n = 16
    s = np.linspace(0.0, 1.0, n)
    half_width = 0.009 * np.sin(np.pi * s) + 1e-4
    x = 0.045 * s
    z = 0.015 * s**2
    left = np.c_[x, half_width, z]
    right = np.c_[x, -half_width, z]
    vertices = np.vstack([left, right])
    faces = []
    for i in range(n - 1):
        faces += [[i, n + i, i + 1], [i + 1, n + i, n + i + 1]]
    faces = np.array(faces)
    faces = np.vstack([faces, faces[:, ::-1]])  # two-sided
    return trimesh.Trimesh(vertices, faces, process=True)


def jaw() -> trimesh.Trimesh:
    plate = trimesh.creation.box(extents=[0.003, 0.020, 0.045])
    ribs = [
        trimesh.creation.box(extents=[0.0008, 0.020, 0.002]).apply_translation([0, 0, z])
        for z in np.linspace(-0.018, 0.018, 6)
    ]
    return trimesh.util.concatenate([plate, *ribs])


def funnel() -> trimesh.Trimesh:
    """Open funnel + tube as a thin shell of revolution (top of funnel at z=0)."""
    profile_outer = np.array(
        [[0.030, 0.0], [0.021, -0.020], [0.021, -0.160]]
    )  # (radius, z) along the wall
    thickness = 0.0015
    profile = np.vstack([profile_outer, (profile_outer + [thickness, 0])[::-1]])
    return trimesh.creation.revolve(profile, sections=48)


def delta_base() -> trimesh.Trimesh:
    """Hexagonal plate, circumradius 260 mm, 20 mm thick, underside at z=0."""
    plate = trimesh.creation.cylinder(radius=0.260, height=0.020, sections=6)
    return plate.apply_translation([0, 0, 0.010])


def delta_platform() -> trimesh.Trimesh:
    """Hexagonal plate, circumradius 75 mm, 20 mm thick, centred, a 30 mm boss below."""
    plate = trimesh.creation.cylinder(radius=0.075, height=0.020, sections=6)
    boss = trimesh.creation.cylinder(radius=0.020, height=0.030, sections=24)
    boss.apply_translation([0, 0, -0.025])
    return trimesh.util.concatenate([plate, boss])


def meshes() -> dict[Path, trimesh.Trimesh]:
    """Every mesh by the path it is written to."""
    return {
        WORKCELL_ASSETS / "paper_pot.stl": paper_pot(),
        WORKCELL_ASSETS / "seedling_leaf.stl": seedling_leaf(),
        EFFECTOR_ASSETS / "jaw.stl": jaw(),
        WORKCELL_ASSETS / "funnel.stl": funnel(),
        DELTA_ASSETS / "delta_base.stl": delta_base(),
        DELTA_ASSETS / "delta_platform.stl": delta_platform(),
    }


def main() -> None:
    for path, mesh in meshes().items():
        path.parent.mkdir(parents=True, exist_ok=True)
        mesh.export(path)
        print(f"wrote {path} ({len(mesh.faces)} faces)")


if __name__ == "__main__":
    main()
