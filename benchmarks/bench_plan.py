"""Benchmark: `plan` (planner.plan_program) of generated 1k/10k/100k-move programs.

Each program homes (G28) and then makes a random walk of short moves (each axis up to
+-2 mm a move, kept inside x in [-80, 80] mm, y in [140, 220] mm, Z 60-100 mm) at 100 mm/s:
the SGF interpolates every 0.1 mm, so the cost of a move is its length plus a fixed part.
Prints, per size, the wall time, time per move and the peak resident memory (``ru_maxrss``;
each size runs in its own process) of the plan, to show that time grows linearly with the file and
memory stays nearly constant (what grows is the list of small PlannedLine rows). Asserts
nothing.

    python benchmarks/bench_plan.py [sizes...]     # default: 1000 10000 100000
"""

from __future__ import annotations

import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from transplanter.machine.planner import plan_program
from transplanter.scenario.assemble import machine_config
from transplanter.scenario.schema import load_scenario

PAPER = Path(__file__).resolve().parents[1] / "scenarios" / "paper.toml"


def program(moves: int, seed: int = 0) -> str:
    rng = np.random.default_rng(seed)
    walk = np.cumsum(rng.uniform(-2.0, 2.0, (moves, 3)), axis=0)
    # fold the walk back into the box (a triangle wave keeps every step <= 2 mm)
    lo, span = np.array([-80.0, 140.0, 60.0]), np.array([160.0, 80.0, 40.0])
    folded = np.abs((walk + np.array([80.0, 40.0, 20.0])) % (2 * span) - span)
    x, y, z = (lo + span - folded).T
    lines = ["G28", "G1 X0 Y180 Z100 S100"]
    lines += [f"G1 X{a:.3f} Y{b:.3f} Z{c:.3f}" for a, b, c in zip(x, y, z, strict=True)]
    return "\n".join(lines) + "\n"


def one(moves: int) -> None:
    machine = machine_config(load_scenario(PAPER))
    text = program(moves)
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    rows = plan_program(machine, text)
    elapsed = time.perf_counter() - t0
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    assert len(rows) == moves + 2
    print(
        f"{moves:>8} {elapsed:>9.2f} {1e6 * elapsed / moves:>9.1f} {peak_mb:>9.1f} "
        f"{peak_mb - rss0 / 1024:>13.1f}",
        flush=True,
    )


def main(sizes: list[int]) -> None:
    print(f"{'moves':>8} {'seconds':>9} {'us/move':>9} {'peak MB':>9} {'MB over start':>13}")
    for moves in sizes:
        subprocess.run([sys.executable, __file__, "--one", str(moves)], check=True)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--one"]:
        one(int(sys.argv[2]))
    else:
        main([int(arg) for arg in sys.argv[1:]] or [1000, 10000, 100000])
