"""Write the numbers of the pool_to_belt workcell into models/workcells/pool_to_belt/
pool_to_belt.xml from PoolToBeltConfig() (the same `apply` the scene uses: the lane, sensor 1,
the belt) and draw its one asset, assets/belt_rubber.png (the belt's ribs).

The XML's structure (bodies, geoms, classes, materials, comments) is edited by hand; this
script only rewrites the pos, quat and size of the bodies and geoms that `apply` sets, the
belt's slide range and its drive's gain, bias and force range.

Run: .venv/bin/python scripts/make_pool_to_belt_model.py          (rewrites the files)
     .venv/bin/python scripts/make_pool_to_belt_model.py --check  (exit status 1 if stale)
"""

from __future__ import annotations

import io
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
from PIL import Image

from transplanter.scene.workcells import pool_to_belt

FOLDER = Path(__file__).resolve().parent.parent / "models" / "workcells" / "pool_to_belt"
XML = FOLDER / "pool_to_belt.xml"
PNG = FOLDER / "assets" / "belt_rubber.png"


def _num(values) -> str:
    return " ".join(f"{(float(v) if abs(v) > 1e-12 else 0.0):.6g}" for v in values)


def belt_png() -> bytes:
    """A dark rubber belt with a cross rib every 8 pixels (64 x 16, grey)."""
    img = np.full((16, 64), 40, dtype=np.uint8)
    img[:, ::8] = 70
    img[:, 1::8] = 55
    out = io.BytesIO()
    Image.fromarray(img, mode="L").convert("RGB").save(out, format="PNG", optimize=False)
    return out.getvalue()


def model_xml(text: str) -> str:
    """The XML text with the numbers of PoolToBeltConfig() written in."""
    spec = mujoco.MjSpec.from_string(text, assets={"belt_rubber.png": belt_png()})
    cfg = pool_to_belt.PoolToBeltConfig()
    pool_to_belt.apply(spec, cfg)
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    root = ET.fromstring(text, parser=parser)
    for el in root.iter("body"):
        if el.get("name") in {"pool", "station_sensor", "belt_frame"}:
            body = spec.body(el.get("name"))
            el.set("pos", _num(body.pos))
            el.set("quat", _num(body.quat))
    for el in root.iter("geom"):
        name = el.get("name")
        if name is None or name == "ground":
            continue
        geom = spec.geom(name)
        size = geom.size if el.get("type") not in {"cylinder"} else geom.size[:2]
        el.set("size", _num(size))
        el.set("pos", _num(geom.pos))
        if any(abs(q - r) > 1e-12 for q, r in zip(geom.quat, (1, 0, 0, 0), strict=True)):
            el.set("quat", _num(geom.quat))
        if el.get("class") != "pool_visual":
            el.set("friction", _num(geom.friction))
    for el in root.iter("site"):
        site = spec.site(el.get("name"))
        el.set("quat", _num(site.quat))
    (joint,) = root.iter("joint")
    joint.set("range", _num(spec.joint("belt").range))
    (act,) = root.iter("general")
    a = spec.actuator("belt")
    act.set("gainprm", _num(a.gainprm[:1]))
    act.set("biasprm", _num(a.biasprm[:3]))
    act.set("forcerange", _num(a.forcerange))
    ET.indent(root, space="  ")
    head, _, _ = text.partition("<mujoco")
    return head + ET.tostring(root, encoding="unicode") + "\n"


def main(argv: list[str]) -> int:
    check = "--check" in argv
    text = XML.read_text()
    xml, png = model_xml(text), belt_png()
    stale = xml != text or not PNG.exists() or PNG.read_bytes() != png
    if check:
        if stale:
            print(f"{XML} or {PNG} is out of date: run scripts/make_pool_to_belt_model.py")
        return 1 if stale else 0
    PNG.parent.mkdir(exist_ok=True)
    XML.write_text(xml)
    PNG.write_bytes(png)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
