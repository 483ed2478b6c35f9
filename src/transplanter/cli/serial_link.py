"""The commands of the serial line between the PGF and the SGF (Marlin dialect): `serve` (the
twin's SGF and physics behind a pty or port) and `pgf` (stream the taught cycle to one)."""

from __future__ import annotations

import argparse
import math

from transplanter.cli.common import (
    EXIT_FIRMWARE_FAULT,
    EXIT_OK,
    EXIT_REFUSED,
    _err,
    _finish,
    _machine,
    _output_targets,
    _run,
    _single_trial_config,
    add_options,
    ascii_float,
    ascii_int,
)


def register(sub) -> None:
    _serve_parser(sub)
    _pgf_parser(sub)


def _serve_parser(sub) -> None:
    p = sub.add_parser(
        "serve",
        help="the SGF and the physics behind a pseudo-terminal or serial port (Marlin dialect)",
        epilog="one host session: it ends when the host closes the pty (or, with --until-done, "
        "when the taught program is done); exit status 0 done, 2 refused, 3 physics not "
        "valid, 4 the machine stopped on a fault (a stall, a homing failure), 5 a result "
        "file could not be written, 130 interrupted (Ctrl-C), 143 SIGTERM (as Ctrl-C)",
    )
    add_options(p, "scenario", "--set", "--seedlings", "--seed")
    p.add_argument("--port", default=None, help="a serial port (pyserial) instead of a new pty")
    p.add_argument("--baud", type=ascii_int, default=115200, help="baud rate of --port")
    p.add_argument(
        "--realtime",
        action="store_true",
        help="pace the physics to the wall clock (default: as fast as the handshake allows)",
    )
    p.add_argument(
        "--until-done",
        action="store_true",
        help="end once the scenario's taught program has been answered (default: when the "
        "host closes the port)",
    )
    p.add_argument(
        "--keepalive-s",
        type=ascii_float,
        default=2.0,
        help="'busy: processing' every this many s while a line runs (Marlin: 2; 0: none)",
    )
    p.add_argument(
        "--inject-errors",
        type=ascii_float,
        default=0.0,
        metavar="RATE",
        help="share of received lines given one byte error (a flipped bit or a dropped byte)",
    )
    p.add_argument("--inject-seed", type=ascii_int, default=0, help="seed of --inject-errors")
    add_options(p, "--json", "--record", "--record-rate")
    p.set_defaults(func=cmd_serve)


def cmd_serve(args: argparse.Namespace) -> int:
    from transplanter.machine.marlin import LineNoise
    from transplanter.scenario.schema import ScenarioError
    from transplanter.twin.report import format_summary
    from transplanter.twin.serve import PtyEndpoint, RemoteHost, SerialEndpoint, format_stats
    from transplanter.twin.sim import Twin

    if not (0 <= args.inject_errors <= 1):
        _err(f"--inject-errors is the share of lines with a byte error, 0..1: {args.inject_errors}")
        return EXIT_REFUSED
    if not (math.isfinite(args.keepalive_s) and args.keepalive_s >= 0):
        _err(f"--keepalive-s must be >= 0 s (0: none), got {args.keepalive_s}")
        return EXIT_REFUSED
    targets = _output_targets(args)
    if targets is None:
        return EXIT_REFUSED
    try:
        config = _single_trial_config(args)
    except ScenarioError as exc:
        _err(f"scenario refused: {exc}")
        return EXIT_REFUSED
    try:
        endpoint = PtyEndpoint() if args.port is None else SerialEndpoint(args.port, args.baud)
    except Exception as exc:  # pyserial's SerialException, or no pty on this system
        _err(f"cannot open {args.port or 'a pseudo-terminal'}: {exc}")
        return EXIT_REFUSED
    noise = LineNoise(args.inject_errors, args.inject_seed) if args.inject_errors > 0 else None
    host = RemoteHost(
        endpoint, config.machine, realtime=args.realtime, until_done=args.until_done,
        keepalive_s=args.keepalive_s, noise=noise,
    )  # fmt: skip
    mode = "real time" if args.realtime else "as fast as the handshake allows"
    print(f"serving {config.name} on {endpoint.path} ({mode}); connect a host there", flush=True)
    try:
        result, interrupted = _run(
            config, record_path=targets["--record"], record_rate_hz=args.record_rate,
            twin_factory=lambda c: Twin(c, remote=host), horizon_s=math.inf,
        )  # fmt: skip
    finally:
        endpoint.close()
    stats = host.stats()
    payload = {**result.to_dict(), "serial": stats.to_dict()}
    return _finish(  # exit status 4: the machine stopped (a stall, a homing failure)
        args, [result], f"{format_summary(result)}\n{format_stats(stats)}", payload,
        targets["--json"], interrupted=interrupted,
    )  # fmt: skip


def _pgf_parser(sub) -> None:
    p = sub.add_parser(
        "pgf",
        help="stream the taught cycle (the PGF) to a serial SGF: `serve`, or a board",
        epilog="exit status 0 every line acknowledged, 2 refused, 4 the PGF stopped (a line "
        "refused, or no reply within the bus timeout)",
    )
    add_options(p, "scenario", "--set", "--seedlings")
    p.add_argument("--port", required=True, help="serial device of the SGF, e.g. /dev/ttyUSB0")
    p.add_argument("--baud", type=ascii_int, default=115200, help="baud rate (115200)")
    p.set_defaults(func=cmd_pgf)


def cmd_pgf(args: argparse.Namespace) -> int:
    from transplanter.machine.pgf import PGF
    from transplanter.machine.serial_host import SerialPGF

    machine = _machine(args)
    if machine is None:
        return EXIT_REFUSED
    try:
        import serial

        port = serial.Serial(args.port, baudrate=args.baud, timeout=0)
    except Exception as exc:  # SerialException: no such device, busy, no permission
        _err(f"cannot open {args.port}: {exc}")
        return EXIT_REFUSED
    pgf = PGF(machine.eeprom, machine.pgf)
    total = len(pgf.program)
    print(f"streaming {total} lines of the taught cycle to {args.port}", flush=True)
    try:
        run = SerialPGF(pgf, port, name=args.port).run()
    finally:
        port.close()
    print(
        f"{run.lines_sent} lines sent, {run.resends} resent after line errors, "
        f"{run.wall_time_s:.1f} s"
    )
    if run.fault is not None:
        _err(f"PGF stopped: {run.fault}")
        return EXIT_FIRMWARE_FAULT
    print("done: every line acknowledged")
    return EXIT_OK
