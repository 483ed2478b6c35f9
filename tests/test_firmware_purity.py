"""The firmware is pure numpy: importing it must not pull in MuJoCo (it should run on a
microcontroller's host side or real hardware without the physics engine)."""

import json
import subprocess
import sys
from pathlib import Path

PURE_MODULES = [
    "transplanter.kinematics",
    "transplanter.gcode",
    "transplanter.motion",
    "transplanter.steppers",
    "transplanter.units",
    "transplanter.errors",
    "transplanter.planner",
    "transplanter.hmi",
    "transplanter.firmware",
    "transplanter.firmware.bus",
    "transplanter.firmware.eeprom",
    "transplanter.firmware.faults",
    "transplanter.firmware.homing",
    "transplanter.firmware.marlin",
    "transplanter.firmware.pgf",
    "transplanter.firmware.rig",
    "transplanter.firmware.serial_host",
    "transplanter.firmware.sgf",
]

_PROBE = """
import importlib, json, sys
for name in sys.argv[1:]:
    importlib.import_module(name)
print(json.dumps(sorted(m for m in sys.modules if m.split(".")[0] in ("mujoco", "transplanter"))))
"""


def _imported(*modules: str) -> list[str]:
    done = subprocess.run(
        [sys.executable, "-c", _PROBE, *modules],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    return json.loads(done.stdout)


def test_the_list_holds_every_firmware_module():
    firmware = Path(__file__).resolve().parents[1] / "src" / "transplanter" / "firmware"
    names = {f"transplanter.firmware.{p.stem}" for p in firmware.glob("*.py")}
    names = {n.removesuffix(".__init__") for n in names}
    assert names <= set(PURE_MODULES)


def test_pure_firmware_modules_do_not_import_mujoco():
    loaded = _imported(*PURE_MODULES)
    assert set(PURE_MODULES) <= set(loaded)
    assert not [m for m in loaded if m.split(".")[0] == "mujoco"]
    assert "transplanter.scene" not in loaded and "transplanter.sim" not in loaded


def test_the_probe_sees_mujoco_when_it_is_imported():
    assert "mujoco" in _imported("transplanter.scene")
