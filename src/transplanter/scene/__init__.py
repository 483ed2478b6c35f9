"""The physical half of the twin: the MuJoCo scene (arm, conveyor, pots, drop tube).

    config    SceneConfig (every physical number) and the scene's named constants
    geometry  procedural geometry: five-bar passive angles, drop tube walls, cells and ribs
    pots      PotBatch: the randomised pots and seedlings of a seed
    build     build_scene: robot + workcell from models/ + a SceneConfig + ribs + pots -> model
    handles   Scene: index arrays, per-step accessors, contact sensing, leaf tests
    conveyor  ConveyorDrive: the conveyor's index controller (state in data.userdata)

The models are MuJoCo Menagerie folders: the robot models/fivebar/, the workcell
models/workcells/conveyor_tube/; their XML carries SceneConfig()'s numbers
(scripts/make_models.py) and models/fivebar/README.md describes the robot, its frames, joints
and actuators.
"""

from transplanter.scene.build import build_scene, export_scene, models_dir
from transplanter.scene.config import SceneConfig
from transplanter.scene.conveyor import ConveyorDrive
from transplanter.scene.geometry import drop_tube_boxes, ring_boxes
from transplanter.scene.handles import Scene
from transplanter.scene.pots import PotBatch

__all__ = [
    "ConveyorDrive",
    "PotBatch",
    "Scene",
    "SceneConfig",
    "build_scene",
    "export_scene",
    "drop_tube_boxes",
    "models_dir",
    "ring_boxes",
]
