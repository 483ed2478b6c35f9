"""`transplanter hmi`: the paper's teach mode on an emulated LCD and keypad (docs/hmi.md)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from transplanter.cli.common import (
    EXIT_OK,
    EXIT_OUTPUT_FAILED,
    EXIT_REFUSED,
    _clash,
    _err,
    _inputs,
    _machine,
    _show,
    add_options,
)


def register(sub) -> None:
    p = sub.add_parser(
        "hmi",
        help="teach the machine on an emulated 20x4 LCD and 4x4 keypad; write the EEPROM image",
        description="The paper's teach mode (docs/hmi.md): jog the arm (a real SGF, homed "
        "at power-on) with the keys, store the pickups' approach and grip points and the "
        "drop point, enter M_pp, the elbow angles, Z_up/Z_low and the speeds, and write the "
        "EEPROM image with its CRC to --out (menu 6). With --keys or --keys-file the keys "
        "are pressed in order and the final LCD is printed; without, on a terminal, the "
        "keypad is interactive (curses; q quits). Key map: menus A up, B down, # select, * "
        "back, a digit picks its item; values: digits, D point, C delete, # save; jog: 4/6 "
        "X, 8/2 Y, 9/3 Z, 5 step 10/1/0.1 mm, # store.",
        epilog="exit status: 0 the image was written (or an interactive session ended), "
        "1 the key sequence ended without writing it, 2 refused (options, scenario, a bad "
        "key in the script, --from image, --out path), 5 the last write of the image failed "
        "(a full disk: --out is left as it was)",
    )
    add_options(p, "scenario")
    p.add_argument("--out", type=Path, required=True, help="the EEPROM image to write (.eeprom)")
    p.add_argument(
        "--keys",
        default=None,
        help="keys to press, e.g. '1 0 5#' (0-9 A-D * #; spaces ignored, ';' to the end of "
        "the line is a comment)",
    )
    p.add_argument("--keys-file", type=Path, default=None, help="a file of keys to press")
    p.add_argument(
        "--from",
        dest="start_from",
        type=Path,
        default=None,
        metavar="IMAGE",
        help="start from this EEPROM image's data (to change some of it) instead of a blank one",
    )
    p.add_argument("--show-screens", action="store_true", help="print the LCD after every key")
    add_options(p, "--set")
    p.set_defaults(func=cmd_hmi)


def cmd_hmi(args: argparse.Namespace) -> int:
    from transplanter import fileio
    from transplanter.machine.eeprom import EepromError, EepromImage
    from transplanter.machine.hmi import (
        MAX_KEY_SCRIPT_BYTES,
        Hmi,
        KeyScriptError,
        parse_keys,
        run_keys,
        run_terminal,
    )

    if args.keys is not None and args.keys_file is not None:
        _err("give the keys either with --keys or with --keys-file, not both")
        return EXIT_REFUSED
    try:
        target = fileio.check_output(args.out, ".eeprom")
    except fileio.FileRefused as exc:
        _err(f"--out: {exc}")
        return EXIT_REFUSED
    # (--from IMAGE --out IMAGE edits the image in place: it is read whole before, replaced
    # atomically after)
    clash = _clash([("--out", args.out)], _inputs(args))
    if clash is not None:
        _err(clash)
        return EXIT_REFUSED
    try:
        if args.keys is not None:
            keys = parse_keys(args.keys, "--keys")
        elif args.keys_file is not None:
            text = fileio.read_text_input(args.keys_file, MAX_KEY_SCRIPT_BYTES, "key script")
            keys = parse_keys(text, str(args.keys_file))
        else:
            keys = None
    except (KeyScriptError, fileio.FileRefused) as exc:
        _err(f"hmi refused: {exc}")
        return EXIT_REFUSED
    if keys is None and not (sys.stdin.isatty() and sys.stdout.isatty()):
        _err(
            "hmi: no terminal for the interactive keypad; give the keys with --keys '...' or "
            "--keys-file FILE"
        )
        return EXIT_REFUSED
    image = None
    if args.start_from is not None:
        try:
            image = EepromImage.load(args.start_from)
        except EepromError as exc:
            _err(f"--from refused: {exc}")
            return EXIT_REFUSED
    machine = _machine(args)
    if machine is None:
        return EXIT_REFUSED
    hmi = Hmi(machine, target, image)
    if keys is None:
        run_terminal(hmi)
    else:
        if args.show_screens:
            print(f"power-on (homed at t = {hmi.port.t:.2f} s)\n{hmi.lcd_text()}")

        def show(i: int, key: str, h: Hmi) -> None:
            print(f"key {i + 1}: {key}\n{h.lcd_text()}")

        run_keys(hmi, keys, show if args.show_screens else None)
        if not args.show_screens:
            print(hmi.lcd_text())
    if hmi.write_error is not None:  # the last Write EEPROM failed: --out is as it was
        _err(
            f"--out: the EEPROM image could not be written to {_show(args.out)} "
            f"({hmi.write_error}); the file is as it was"
        )
        return EXIT_OUTPUT_FAILED
    if hmi.refused:
        print(f"refused: {_show(hmi.last_refusal)}")
    if hmi.writes:
        print(
            f"EEPROM image written to {_show(args.out)} (M_pp {hmi.data.m_pp}); run it with: "
            f"transplanter trial {_show(args.scenario)} --eeprom {_show(args.out)}"
        )
        return EXIT_OK
    if keys is not None:
        _err(
            "the key sequence ended without writing the EEPROM image (menu 6 Write EEPROM, then #)"
        )
        return 1
    print("no EEPROM image written")
    return EXIT_OK
