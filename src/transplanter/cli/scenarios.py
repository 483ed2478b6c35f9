"""`transplanter scenarios`: the packaged scenarios, a line each (name, robot, effector,
workcell, description), so a user can see what `trial NAME` runs before running it.
`transplanter keys [SCENARIO]`: the keys a scenario's kinds read, with their values, or
every key (`scenario.keys`; `--markdown` writes docs/keys.md)."""

from __future__ import annotations

import argparse

from transplanter.cli.common import EXIT_REFUSED, _err, _overrides, add_options


def register(sub) -> None:
    p = sub.add_parser(
        "scenarios",
        help="list the packaged scenarios: name, robot, effector, workcell, description",
    )
    p.set_defaults(func=cmd_scenarios)
    k = sub.add_parser(
        "keys",
        help="the keys a scenario's kinds read, with unit, range, default, value and meaning",
        description="With SCENARIO: every key its robot, effector and job read (a key they do "
        "not read is refused by every command), each with its unit, allowed range or "
        "choices, default, the value the scenario gives it (file units) and its meaning. "
        "Without: every key of every section and who reads it.",
    )
    k.add_argument("scenario", nargs="?", default=None,
                   help="scenario file, or a packaged scenario's name (paper)")  # fmt: skip
    add_options(k, "--set")
    k.add_argument("--json", action="store_true", help="print the keys as JSON")
    k.add_argument("--markdown", action="store_true",
                   help="print docs/keys.md (every key, a table per section)")  # fmt: skip
    k.set_defaults(func=cmd_keys)


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


def cmd_keys(args: argparse.Namespace) -> int:
    import json

    from transplanter.scenario import keys
    from transplanter.scenario.schema import ScenarioError, load_scenario

    if args.markdown:
        if args.scenario is not None or args.set or args.json:
            _err("--markdown prints every key: give no scenario, --set or --json with it")
            return EXIT_REFUSED
        print(keys.markdown(), end="")
        return 0
    if args.scenario is None:
        if args.set:
            _err("--set changes a scenario's value: give the scenario")
            return EXIT_REFUSED
        rows = keys.all_key_rows()
        title = f"{len(rows)} keys in {len({r.section for r in rows})} sections (read by):"
    else:
        try:
            sc = load_scenario(args.scenario, _overrides(args))
        except ScenarioError as exc:
            _err(f"scenario refused: {exc}")
            return EXIT_REFUSED
        rows = keys.scenario_key_rows(sc)
        title = (
            f"{sc.meta.name}: {len(rows)} keys its kinds read (robot {sc.robot.kind}, effector "
            f"{sc.effector.kind}, job {sc.workcell.kind}), = the value it gives each:"
        )
    if args.json:
        print(json.dumps([r.to_dict() for r in rows], indent=1))
    else:
        print(keys.format_keys(rows, title), end="")
    return 0
