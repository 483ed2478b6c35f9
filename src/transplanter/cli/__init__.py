"""The `transplanter` command: inverse kinematics, G-code planning, trials and replay.

Argument parsing and what is printed live here, a module per group of commands, each
command's options beside its handler; the work is done by the domain modules
(`scenario.assemble`, `twin.trial.run_trial`, `machine.planner.plan_program`, `twin.report`).

  common       exit statuses, the options several commands share (declared once), reading
               --set/--seeds and the scenario, output paths, the end of every trial command
  kinematics   ik, plan
  motion       plan-move
  trials       trial (and --seeds), render, view, export
  hmi          hmi
  studies      sweep, tune, calibrate
  serial_link  serve, pgf
  replay       replay
  scenarios    scenarios (the packaged scenarios, a line each)
  vision       grade (a drawn plug tray photographed and graded from the picture)
"""

from __future__ import annotations

import argparse
import os
import signal
import sys

import transplanter
from transplanter.cli import (
    hmi,
    kinematics,
    motion,
    replay,
    scenarios,
    serial_link,
    studies,
    trials,
    vision,
)
from transplanter.cli.common import (
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_OUTPUT_FAILED,
    EXIT_REFUSED,
    EXIT_TERMINATED,
    _err,
)

# The command groups in the order `transplanter --help` lists their commands.
COMMAND_GROUPS = (kinematics, motion, trials, hmi, studies, serial_link, replay, scenarios, vision)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="transplanter",
        description="MuJoCo digital twin of robotic seedling transplanters, driven by their "
        "own firmware.",
    )
    parser.add_argument(
        "--version", action="version", version=f"%(prog)s {transplanter.__version__}"
    )
    sub = parser.add_subparsers(dest="command", required=True)
    for group in COMMAND_GROUPS:
        group.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    # rerun's own log lines would repeat a failed recording's one-line report on stderr
    os.environ.setdefault("RUST_LOG", "off")
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(argv)
    report = None
    if getattr(args, "report", None) is not None:  # trial, sweep, compare --report
        from transplanter.cli.common import StdoutCopy, new_report, report_target

        report = report_target(args)
        if report is False:
            return EXIT_REFUSED
        args.report_data = new_report(args, argv)
    if "mujoco" not in sys.modules:  # MuJoCo reads MUJOCO_GL when it is first imported
        from transplanter.viewing.video import prepare_gl

        prepare_gl()  # headless: the offscreen backend this machine has
    from transplanter import interrupts

    with interrupts.handling():  # SIGTERM stops a command as Ctrl-C does
        stdout = sys.stdout
        if report is not None:
            sys.stdout = copy = StdoutCopy(stdout)
        try:
            status = int(args.func(args) or 0)
        except KeyboardInterrupt:
            _err("interrupted")
            status = EXIT_INTERRUPTED
        finally:
            sys.stdout = stdout
        if report is not None:
            from transplanter.cli.common import write_report

            with interrupts.held():
                error = write_report(args, report, copy.text)
            if error is not None:
                _err(error)
                status = EXIT_OUTPUT_FAILED if status == EXIT_OK else status
        if interrupts.take_pending() is not None and status == 0:
            # held while the work finished and was written: nothing was cut
            _err("interrupted when the work had finished: the results are complete and written")
            status = EXIT_INTERRUPTED
        if status == EXIT_INTERRUPTED and interrupts.received() == signal.SIGTERM:
            status = EXIT_TERMINATED
    return status


if __name__ == "__main__":
    sys.exit(main())
