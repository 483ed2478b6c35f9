"""`transplanter trial` for the delta on the five-bar's pot line (`[robot] kind = "delta"` in
the `conveyor_tube` workcell; transplanter.twin.delta_pots): one run of `--seedlings` pots
per seed, a line each; with --seeds the pooled success rate over the pots."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from transplanter.cli.common import EXIT_REFUSED, _err, _seeds

__all__ = ["check", "export", "render", "run_trial", "view"]


def check(scenario) -> None:
    """ScenarioError for what the delta's pot job cannot run: its gripper, its placement."""
    from transplanter.twin.delta_pots import check_placement, require_delta_gripper

    require_delta_gripper(scenario)
    check_placement(scenario)


def export(scenario, target: Path) -> Path:
    """`transplanter export delta_pots`: the scene its trial builds for the scenario's seed
    (`twin.delta_pots.scene_spec`) with the pots' decor, meshes in assets/ beside it."""
    from transplanter.scene.delta_scene import export_spec
    from transplanter.scene.effectors import fuzzy_gripper
    from transplanter.twin.delta_pots import scene_spec

    check(scenario)
    spec = scene_spec(scenario, scenario.seed, decor=True)[0]
    return export_spec(spec, target, mount=fuzzy_gripper.MOUNT)


def render(
    args: argparse.Namespace, overrides: dict[str, Any], target: Path, json_path: Path | None
) -> int:
    """`transplanter render delta_pots`: one trial as `trial` runs it, filmed
    (`cli.serial_trial.render_pots`)."""
    from transplanter.cli.serial_trial import render_pots
    from transplanter.twin.delta_pots import DEFINITIONS, run_delta_pots

    return render_pots(args, overrides, target, json_path, run_delta_pots, DEFINITIONS, check)


def run_trial(
    args: argparse.Namespace,
    overrides: dict[str, Any],
    json_path: Path | None,
    record_path: Path | None = None,
) -> int:
    from transplanter.machine.servo_drives import frame_steps
    from transplanter.scenario.schema import ScenarioError, load_scenario
    from transplanter.twin.delta_pots import DEFINITIONS, run_delta_pots

    for option, value in (
        ("--clips-of-failures", args.clips_of_failures),
        ("--eeprom", args.eeprom),
    ):
        if value is not None:
            _err(f"{option}: not available for the delta's pot job (docs/compare.md)")
            return EXIT_REFUSED
    if args.seeds is not None and args.seed is not None:
        _err("--seeds runs one trial per seed: drop --seed")
        return EXIT_REFUSED
    if args.seeds is not None and record_path is not None:
        _err("--seeds runs one trial per seed: drop --record (record one --seed)")
        return EXIT_REFUSED
    seeds = _seeds(args) if args.seeds is not None else [None]
    if seeds is None:
        return EXIT_REFUSED
    try:
        scenario = load_scenario(args.scenario, overrides)
        frame_steps(scenario.physics.timestep_s)
        check(scenario)
    except (ScenarioError, ValueError) as exc:
        _err(f"scenario refused: {exc}")
        return EXIT_REFUSED
    from transplanter.cli.serial_trial import pots_line, run_pot_seeds

    return run_pot_seeds(
        args, scenario, seeds, json_path, run_delta_pots, pots_line, DEFINITIONS, record_path
    )


def view(args: argparse.Namespace, overrides: dict[str, Any]) -> int:
    """`transplanter view delta_pots`: one trial as `trial` runs it, shown live."""
    from transplanter.cli.serial_trial import view_pots
    from transplanter.twin.delta_pots import run_delta_pots

    return view_pots(args, overrides, run_delta_pots, check)
