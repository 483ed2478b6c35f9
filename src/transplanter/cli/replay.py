"""`transplanter replay`: open a recorded trial (.rrd) in the rerun viewer."""

from __future__ import annotations

import argparse
from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser("replay", help="open a recorded trial in the rerun viewer")
    p.add_argument("file", type=Path)
    p.set_defaults(func=cmd_replay)


def cmd_replay(args: argparse.Namespace) -> int:
    from transplanter.viewing.playback import replay

    return replay(args.file)
