"""Write the plug_trays workcell: models/workcells/plug_trays/plug_trays.xml (the 128-cell tray's
frame and cell walls as boxes, from TrayGeometry()) and its one asset, assets/peat.png (the
substrate's grain, a seeded noise texture).

Run: .venv/bin/python scripts/make_plug_trays_model.py          (rewrites the files)
     .venv/bin/python scripts/make_plug_trays_model.py --check  (exit status 1 if stale)
"""

from __future__ import annotations

import io
import sys
from pathlib import Path

import numpy as np
from PIL import Image

from transplanter.scene.plug_tray import TrayGeometry

FOLDER = Path(__file__).resolve().parent.parent / "models" / "workcells" / "plug_trays"


def _f(x_mm: float) -> str:
    """mm -> m, written short."""
    return f"{x_mm / 1000:.4f}".rstrip("0").rstrip(".") or "0"


def _box(name: str, cx: float, cy: float, hx: float, hy: float, hz: float, cz: float) -> str:
    return (
        f'      <geom name="{name}" class="tray" size="{_f(hx)} {_f(hy)} {_f(hz)}" '
        f'pos="{_f(cx)} {_f(cy)} {_f(cz)}"/>'
    )


def tray_xml(g: TrayGeometry) -> str:
    half_x, half_y = g.length_mm / 2, g.width_mm / 2
    gx = g.cols * g.pitch_mm / 2 - (g.pitch_mm - g.opening_mm) / 2  # outermost opening edge
    gy = g.rows * g.pitch_mm / 2 - (g.pitch_mm - g.opening_mm) / 2
    wall = (g.pitch_mm - g.opening_mm) / 2
    hz, cz = g.depth_mm / 2, -g.depth_mm / 2
    lines = []
    # the rim: the outer walls from the outermost openings to the tray's edge
    rx, ry = (half_x - gx) / 2, (half_y - gy) / 2
    lines.append(_box("rim_left", -(gx + rx), 0, rx, half_y, hz, cz))
    lines.append(_box("rim_right", gx + rx, 0, rx, half_y, hz, cz))
    lines.append(_box("rim_top", 0, gy + ry, gx, ry, hz, cz))
    lines.append(_box("rim_bottom", 0, -(gy + ry), gx, ry, hz, cz))
    for k in range(1, g.cols):
        x = (k - g.cols / 2) * g.pitch_mm
        lines.append(_box(f"wall_x{k}", x, 0, wall, gy, hz, cz))
    for k in range(1, g.rows):
        y = (g.rows / 2 - k) * g.pitch_mm
        lines.append(_box(f"wall_y{k}", 0, y, gx, wall, hz, cz))
    lines.append(_box("bottom", 0, 0, gx, gy, 1.0, -g.depth_mm + 1.0))
    walls = "\n".join(lines)
    return f"""<!--
  The plug_trays workcell: one 128-cell plug tray (seed 002, Zhao et al. 2022: 566 x 286 mm,
  8 x 16 cells, 30 x 30 mm openings, 42 mm deep) lying on the imaging station. Written by
  scripts/make_plug_trays_model.py from transplanter.scene.plug_tray.TrayGeometry(); do not
  edit by hand. Described in README.md beside this file.

  Tray frame: origin at the centre of the tray's top face (the top of the walls), x along the
  length (16 columns), y along the width (8 rows), z up; the tray's body stands on the station
  at z = 0. The walls are vertical boxes {g.pitch_mm - g.opening_mm:g} mm wide (the pitch of
  {g.pitch_mm:g} mm is an estimate): the cells' taper to {g.bottom_opening_mm:g} mm at the bottom
  is not modelled (the substrate hides it from above). transplanter.scene.tray_camera adds the
  substrate, the seedlings' leaves and the specks of a drawn tray, and tilts and shifts the tray.
-->
<mujoco model="plug_trays">
  <compiler angle="radian" meshdir="assets" texturedir="assets" autolimits="true"/>

  <asset>
    <texture name="peat" type="2d" file="peat.png"/>
    <material name="substrate" texture="peat" texrepeat="1 1" texuniform="false"
              rgba="0.42 0.30 0.19 1" specular="0" shininess="0"/>
    <material name="tray_plastic" rgba="0.80 0.80 0.78 1" specular="0.05" shininess="0.1"/>
  </asset>

  <default>
    <default class="tray">
      <geom type="box" material="tray_plastic" contype="1" conaffinity="1"/>
    </default>
    <default class="plant">
      <geom contype="0" conaffinity="0" group="1" mass="0.0001"/>
    </default>
  </default>

  <worldbody>
    <body name="tray" pos="0 0 {_f(g.depth_mm)}">
{walls}
    </body>
  </worldbody>
</mujoco>
"""


def peat_png(seed: int = 2) -> bytes:
    """Grey grain (the material's colour tints it): blurred noise with darker crumbs."""
    rng = np.random.default_rng(seed)
    n = 128
    noise = rng.normal(0.0, 1.0, (n, n))
    k = np.fft.fftfreq(n)
    kk = np.sqrt(k[:, None] ** 2 + k[None, :] ** 2)
    smooth = np.real(np.fft.ifft2(np.fft.fft2(noise) * np.exp(-((kk / 0.12) ** 2))))
    smooth = (smooth - smooth.mean()) / smooth.std()
    crumbs = rng.uniform(size=(n, n)) < 0.03
    grey = np.clip(0.78 + 0.12 * smooth - 0.25 * crumbs, 0.3, 1.0)
    image = Image.fromarray((grey * 255).astype(np.uint8), mode="L").convert("RGB")
    out = io.BytesIO()
    image.save(out, format="PNG", optimize=True)
    return out.getvalue()


def main(argv: list[str]) -> int:
    files = {
        FOLDER / "plug_trays.xml": tray_xml(TrayGeometry()).encode(),
        FOLDER / "assets" / "peat.png": peat_png(),
    }
    if "--check" in argv:
        stale = [p for p, data in files.items() if not p.exists() or p.read_bytes() != data]
        for p in stale:
            print(f"stale: {p}")
        return 1 if stale else 0
    for path, data in files.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
