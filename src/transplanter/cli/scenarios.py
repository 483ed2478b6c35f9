"""`transplanter scenarios`: the packaged scenarios, a line each (name, robot, effector,
workcell, description), so a user can see what `trial NAME` runs before running it."""

from __future__ import annotations

import argparse

from transplanter.cli.common import EXIT_REFUSED, _err


def register(sub) -> None:
    p = sub.add_parser(
        "scenarios",
        help="list the packaged scenarios: name, robot, effector, workcell, description",
    )
    p.set_defaults(func=cmd_scenarios)


def scenario_rows() -> list[tuple[str, str, str, str, str]]:
    """(name, robot kind, effector kind, workcell kind, description) of every packaged
    scenario, in name order."""
    from transplanter.scenario.schema import load_scenario, packaged_scenarios

    rows = []
    for name in packaged_scenarios():
        s = load_scenario(name)
        rows.append((name, s.robot.kind, s.effector.kind, s.workcell.kind, s.meta.description))
    return rows


def cmd_scenarios(args: argparse.Namespace) -> int:
    from transplanter.scenario.schema import ScenarioError
    from transplanter.twin.report import printable

    try:
        rows = scenario_rows()
    except ScenarioError as exc:
        _err(f"a packaged scenario is refused: {exc}")
        return EXIT_REFUSED
    header = ("scenario", "robot", "effector", "workcell", "description")
    widths = [max(len(r[i]) for r in (header, *rows)) for i in range(4)]
    for row in (header, *rows):
        cells = [printable(cell).ljust(width) for cell, width in zip(row, widths, strict=False)]
        print("  ".join(cells) + "  " + printable(row[4]))
    return 0
