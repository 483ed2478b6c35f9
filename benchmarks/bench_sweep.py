"""Benchmark: trials per minute of a small sweep on 1 and 2 workers.

Runs the same grid (Z_low at 4 values x 2 seeds, 4 seedlings per trial) with the process
pool on 1 and 2 workers (and Ray on 2 when it is installed), each into a fresh directory,
prints trials per minute and the scaling ratio against 1 worker, and checks that every
backend gave the same rows (bar the wall time). The pool's start (spawned workers importing
MuJoCo) is part of the time, as a user sees it. Beside each it prints the share of the
workers' time not spent inside the trials (`run_trial`'s own wall time, which starts with
the scene's compile): the pool's start and the workers' imports, reading and checking the
scenario, collecting the rows. Asserts nothing else.

    python benchmarks/bench_sweep.py [--seedlings 4] [--workers 1,2] [--address auto]

With --address, Ray runs on that cluster (`ray start --head` first; `auto` finds a local
one) instead of a local Ray that the benchmark starts itself.
"""

from __future__ import annotations

import argparse
import importlib.util
import tempfile
import time
from pathlib import Path

from transplanter.studies.sweep import Axis, SweepSpec, comparable, run_sweep


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seedlings", type=int, default=4)
    parser.add_argument("--workers", default="1,2", help="worker counts, e.g. 1,2,4")
    parser.add_argument("--address", default=None, help="a Ray cluster to run on as well")
    args = parser.parse_args()
    spec = SweepSpec(
        "paper", (Axis("taught.z_low_mm", (28.0, 32.0, 36.0, 40.0)),), (1, 2), args.seedlings
    )
    runs = [("process", int(n), None) for n in args.workers.split(",")]
    if importlib.util.find_spec("ray") is not None:
        # a local Ray of its own, or the cluster at --address (with a cluster running, Ray
        # refuses to start a local one beside it)
        runs.append(("ray", max(n for _, n, _ in runs), args.address))
    print(f"{spec.runs_total} trials of {args.seedlings} seedlings each")
    base_rate, reference = None, None
    with tempfile.TemporaryDirectory() as tmp:
        for k, (backend, workers, address) in enumerate(runs):
            out = Path(tmp) / f"{k}{backend}{workers}"
            t0 = time.perf_counter()
            report = run_sweep(
                spec, out, backend=backend, workers=workers, address=address, plots=False
            )
            wall = time.perf_counter() - t0
            rate = 60.0 * report.ran / wall
            if base_rate is None:
                base_rate, reference = rate, comparable(report.rows)
            same = comparable(report.rows) == reference
            inside = sum(r["wall_time_s"] or 0.0 for r in report.rows)
            outside = 1.0 - inside / (workers * wall)
            print(
                f"{backend:>7} x{workers}{' at ' + address if address else ''}: {wall:6.1f} s, "
                f"{rate:6.1f} trials/min, "
                f"scaling {rate / base_rate:.2f}x vs {runs[0][0]} x{runs[0][1]}, "
                f"rows {'identical' if same else 'DIFFER'}, "
                f"{inside / report.ran:.2f} s in each trial, {100 * outside:.0f} % of the "
                "workers' time outside the trials"
            )


if __name__ == "__main__":
    main()
