"""The plug-trays workcell of the delta's cull-and-refill job (seed 002): the planting tray
and the supply tray side by side under the delta's base, and a bin for culled seedlings.

Unlike the conveyor workcell it is not loaded from its MJCF (models/workcells/plug_trays/ is
the imaging station's rigid tray, drawn for the camera): the cells and plugs the job touches
are built with `transplanter.scene.plug_physics` (tapered walls, free plugs held by contact),
the rest drawn static (`transplanter.scene.delta_scene.add_trays`).
"""

from __future__ import annotations

import mujoco

from transplanter.scene.delta_scene import DeltaSceneConfig, JobCells, add_trays
from transplanter.scene.plug_tray import TrayDraw

MODEL = "plug_trays"
"""The workcell's model folder (the camera's tray; the job's cells are built, see above)."""

JUDGE = "transplanter.twin.delta_refill:DeltaRefillJudge"

CAMERA = "tray_camera"
"""The imaging station's camera over the tray (scene.tray_camera): `transplanter grade` and
the trial's pipeline grading photograph the trays with it."""


def populate_job(
    spec: mujoco.MjSpec,
    cfg: DeltaSceneConfig,
    planting: TrayDraw,
    supply: TrayDraw,
    job: JobCells,
) -> None:
    """Both trays' cells and plugs and the bin (delta_scene.add_trays)."""
    add_trays(spec, cfg, planting, supply, job)


def home_joints(cfg) -> dict[str, float]:
    """The workcell has no joints of its own: its plugs start seated (their drawn pose)."""
    return {}
