"""Write the plug-in claws' visual mesh into models/effectors/plug_claws/assets/
(re-runnable, deterministic).

Run: .venv/bin/python scripts/make_plug_claws_meshes.py

- plug_claw_blade.stl: one seedling claw, a flat tapered blade 45 mm long, its tip at the
  origin and its back along +z; 1 mm wide at the tip and 3 mm at the back (along y), 1 mm thick
  (along x, the side that presses the substrate). Visual only: the claw's collision shape is a
  capsule (models/effectors/plug_claws/plug_claws.xml).
"""

from pathlib import Path

import numpy as np
import trimesh

ASSETS = Path(__file__).resolve().parent.parent / "models" / "effectors" / "plug_claws" / "assets"


def claw_blade() -> trimesh.Trimesh:
    """Tapered blade: a convex hull of its tip and back rectangles (metres)."""
    length, tip_w, back_w, thick = 0.045, 0.001, 0.003, 0.001
    corners = []
    for z, w in ((0.0, tip_w), (length, back_w)):
        for sx in (-1, 1):
            for sy in (-1, 1):
                corners.append((sx * thick / 2, sy * w / 2, z))
    return trimesh.convex.convex_hull(np.array(corners))


def main() -> None:
    ASSETS.mkdir(parents=True, exist_ok=True)
    path = ASSETS / "plug_claw_blade.stl"
    claw_blade().export(path)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
