"""The machine package (the firmware side) is pure numpy: every module in it imports with
MuJoCo absent, so it can run on a host beside real hardware without the physics engine."""

import json
import subprocess
import sys

_PROBE = """
import importlib, json, pkgutil, sys

class NoMujoco:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] == "mujoco":
            raise ImportError("mujoco is absent in this probe")
        return None

if sys.argv[1] == "absent":
    sys.meta_path.insert(0, NoMujoco())
import transplanter.machine as pure
names = ["transplanter.errors", "transplanter.units", pure.__name__]
names += [m.name for m in pkgutil.walk_packages(pure.__path__, pure.__name__ + ".")]
for name in names:
    importlib.import_module(name)
for name in sys.argv[2:]:
    importlib.import_module(name)
print(json.dumps({"walked": names, "loaded": sorted(
    m for m in sys.modules if m.split(".")[0] in ("mujoco", "transplanter"))}))
"""


def _probe(mode: str, *extra: str) -> dict:
    done = subprocess.run(
        [sys.executable, "-c", _PROBE, mode, *extra],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    return json.loads(done.stdout)


def test_every_module_of_the_machine_package_imports_with_mujoco_absent():
    found = _probe("absent")
    walked = set(found["walked"])
    # the walk reaches the firmware's parts and the kinematics of every arm
    for name in ("sgf", "pgf", "motion", "gcode", "homing", "kinematics", "kinematics.fivebar"):
        assert f"transplanter.machine.{name}" in walked
    assert not [m for m in found["loaded"] if m.split(".")[0] == "mujoco"]
    assert "transplanter.scene" not in found["loaded"]
    assert "transplanter.twin.sim" not in found["loaded"]


def test_the_probe_sees_mujoco_when_it_is_imported():
    assert "mujoco" in _probe("present", "transplanter.scene")["loaded"]
