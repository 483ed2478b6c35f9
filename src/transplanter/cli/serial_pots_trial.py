"""`transplanter trial` and `render` for the serial arm on the five-bar's pot line (`[robot]
kind = "serial4"` in the `conveyor_tube` workcell; transplanter.twin.serial_pots): the trial
is `cli.serial_trial`'s (its pot path), the render the pot jobs' (`serial_trial.render_pots`);
`export` writes its scene and `view` shows it live (`serial_trial.view_pots`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

__all__ = ["check", "export", "render", "run_trial", "view"]


def check(scenario) -> None:
    """ScenarioError for what the serial arm's pot job cannot run: its own motion, its
    placement."""
    from transplanter.twin.serial_arm import require_own_motion
    from transplanter.twin.serial_pots import check_placement

    require_own_motion(scenario, "the serial arm's pot job")
    check_placement(scenario)


def export(scenario, target: Path) -> Path:
    """`transplanter export serial_arm_pots`: the scene its trial builds for the scenario's
    seed (`twin.serial_pots.scene_spec`) with the pots' decor, meshes in assets/ beside it."""
    from transplanter.scene.effectors import fuzzy_gripper
    from transplanter.scene.export import export_spec
    from transplanter.twin.serial_pots import scene_spec

    check(scenario)
    spec = scene_spec(scenario, scenario.seed, decor=True)[0]
    return export_spec(spec, target, mount=fuzzy_gripper.MOUNT)


def run_trial(
    args: argparse.Namespace,
    overrides: dict[str, Any],
    json_path: Path | None,
    record_path: Path | None = None,
) -> int:
    from transplanter.cli.serial_trial import run_trial as serial_trial

    return serial_trial(args, overrides, json_path, record_path)


def render(
    args: argparse.Namespace, overrides: dict[str, Any], target: Path, json_path: Path | None
) -> int:
    """`transplanter render serial_arm_pots`: one trial as `trial` runs it, filmed."""
    from transplanter.cli.serial_trial import render_pots
    from transplanter.twin.serial_pots import DEFINITIONS, run_serial_pots

    return render_pots(args, overrides, target, json_path, run_serial_pots, DEFINITIONS, check)


def view(args: argparse.Namespace, overrides: dict[str, Any]) -> int:
    """`transplanter view serial_arm_pots`: one trial as `trial` runs it, shown live."""
    from transplanter.cli.serial_trial import view_pots
    from transplanter.twin.serial_pots import run_serial_pots

    return view_pots(args, overrides, run_serial_pots, check)
