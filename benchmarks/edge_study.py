"""Trials at the edge: what recovery and the solver's knobs change (docs/edge_trials.md).

Runs (or resumes) three sweeps of the paper scenario with `transplanter sweep`, 40 seedlings
and seeds 1-5 each, and prints their tables as Markdown:

- recovery: Z_low 24 and 28 mm, open loop (the paper's machine) and a re-home before every
  5th cycle;
- sleep: Z_low 24, 28 and 34 mm with stall detection, physics.sleep on and off, and 24 mm
  again on seeds 6-10 (its trials spread the most);
- timestep: the same with sleep on at 0.5 ms (the 1 ms rows are the sleep sweep's). The
  2 ms rows of docs/edge_trials.md were measured before the preflight learned to refuse a
  step the stepper servos cannot follow (commit 9df47d6); today the sweep refuses them.

A single trial may change with a knob; the pooled rates (a cluster bootstrap over the trials,
never narrower than Wilson over all picks) must agree within their intervals.

    python benchmarks/edge_study.py OUT_DIR [--workers 2] [--tables-only]

About 30-65 minutes on 2 cores (the sleep-off trials are the slow ones).
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
from pathlib import Path

SEEDS = "1-5"
SWEEPS = {
    "recovery": [
        "--vary", "taught.z_low_mm=24,28", "--vary", "recovery.rehome_every_cycles=0,5",
    ],
    "sleep": [
        "--vary", "taught.z_low_mm=24,28,34", "--vary", "physics.sleep=true,false",
        "--set", "recovery.stall_detection=true",
    ],
    "sleep_24mm_seeds_6_10": [
        "--vary", "taught.z_low_mm=24", "--vary", "physics.sleep=true,false",
        "--set", "recovery.stall_detection=true",
    ],
    "timestep": [
        "--vary", "taught.z_low_mm=24,28,34", "--vary", "physics.timestep_ms=0.5",
        "--set", "recovery.stall_detection=true",
    ],
}  # fmt: skip


def run(out: Path, workers: int) -> None:
    for name, args in SWEEPS.items():
        seeds = "6-10" if name.endswith("seeds_6_10") else SEEDS
        command = [
            sys.executable, "-m", "transplanter.cli", "sweep", "paper", *args,
            "--seeds", seeds, "--seedlings", "40", "--workers", str(workers),
            "--out", str(out / name), "--quiet",
        ]  # fmt: skip
        subprocess.run(command, check=True)


def table(out: Path, name: str) -> str:
    """The sweep's settings as a Markdown table, with each seed's successes."""
    settings = list(csv.DictReader((out / name / "settings.csv").open()))
    runs = [json.loads(line) for line in (out / name / "runs.jsonl").open()]
    varied = [k for k in settings[0] if "." in k]
    lines = [
        "| " + " | ".join(varied) + " | per seed (of 40) | pooled | 95 % CI | "
        "lost-step events | position_lost | cycle s |",
        "|" + " --- |" * (len(varied) + 6),
    ]
    for s in settings:
        mine = sorted(
            (r for r in runs if all(str(r[k]) == _py(s[k]) for k in varied)),
            key=lambda r: r["seed"],
        )
        per_seed = " ".join("err" if r["error"] else str(r["successes"]) for r in mine)
        events = sum(r["lost_step_events"] or 0 for r in mine)
        lost = sum(r.get("fail_position_lost") or 0 for r in mine)
        rate = f"{100 * float(s['success_rate']):.1f} %" if s["success_rate"] else "n/a"
        ci = (
            f"{100 * float(s['ci95_low']):.1f}-{100 * float(s['ci95_high']):.1f} %"
            if s["ci95_low"]
            else "n/a"
        )
        cycle = f"{float(s['cycle_time_s']):.3f}" if s["cycle_time_s"] else "n/a"
        cells = [s[k] for k in varied] + [per_seed, rate, ci, str(events), str(lost), cycle]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _py(text: str) -> str:
    """A settings.csv cell as str() of the value runs.jsonl holds."""
    return {"True": "True", "False": "False", "true": "True", "false": "False"}.get(text, text)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--workers", default="2")
    parser.add_argument("--tables-only", action="store_true")
    args = parser.parse_args()
    if not args.tables_only:
        run(args.out, args.workers)
    for name in SWEEPS:
        if (args.out / name / "settings.csv").exists():
            print(f"\n### {name}\n\n{table(args.out, name)}")


if __name__ == "__main__":
    main()
