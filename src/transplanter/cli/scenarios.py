"""`transplanter scenarios`: the packaged scenarios, a line each (name, robot, effector,
workcell, description), so a user can see what `trial NAME` runs before running it.
`transplanter keys [SCENARIO]`: the keys a scenario's kinds read, with their values, or
every key (`scenario.keys`; `--markdown` writes docs/keys.md).
`transplanter matrix`: every robot on every job, each cell its packaged scenarios and
effector, or the job's reason it cannot run (`--json`)."""

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
    m = sub.add_parser(
        "matrix",
        help="every robot on every job: the packaged scenarios of each cell, or why it cannot run",
        description="A row per job, a cell per robot: the packaged scenarios that run the "
        "robot on the job with their effector, a combination the job takes that no packaged "
        "scenario runs yet, or the job's one-line reason it refuses the robot (each job's "
        "`refusal`, transplanter.kinds). A bench of an effector alone moves no robot.",
    )
    m.add_argument("--json", action="store_true", help="print the cells as JSON")
    m.set_defaults(func=cmd_matrix)


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


def _reach_reason(job: str, robot: str, by_cell: dict) -> str | None:
    """Why `robot` reaches `job`'s key points from no placement (`scenario.reach`), judged
    on a packaged scenario of the job with the robot's own sections (its defaults or the
    reference scenario's); None where it reaches them or the job has no packaged scenario."""
    from transplanter.scenario.reach import reach_refusal
    from transplanter.scenario.schema import load_scenario

    for (cell_job, _), packaged in sorted(by_cell.items(), key=lambda kv: str(kv[0])):
        if cell_job == job and packaged:
            return reach_refusal(load_scenario(packaged[0][0], {"robot.kind": robot}))
    return None


def matrix_cells() -> list[dict]:
    """A cell per (job, robot) of the registered kinds: `scenarios` (the packaged ones of the
    cell, by name) and `effectors` (those the job takes with the robot), or `reason` (why the
    job takes the robot with no effector: the robot's workspace missing the job's key points,
    computed from its kinematics, before the job's own refusal); a job that moves no robot (a
    bench) has one cell with robot None."""
    from transplanter import kinds

    by_cell: dict[tuple[str, str | None], list[tuple[str, str]]] = {}
    for name, robot, effector, job, _ in scenario_rows():
        key = (job, robot if kinds.job(job).uses_robot() else None)
        by_cell.setdefault(key, []).append((name, effector))
    cells = []
    for job_name in kinds.names("job"):
        job = kinds.job(job_name)
        robots = kinds.names("robot") if job.uses_robot() else [None]
        for robot in robots:
            effectors = [e for e in kinds.names("effector") if job.refusal(robot or "", e) is None]
            packaged = by_cell.get((job_name, robot), [])
            cell = {
                "job": job_name,
                "robot": robot,
                "unit": job.UNIT,
                "scenarios": [n for n, _ in packaged],
                "effectors": sorted({e for _, e in packaged} or effectors),
                "reason": None,
            }
            if robot is not None and not packaged:
                cell["reach"] = _reach_reason(job_name, robot, by_cell)
            if not effectors:
                first = kinds.names("effector")[0]
                cell["reason"] = cell.get("reach") or job.refusal(robot or "", first)
            elif not packaged:
                cell["reason"] = "runs, but no packaged scenario does it yet"
            cells.append(cell)
    return cells


def cmd_matrix(args: argparse.Namespace) -> int:
    import json
    import textwrap

    from transplanter.scenario.schema import ScenarioError
    from transplanter.twin.report import printable

    try:
        cells = matrix_cells()
    except ScenarioError as exc:
        _err(f"a packaged scenario is refused: {exc}")
        return EXIT_REFUSED
    if args.json:
        print(json.dumps(cells, indent=1))
        return 0
    for job in dict.fromkeys(c["job"] for c in cells):
        row = [c for c in cells if c["job"] == job]
        print(f"{job} ({row[0]['unit']}):")
        for c in row:
            who = c["robot"] if c["robot"] is not None else "(bench)"
            if c["scenarios"]:
                text = f"{', '.join(c['scenarios'])} (effector {', '.join(c['effectors'])})"
            else:
                text = f"cannot run: {c['reason']}" if not c["effectors"] else c["reason"]
            lines = textwrap.wrap(printable(text), 78) or [""]
            print(f"  {who:<10} {lines[0]}")
            for more in lines[1:]:
                print(f"  {'':<10} {more}")
    return 0
