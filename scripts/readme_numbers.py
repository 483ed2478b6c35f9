"""Rerun every number README.md and docs/ quote from a command and diff it against their text.

Run: .venv/bin/python scripts/readme_numbers.py            (every block; an hour or more on 2 cores)
     .venv/bin/python scripts/readme_numbers.py --quick    (a subset for CI, well under a minute)
     .venv/bin/python scripts/readme_numbers.py --update   (rewrite the stale numbers)
     .venv/bin/python scripts/readme_numbers.py --only edge_knobs --sweep-out results/docs

The pages mark the text this script owns, so that it never guesses:

    <!-- readme_numbers: NAME -->TEXT<!-- /readme_numbers -->

(inline, or with TEXT on lines of its own, a fenced block or a Markdown table). NAME is one of
BLOCKS below: each says which page quotes it (README.md or a page of docs/), which command
gives the text and how the text is made from that command's output. Nothing outside the
markers is read or written. Every number in TEXT is compared, in order, with the same number in
the text the twin gives now; each is printed with what the page says and what the twin gives,
and the exit status is 1 when any differs (2 when a page's markers and BLOCKS disagree).
Numbers that measure the computer rather than the twin (wall time, real-time factor) are printed
but not compared, and --update leaves them as they are (docs/performance.md and the benchmarks
measure speed).

The tables of docs/ (DOC_TABLES: the timestep study of docs/drives.md, the edge studies of
docs/edge_trials.md) are `transplanter sweep` runs rendered from their runs.jsonl and
settings.csv: the varied keys, then the columns each table names (COLUMNS). With --sweep-out
DIR each sweep keeps its files in DIR/NAME, and a rerun into the same DIR resumes it.

--quick runs the cheap part of the README: the paper trial (40 seedlings, seed 1: a few
seconds), the 22 mm trial (20 seedlings), `ik`, `plan`, and one row (32 mm) of the z_low sweep
table instead of all seven. With --update it rewrites only what it ran. The commands run in
this process through `transplanter.cli.main`, with --json (and the sweep's --out) pointed into a
scratch directory.

tests/test_readme_numbers.py runs --quick and checks that every `transplanter ...` line the
README quotes parses, and that every block is marked once on its page.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import io
import json
import os
import re
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"

BLOCK_RE = re.compile(
    r"<!-- readme_numbers: (?P<name>[a-z0-9_]+) -->(?P<body>.*?)<!-- /readme_numbers -->", re.S
)
# A number as the twin prints it: not part of a name (theta1, X140), and a minus sign only
# where it cannot be a range's dash (91.2-100.0)
NUMBER_RE = re.compile(r"(?:(?<![\w.)%])-)?(?<![\w.])\d+(?:\.\d+)?")


class Runs:
    """Runs the README's commands in this process, each once, in a scratch directory."""

    def __init__(self, scratch: Path, sweep_out: Path | None = None):
        self.scratch = scratch
        self.sweep_out = sweep_out
        self._cache: dict[tuple[str, ...], tuple[str, dict | None]] = {}

    def cli(self, argv: list[str], json_out: bool = False) -> tuple[str, dict | None]:
        """stdout of `transplanter ARGV` (and its --json, when asked), exit 0 or 1 required."""
        key = tuple(argv) + (("--json",) if json_out else ())
        if key in self._cache:
            return self._cache[key]
        from transplanter.cli import main

        extra: list[str] = []
        json_path = self.scratch / f"run{len(self._cache)}.json"
        if json_out:
            extra = ["--json", str(json_path), "--quiet"]
        print(f"  running: transplanter {' '.join(argv)}", file=sys.stderr, flush=True)
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            status = main(argv + extra)
        if status not in (0, 1):
            raise RuntimeError(f"transplanter {' '.join(argv)} exited {status}")
        data = json.loads(json_path.read_text()) if json_out else None
        self._cache[key] = (out.getvalue(), data)
        return self._cache[key]

    def sweep(self, vary: str) -> str:
        """The settings table `transplanter sweep` prints for the README's z_low sweep."""
        out_dir = (self.sweep_out or self.scratch) / ("readme_" + re.sub(r"\W", "_", vary))
        argv = ["sweep", "paper", "--vary", vary, "--seeds", "1-3", "--seedlings", "40",
                "--workers", "2", "--out", str(out_dir), "--quiet"]  # fmt: skip
        text, _ = self.cli(argv)
        lines = text.splitlines()
        start = next(i for i, line in enumerate(lines) if line.startswith("taught.z_low_mm"))
        end = next(i for i in range(start, len(lines)) if lines[i].startswith("results in"))
        self.last_sweep = out_dir
        return "\n".join(lines[start:end])

    def sweep_dir(self, name: str, argv: list[str]) -> Path:
        """Runs `transplanter sweep ARGV` (2 workers) into its own directory, named after the
        block, under --sweep-out (a rerun resumes) or the scratch directory."""
        out_dir = (self.sweep_out or self.scratch) / name
        self.cli(["sweep", *argv, "--workers", "2", "--out", str(out_dir), "--quiet"])
        return out_dir

    def sweep_runs(self) -> list[dict]:
        """The rows of the full sweep's runs.jsonl (after `sweep`)."""
        path = self.last_sweep / "runs.jsonl"
        return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _fenced(text: str) -> str:
    return f"\n```\n{text}\n```\n"


# --- the blocks: each makes its text from the output of a command the README quotes ----------


def paper_trial(runs: Runs) -> str:
    """`transplanter trial paper` (the scenario's seed, 1): its summary from 'success rate' to
    the first failure kind, then '...', as the README shows it."""
    text, _ = runs.cli(["trial", "paper"], json_out=True)
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("success rate"))
    end = next(i for i, line in enumerate(lines) if line.startswith("failures: "))
    return _fenced("\n".join(lines[start : end + 1] + ["..."]))


def _paper_json(runs: Runs) -> dict:
    return runs.cli(["trial", "paper"], json_out=True)[1]


def paper_shoot_bend(runs: Runs) -> str:
    """The paper trial's shoot bend row, rounded: '6 deg mean, 13 at most'."""
    text, _ = runs.cli(["trial", "paper"], json_out=True)
    m = re.search(r"shoot bend\s+([\d.]+) deg at most, ([\d.]+) deg mean", text)
    damaged = _paper_json(runs)["failures"]["damaged"]
    at = "none" if damaged == 0 else f"{damaged} damaged"
    return f"{at} at the paper's setting: {float(m[2]):.0f} deg mean, {float(m[1]):.0f} at most"


def pgf_vs_trial(runs: Runs) -> str:
    """The paper trial's outcome and mean cycle (test_serve checks that pgf over serve gives
    the same)."""
    d = _paper_json(runs)
    return f"{d['successes']}/{d['seedlings']}, {d['cycle_time_s']:.3f} s both"


def _z22(runs: Runs) -> dict:
    argv = ["trial", "paper", "--set", "taught.z_low_mm=22", "--seedlings", "20"]
    return runs.cli(argv, json_out=True)[1]


def z_low_22(runs: Runs) -> str:
    """`transplanter trial paper --set taught.z_low_mm=22 --seedlings 20` (seed 1)."""
    d = _z22(runs)
    kinds = ", ".join(f"{n} {k}" for k, n in d["failures"].items() if n)
    return f"{d['successes']}/{d['seedlings']}, seed {d['seed']}: {kinds}"


def z_low_22_strike(runs: Runs) -> str:
    """The first lost-step event of the 22 mm trial, in full steps (16 microsteps each)."""
    events = _z22(runs)["lost_step_events"]
    return f"a motor loses {abs(events[0]['microsteps']) // 16} full steps"


def _calibrated(runs: Runs, seeds: str) -> str:
    d = runs.cli(["trial", "paper_calibrated", "--seeds", seeds, "--quiet"], json_out=True)[1]
    return f"{100 * d['pooled']['success_rate']:.1f} %"


def calibrated_seeds_1_3(runs: Runs) -> str:
    """`transplanter trial paper_calibrated --seeds 1-3`: the pooled rate."""
    return _calibrated(runs, "1-3")


def calibrated_seeds_4_6(runs: Runs) -> str:
    """`transplanter trial paper_calibrated --seeds 4-6`: the pooled rate (held out)."""
    return _calibrated(runs, "4-6")


def ik_example(runs: Runs) -> str:
    """`transplanter ik 0 200`."""
    return _fenced(runs.cli(["ik", "0", "200"])[0].rstrip("\n"))


def plan_example(runs: Runs) -> str:
    """`transplanter plan scenarios/example.gcode`."""
    gcode = README.parent / "scenarios" / "example.gcode"
    text = runs.cli(["plan", str(gcode)])[0].rstrip("\n")
    return _fenced(text)


def zlow_sweep(runs: Runs) -> str:
    """The settings table of the README's z_low sweep (20:44:4, seeds 1-3, 40 seedlings)."""
    return _fenced(runs.sweep("taught.z_low_mm=20:44:4"))


def zlow_sweep_quick(runs: Runs) -> str:
    """The 32 mm row of the same sweep alone (the same setting and seeds give the same row;
    `check` compares the columns it has: the table's failure columns depend on every row)."""
    return _fenced(runs.sweep("taught.z_low_mm=32"))


def zlow_24_per_seed(runs: Runs) -> str:
    """The 24 mm trials of the z_low sweep, seed by seed: '8, 7 and 9 of 40'."""
    runs.sweep("taught.z_low_mm=20:44:4")
    rows = sorted(
        (r for r in runs.sweep_runs() if r["taught.z_low_mm"] == 24.0), key=lambda r: r["seed"]
    )
    counts = [str(r["successes"]) for r in rows]
    return f"{', '.join(counts[:-1])} and {counts[-1]} of {rows[0]['seedlings']}"


# --- the tables of docs/: each a `transplanter sweep`, rendered from its runs.jsonl ----------

FAIL_PREFIX = "fail_"


def _value(text: str) -> str:
    """A settings.csv cell as a person reads it: 22.0 -> 22, True -> on."""
    if text in ("True", "False"):
        return {"True": "on", "False": "off"}[text]
    try:
        number = float(text)
    except ValueError:
        return text
    return f"{number:g}"


def _same_setting(run: dict, setting: dict, varied: list[str]) -> bool:
    return all(_value(str(run[k])) == _value(setting[k]) for k in varied)


def _failures(mine: list[dict]) -> str:
    """Failures summed over a setting's trials, most frequent first: '14 `not_gripped`, 3
    `slipped`', and the trials a fault stopped."""
    totals: dict[str, int] = {}
    for r in mine:
        for key, n in r.items():
            if key.startswith(FAIL_PREFIX) and n:
                totals[key[len(FAIL_PREFIX) :]] = totals.get(key[len(FAIL_PREFIX) :], 0) + n
    parts = [f"{n} `{kind}`" for kind, n in sorted(totals.items(), key=lambda kv: (-kv[1], kv[0]))]
    stops: dict[str, int] = {}
    for r in mine:
        if r.get("fault_kind"):
            what = f"stopped by `{r['fault_kind']}`"
        elif r.get("error") and "did not finish" in r["error"]:
            what = "ran to the horizon"
        elif r.get("error"):
            what = "ended in an error"
        else:
            continue
        stops[what] = stops.get(what, 0) + 1
    parts += [f"{n} trial{'s' if n > 1 else ''} {what}" for what, n in sorted(stops.items())]
    return ", ".join(parts)


COLUMNS: dict[str, tuple[str, Callable[[dict, list[dict]], str]]] = {
    "success": (
        "success",
        lambda s, mine: (
            f"{100 * float(s['success_rate']):.1f} % ({s['successes']}/{s['seedlings']})"
            if s["success_rate"]
            else "n/a"
        ),
    ),
    "ci": (
        "95 % CI",
        lambda s, mine: (
            f"{100 * float(s['ci95_low']):.1f}-{100 * float(s['ci95_high']):.1f} %"
            if s["ci95_low"]
            else "n/a"
        ),
    ),
    "per_seed": (
        "per seed",
        lambda s, mine: " ".join("err" if r["error"] else str(r["successes"]) for r in mine),
    ),
    "failures": ("failures", lambda s, mine: _failures(mine)),
    "events": (
        "lost-step events",
        lambda s, mine: str(sum(r["lost_step_events"] or 0 for r in mine)),
    ),
    "cycle": (
        "cycle s",
        lambda s, mine: f"{float(s['cycle_time_s']):.3f}" if s["cycle_time_s"] else "n/a",
    ),
    "bends": (
        "largest shoot bend per seed, deg",
        lambda s, mine: " ".join(f"{r['max_stem_bend_deg']:.0f}" for r in mine),
    ),
}


def sweep_table(runs: Runs, name: str, argv: list[str], columns: tuple[str, ...]) -> str:
    """A sweep's settings as a Markdown table: the varied keys, then `columns` (COLUMNS)."""
    out = runs.sweep_dir(name, argv)
    with (out / "settings.csv").open(newline="") as f:
        settings = list(csv.DictReader(f))
    trials = [json.loads(line) for line in (out / "runs.jsonl").read_text().splitlines() if line]
    varied = [k for k in settings[0] if "." in k]
    lines = [
        "| " + " | ".join(varied + [COLUMNS[c][0] for c in columns]) + " |",
        "|" + " --- |" * (len(varied) + len(columns)),
    ]
    for s in settings:
        mine = sorted((r for r in trials if _same_setting(r, s, varied)), key=lambda r: r["seed"])
        cells = [_value(s[k]) for k in varied] + [COLUMNS[c][1](s, mine) for c in columns]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n" + "\n".join(lines) + "\n"


FAST = ["--set", "motion.accel_mm_s2=20000", "--set", "taught.s_high_mm_s=500"]
SEEDLINGS_40 = ["--seedlings", "40"]
# name: (the page, the sweep's arguments, the table's columns)
DOC_TABLES: dict[str, tuple[str, list[str], tuple[str, ...]]] = {
    # docs/drives.md: the outcomes against the timestep, on seeds used nowhere else
    "steps_paper": ("docs/drives.md", ["paper", "--vary", "physics.timestep_ms=1,0.5,0.25",
                    "--seeds", "21-25", *SEEDLINGS_40],
                    ("success", "ci", "failures", "cycle", "bends")),
    "steps_calibrated": ("docs/drives.md", ["paper_calibrated", "--vary",
                         "physics.timestep_ms=1,0.5,0.25", "--seeds", "21-25", *SEEDLINGS_40],
                         ("success", "ci", "failures", "cycle", "bends")),
    "steps_z28": ("docs/drives.md", ["paper", "--set", "taught.z_low_mm=28", "--vary",
                  "physics.timestep_ms=1,0.5,0.25", "--seeds", "21-25", *SEEDLINGS_40],
                  ("success", "ci", "failures", "cycle", "bends")),
    "steps_fast": ("docs/drives.md", ["paper_calibrated", *FAST, "--vary",
                   "physics.timestep_ms=1,0.5,0.25", "--seeds", "21-25", *SEEDLINGS_40],
                   ("success", "ci", "failures", "cycle", "bends")),
    # docs/edge_trials.md: the two edges of today's machine, recovery and the solver's knobs
    "edge_zlow_recovery": ("docs/edge_trials.md", ["paper", "--vary", "taught.z_low_mm=22,24",
                           "--vary", "recovery.rehome_every_cycles=0,5", "--seeds", "1-5",
                           *SEEDLINGS_40],
                           ("per_seed", "success", "ci", "failures", "events", "cycle")),
    "edge_zlow_stall": ("docs/edge_trials.md", ["paper", "--vary", "taught.z_low_mm=22,24",
                        "--set", "recovery.stall_detection=true", "--seeds", "1-3",
                        "--seedlings", "20"],
                        ("per_seed", "success", "ci", "failures", "events", "cycle")),
    "edge_fast_recovery": ("docs/edge_trials.md", ["paper_calibrated", *FAST, "--vary",
                           "recovery.rehome_every_cycles=0,5", "--vary",
                           "recovery.stall_detection=false,true", "--seeds", "1-5",
                           *SEEDLINGS_40],
                           ("per_seed", "success", "ci", "failures", "events", "cycle")),
    "edge_knobs": ("docs/edge_trials.md", ["paper", "--vary", "taught.z_low_mm=22,24,34",
                   "--vary", "physics.sleep=true,false", "--seeds", "1-5", *SEEDLINGS_40],
                   ("per_seed", "success", "ci", "failures", "events", "cycle")),
    "edge_timestep": ("docs/edge_trials.md", ["paper", "--vary", "taught.z_low_mm=22,24,34",
                      "--vary", "physics.timestep_ms=0.5", "--seeds", "1-5", *SEEDLINGS_40],
                      ("per_seed", "success", "ci", "failures", "events", "cycle")),
    "edge_fast_knobs": ("docs/edge_trials.md", ["paper_calibrated", *FAST, "--vary",
                        "physics.sleep=true,false", "--vary", "physics.timestep_ms=1,0.5",
                        "--seeds", "1-5", *SEEDLINGS_40],
                        ("per_seed", "success", "ci", "failures", "events", "cycle")),
    # docs/fidelity.md: the paper scenario's responses and the failure mechanisms, seeds 1-3
    **{
        name: ("docs/fidelity.md", [scenario, *argv, "--seeds", "1-3", *SEEDLINGS_40], columns)
        for name, scenario, argv, columns in (
            ("fid_zlow", "paper", ["--vary", "taught.z_low_mm=20:34:2"],
             ("per_seed", "success", "failures", "bends")),
            ("fid_close_dwell", "paper", ["--vary", "gripper.close_dwell_ms=50,100,200,300"],
             ("per_seed", "success", "failures", "cycle")),
            ("fid_s_low", "paper", ["--vary", "taught.s_low_mm_s=30,60,120,250"],
             ("per_seed", "success", "failures", "cycle")),
            ("fid_s_high", "paper", ["--vary", "taught.s_high_mm_s=100,150,250,400"],
             ("per_seed", "success", "failures", "cycle")),
            ("fid_z_up", "paper", ["--vary", "taught.z_up_mm=50,60,80,100,150"],
             ("per_seed", "success", "failures", "cycle", "bends")),
            ("fid_index", "paper", ["--vary", "conveyor.index_time_s=0.3,0.35,0.4,0.45,0.5,0.6"],
             ("per_seed", "success", "failures")),
            ("fid_friction", "paper",
             ["--vary", "pots.friction=0.05,0.075,0.1,0.125,0.15,0.2,0.3,0.6"],
             ("per_seed", "success", "failures")),
            ("fid_mass", "paper", ["--vary", "pots.mass_g=40,47,50,60,70,80"],
             ("per_seed", "success", "failures")),
            ("fid_soft", "paper", ["--set", "pots.soft_wall_mm=40", "--vary",
                                   "pots.soft_share=0.05,0.1,0.2"],
             ("per_seed", "success", "failures")),
            ("fid_crooked", "paper", ["--set", "pots.crooked_share=0.5", "--vary",
                                      "pots.crooked_max_deg=8,12,16,20"],
             ("per_seed", "success", "failures")),
            ("fid_bond", "paper", ["--set", "pots.bond_share=0.3", "--set",
                                   "pots.bond_force_sd_log=0.5", "--vary",
                                   "pots.bond_force_n=4,6,8,10"],
             ("per_seed", "success", "failures")),
            ("fid_canopy", "paper", ["--set", "pots.canopy_contact=true", "--vary",
                                     "pots.canopy_timeconst_ms=50,100,200,400,800"],
             ("per_seed", "success", "failures")),
            ("fid_calibrated_speed", "paper_calibrated",
             ["--vary", "motion.accel_mm_s2=1500,5000,20000", "--vary",
              "taught.s_high_mm_s=150,300,400,500"],
             ("per_seed", "success", "failures", "cycle", "bends")),
            ("fid_sway_fast", "paper", [*FAST, "--vary", "pots.stem_sway_hz=1.5,2,2.5,3,4"],
             ("per_seed", "success", "failures", "bends")),
            ("fid_sway_slow", "paper", ["--vary", "pots.stem_sway_hz=2.5,3,4", "--vary",
                                        "motion.accel_mm_s2=1500,20000"],
             ("per_seed", "success", "failures", "bends")),
        )
    },
}  # fmt: skip


def _doc_table(name: str) -> Callable[[Runs], str]:
    page, argv, columns = DOC_TABLES[name]

    def make(runs: Runs) -> str:
        return sweep_table(runs, name, argv, columns)

    make.__doc__ = f"{page}: `transplanter sweep {' '.join(argv)}`"
    return make


NINE = (
    "paper", "paper_calibrated", "paper_tuned", "serial_arm_pots", "serial_arm_pots_tuned",
    "delta_pots", "delta_pots_tuned", "delta_refill", "delta_refill_tuned",
)  # fmt: skip
"""The nine rows of docs/compare.md's comparison."""
NINE_COMMAND = (
    "MUJOCO_GL=egl transplanter compare " + " ".join(NINE)
    + " --seeds 1-3 --seedlings 40 --workers 2 --out results/compare"
)  # fmt: skip


def _nine(runs: Runs) -> dict[str, dict]:
    """The nine-row comparison's rows by scenario (compare.json), run once (under
    --sweep-out NAME a rerun resumes)."""
    out_dir = (runs.sweep_out or runs.scratch) / "compare_nine"
    runs.cli(["compare", *NINE, "--seeds", "1-3", "--seedlings", "40", "--workers", "2",
              "--out", str(out_dir), "--quiet"])  # fmt: skip
    rows = json.loads((out_dir / "compare.json").read_text())["rows"]
    return {r["scenario"]: r for r in rows}


def _of(row: dict) -> str:
    return f"{row['successes']}/{row['seedlings']}"


def compare_machines(runs: Runs) -> str:
    """The README's paragraph on the comparison: each machine's plants per hour and success,
    as published and tuned (the nine-row comparison)."""
    r = _nine(runs)
    paper, tuned = r["paper"], r["paper_tuned"]
    arm, arm_tuned = r["serial_arm_pots"], r["serial_arm_pots_tuned"]
    tray, tray_tuned = r["delta_refill"], r["delta_refill_tuned"]
    return (
        f"{paper['plants_per_hour']:.0f} pots an hour as published "
        f"({100 * paper['success_rate']:.0f} %) and {tuned['plants_per_hour']:.0f} tuned "
        f"(`paper_tuned`, {tuned['cycle_time_s']:.1f} s a cycle, {_of(tuned)}); the serial arm "
        f"{arm['plants_per_hour']:.0f} ({_of(arm)}) and {arm_tuned['plants_per_hour']:.0f} tuned "
        f"({_of(arm_tuned)}), both below a 90 % floor; the delta culls or refills "
        f"{tray['plants_per_hour']:.0f} cells an hour ({100 * tray['success_rate']:.1f} %) on its "
        f"trays and {tray_tuned['plants_per_hour']:.0f} tuned (`delta_refill_tuned`)"
    )


def compare_delta_pots(runs: Runs) -> str:
    """The delta on the pot line in the README's comparison paragraph."""
    r = _nine(runs)
    pots, tuned = r["delta_pots"], r["delta_pots_tuned"]
    return (
        f"{pots['plants_per_hour']:.0f} pots an hour, {_of(pots)}, and "
        f"{tuned['plants_per_hour']:.0f} tuned (`delta_pots_tuned`, {_of(tuned)}"
    )


def serial_arm_pots_seeds_1_3(runs: Runs) -> str:
    """The serial arm on the pot line over seeds 1-3 (the nine-row comparison's row)."""
    arm = _nine(runs)["serial_arm_pots"]
    lo, hi = arm["ci95"]
    return (
        f"{arm['successes']} of {arm['seedlings']} into the tube undamaged over seeds 1-3 "
        f"({100 * arm['success_rate']:.1f} %, 95 % CI {100 * lo:.1f}-{100 * hi:.1f} %)"
    )


def _pooled(runs: Runs, argv: list[str]) -> tuple[dict, float]:
    """A `trial --seeds` run's pooled rate and the mean of its trials' cycles (s)."""
    d = runs.cli(["trial", *argv, "--quiet"], json_out=True)[1]
    cycles = [t["cycle_time_s"] for t in d["trials"] if t["cycle_time_s"] is not None]
    return d["pooled"], sum(cycles) / len(cycles)


def delta_pots_planners(runs: Runs) -> str:
    """`trial delta_pots --seeds 1-3 --seedlings 20`, with its splines and with G1 lines."""
    argv = ["delta_pots", "--seeds", "1-3", "--seedlings", "20"]
    splines, spline_cycle = _pooled(runs, argv)
    _, lines_cycle = _pooled(runs, [*argv, "--set", 'motion.planner="lines"'])
    return (
        f"{splines['successes']}/{splines['seedlings']} pots into the tube, their shoots "
        f"undamaged, over seeds 1-3 x 20 at {spline_cycle:.2f} s a pot with its splines, "
        f"{lines_cycle:.2f} s"
    )


def paper_bspline5(runs: Runs) -> str:
    """`trial paper --seeds 31-35` with the five-bar's spline transfer and with its lines."""
    spline, spline_cycle = _pooled(runs, ["paper", "--seeds", "31-35", "--set",
                                          'motion.planner="bspline5"'])  # fmt: skip
    lines, lines_cycle = _pooled(runs, ["paper", "--seeds", "31-35"])
    same = (spline["successes"], spline["seedlings"]) == (lines["successes"], lines["seedlings"])
    tally = (
        f"the same {spline['successes']}/{spline['seedlings']}"
        if same
        else f"{spline['successes']}/{spline['seedlings']} against "
        f"{lines['successes']}/{lines['seedlings']}"
    )
    return f"{spline_cycle:.3f} s a seedling against {lines_cycle:.3f} s at {tally}"


def serial_arm_tomatoes(runs: Runs) -> str:
    """`trial serial_arm --seeds 1-3`: the tomatoes onto the belt and their mean cycle."""
    d = runs.cli(["trial", "serial_arm", "--seeds", "1-3", "--quiet"], json_out=True)[1]
    pooled = d["pooled"]
    return (
        f"{pooled['successes']}/{pooled['seedlings']} over seeds 1-3, "
        f"{d['mean_cycle_time_s']:.2f} s a tomato"
    )


def serial_arm_targets(runs: Runs) -> str:
    """`trial serial_arm` (seed 1): the ten targets' mean error per axis, its range (cm)."""
    d = runs.cli(["trial", "serial_arm", "--quiet"], json_out=True)[1]
    errors = d["mean_error_cm"]
    return f"{min(errors):.2f}-{max(errors):.2f} cm per axis"


def _per_operation(runs: Runs, extra: list[str]) -> float:
    """The mean of the trays' time per operation, `trial delta_refill --seeds 1-3` graded from
    the drawn truth (the motion compared alone, as docs/delta.md's table)."""
    argv = ["trial", "delta_refill", "--seeds", "1-3", "--set", 'delta_refill.vision="truth"']
    d = runs.cli([*argv, *extra, "--quiet"], json_out=True)[1]
    times = [t["time_per_operation_s"] for t in d["trials"]]
    return sum(times) / len(times)


def delta_tray_operation(runs: Runs) -> str:
    """The delta's time per operation with its splines and with straight lines."""
    splines = _per_operation(runs, [])
    lines = _per_operation(runs, ["--set", 'motion.planner="lines"'])
    return (
        f"about {splines:.2f} s per operation against the paper's 3.1 s ({lines:.1f} s with "
        "straight lines"
    )


def calibrated_held_out(runs: Runs) -> str:
    """docs/fidelity.md: `transplanter trial paper_calibrated --seeds S` on the fitted seeds and
    on seeds the fit never saw, per seed and pooled."""
    lines = [
        "| seeds | per seed (of 40) | pooled | 95 % CI | failures |",
        "| --- | --- | --- | --- | --- |",
    ]
    for seeds, label in (("1-3", "1-3 (fitted)"), ("4-6", "4-6 (held out)"),
                         ("7-9", "7-9 (held out)"), ("4-9", "4-9 (held out)"),
                         ("21-25", "21-25 (held out)")):  # fmt: skip
        d = runs.cli(["trial", "paper_calibrated", "--seeds", seeds, "--quiet"], json_out=True)[1]
        trials, pooled = d["trials"], d["pooled"]
        per_seed = " ".join(str(t["successes"]) for t in trials)
        lo, hi = pooled["ci95"]
        rows = [{f"fail_{k}": n for k, n in t["failures"].items()} for t in trials]
        lines.append(
            f"| {label} | {per_seed} | {100 * pooled['success_rate']:.1f} % "
            f"({pooled['successes']}/{pooled['seedlings']}) | {100 * lo:.1f}-{100 * hi:.1f} % | "
            f"{_failures(rows)} |"
        )
    return "\n" + "\n".join(lines) + "\n"


@dataclass(frozen=True)
class Block:
    name: str
    make: Callable[[Runs], str]
    command: str  # the README's command the text comes from
    quick: bool = False  # run by --quick
    # lines whose numbers measure the computer, not the twin: shown, never compared
    volatile: tuple[str, ...] = ()
    # --quick: a function giving the block's text in part (the lines it gives replace the
    # README's lines that start with the same first field)
    partial: Callable[[Runs], str] | None = None
    page: str = "README.md"  # the file, relative to the repository, that quotes the text


BLOCKS = {
    b.name: b
    for b in (
        Block("paper_trial", paper_trial, "transplanter trial paper", quick=True,
              volatile=("wall time", "real-time factor")),
        Block("paper_shoot_bend", paper_shoot_bend, "transplanter trial paper", quick=True),
        Block("calibrated_seeds_1_3", calibrated_seeds_1_3,
              "transplanter trial paper_calibrated --seeds 1-3"),
        Block("calibrated_seeds_4_6", calibrated_seeds_4_6,
              "transplanter trial paper_calibrated --seeds 4-6"),
        Block("z_low_22_strike", z_low_22_strike,
              "transplanter trial paper --set taught.z_low_mm=22 --seedlings 20", quick=True),
        Block("z_low_22", z_low_22,
              "transplanter trial paper --set taught.z_low_mm=22 --seedlings 20", quick=True),
        Block("ik_example", ik_example, "transplanter ik 0 200", quick=True),
        Block("plan_example", plan_example, "transplanter plan scenarios/example.gcode",
              quick=True),
        Block("pgf_vs_trial", pgf_vs_trial, "transplanter trial paper", quick=True),
        Block("zlow_sweep", zlow_sweep,
              "transplanter sweep paper --vary taught.z_low_mm=20:44:4 --seeds 1-3 "
              "--seedlings 40 --workers 2 --out results/zlow",
              partial=zlow_sweep_quick),
        Block("zlow_24_per_seed", zlow_24_per_seed, "the same sweep, runs.jsonl"),
        Block("compare_machines", compare_machines, NINE_COMMAND),
        Block("compare_delta_pots", compare_delta_pots, NINE_COMMAND),
        Block("serial_arm_pots_seeds_1_3", serial_arm_pots_seeds_1_3, NINE_COMMAND),
        Block("delta_pots_planners", delta_pots_planners,
              "transplanter trial delta_pots --seeds 1-3 --seedlings 20 [--set "
              "motion.planner='\"lines\"']"),
        Block("paper_bspline5", paper_bspline5,
              "transplanter trial paper --seeds 31-35 [--set motion.planner='\"bspline5\"']"),
        Block("serial_arm_tomatoes", serial_arm_tomatoes,
              "transplanter trial serial_arm --seeds 1-3"),
        Block("serial_arm_targets", serial_arm_targets, "transplanter trial serial_arm"),
        Block("delta_tray_operation", delta_tray_operation,
              "transplanter trial delta_refill --seeds 1-3 --set delta_refill.vision='\"truth\"'"
              " [--set motion.planner='\"lines\"']"),
        Block("calibrated_held_out", calibrated_held_out,
              "transplanter trial paper_calibrated --seeds S", page="docs/fidelity.md"),
        *(
            Block(name, _doc_table(name), "transplanter sweep " + " ".join(argv), page=page)
            for name, (page, argv, _) in DOC_TABLES.items()
        ),
    )
}  # fmt: skip


# --- comparing and rewriting -----------------------------------------------------------------


def _first_field(line: str) -> str:
    parts = line.split()
    return parts[0] if parts else ""


def _common(body: str, widths: dict[str, int]) -> str:
    """The lines of `body` whose first field is in `widths`, each cut to that many words."""
    return "\n".join(
        " ".join(line.split()[: widths[_first_field(line)]])
        for line in body.split("\n")
        if _first_field(line) in widths
    )


def keep_volatile(block: Block, old: str, new: str) -> str:
    """`new` with the README's own lines for the block's volatile lines (a wall time measured
    on a busy machine is no news)."""
    kept = {v: line for line in old.split("\n") for v in block.volatile if line.startswith(v)}
    return "\n".join(
        next((kept[v] for v in block.volatile if line.startswith(v) and v in kept), line)
        for line in new.split("\n")
    )


@dataclass
class Finding:
    block: str
    context: str
    readme: str
    twin: str
    compared: bool

    @property
    def differs(self) -> bool:
        return self.compared and self.readme != self.twin


def compare(block: Block, old: str, new: str) -> list[Finding]:
    """Every number of `old` (the README's text) against `new` (the twin's), line by line; a
    line of `new` missing from `old` or the other way round is a difference too."""
    findings: list[Finding] = []
    old_lines, new_lines = old.strip("\n").split("\n"), new.strip("\n").split("\n")
    for i in range(max(len(old_lines), len(new_lines))):
        o = old_lines[i] if i < len(old_lines) else ""
        n = new_lines[i] if i < len(new_lines) else ""
        volatile = any(o.startswith(v) or n.startswith(v) for v in block.volatile)
        o_nums, n_nums = NUMBER_RE.findall(o), NUMBER_RE.findall(n)
        line = (n or o).strip()
        label = NUMBER_RE.split(line)[0].strip()
        if not label and len(new_lines) > 1:
            label = f"row {_first_field(line)}"
        if o_nums == n_nums and not volatile and NUMBER_RE.sub("#", o) != NUMBER_RE.sub("#", n):
            findings.append(Finding(block.name, f"{label} (words)", o.strip(), n.strip(), True))
            continue
        for j in range(max(len(o_nums), len(n_nums))):
            findings.append(
                Finding(
                    block.name,
                    f"{label} #{j + 1}".strip() if len(n_nums) > 1 else label,
                    o_nums[j] if j < len(o_nums) else "(none)",
                    n_nums[j] if j < len(n_nums) else "(none)",
                    not volatile,
                )
            )
    return findings


def page_blocks(page: str) -> dict[str, Block]:
    return {name: b for name, b in BLOCKS.items() if b.page == page}


def check(
    text: str,
    quick: bool,
    runs: Runs,
    page: str = "README.md",
    only: set[str] | None = None,
) -> tuple[list[Finding], str, list[str]]:
    """The findings, the page's text with the twin's numbers, and the problems with the
    markers. `only`: the names of the blocks to run (the others are left as they are)."""
    blocks = page_blocks(page)
    found = {m["name"]: m for m in BLOCK_RE.finditer(text)}
    problems = [f"{page} block {n!r} is not one of the script's" for n in found if n not in blocks]
    problems += [f"no {page} block {n!r}" for n in blocks if n not in found]
    if problems:
        return [], text, problems
    findings: list[Finding] = []
    replacements: dict[str, str] = {}
    for name, block in blocks.items():
        old = found[name]["body"]
        if only is not None and name not in only:
            continue
        if quick and not block.quick:
            if block.partial is None:
                continue
            part = block.partial(runs)
            # a partial run's line holds the columns common to every run (the table's failure
            # columns depend on the other rows): compare those words only, keep the README's
            widths = {_first_field(line): len(line.split()) for line in part.splitlines()}
            widths = {k: n for k, n in widths.items() if k not in ("", "```")}
            findings += compare(block, _common(old, widths), _common(part, widths))
            new = old
        else:
            new = block.make(runs)
            findings += compare(block, old, new)
            new = keep_volatile(block, old, new)
        replacements[name] = new

    def put(m: re.Match) -> str:
        body = replacements.get(m["name"], m["body"])
        return f"<!-- readme_numbers: {m['name']} -->{body}<!-- /readme_numbers -->"

    return findings, BLOCK_RE.sub(put, text), []


def write_atomically(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, path.stat().st_mode & 0o777)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="the cheap subset (CI)")
    parser.add_argument("--update", action="store_true", help="rewrite the stale numbers")
    parser.add_argument(
        "--readme", type=Path, default=None, help="check this file's README blocks only"
    )
    parser.add_argument(
        "--only", default=None, help="comma-separated block names (default: every block)"
    )
    parser.add_argument(
        "--sweep-out", type=Path, default=None, help="keep the sweeps' files here (a rerun resumes)"
    )
    parser.add_argument("--all", action="store_true", help="print equal numbers too")
    args = parser.parse_args(argv)
    only = None if args.only is None else set(args.only.split(","))
    if only is not None and only - set(BLOCKS):
        print(f"error: no block {sorted(only - set(BLOCKS))}; blocks: {', '.join(BLOCKS)}",
              file=sys.stderr)  # fmt: skip
        return 2
    if args.readme is not None:
        pages = {"README.md": args.readme}
    else:
        pages = {b.page: ROOT / b.page for b in BLOCKS.values()}
        if only is not None:
            pages = {b.page: ROOT / b.page for b in BLOCKS.values() if b.name in only}

    findings: list[Finding] = []
    texts: dict[str, tuple[Path, str, str]] = {}
    problems: list[str] = []
    with tempfile.TemporaryDirectory(prefix="readme_numbers_") as scratch:
        runs = Runs(Path(scratch), args.sweep_out)
        for page, path in pages.items():
            text = path.read_text(encoding="utf-8")
            found, new_text, trouble = check(text, args.quick, runs, page, only)
            findings += found
            problems += trouble
            texts[page] = (path, text, new_text)
    for p in problems:
        print(f"error: {p}", file=sys.stderr)
    if problems:
        return 2
    width = max((len(f.block) + len(f.context) for f in findings), default=20) + 3
    print(f"{'number':<{width}}  {'quoted':>10}  {'twin now':>10}")
    for f in findings:
        mark = "DIFF" if f.differs else ("" if f.compared else "(not compared: the computer)")
        if f.differs or args.all or not f.compared:
            where = f"{f.block}: {f.context}"
            print(f"{where:<{width}}  {f.readme:>10}  {f.twin:>10}  {mark}".rstrip())
    stale = [f for f in findings if f.differs]
    blocks = sorted({f.block for f in stale})
    print(
        f"{len(findings)} numbers in {len({f.block for f in findings})} blocks"
        f"{' (quick)' if args.quick else ''}: {len(stale)} differ"
        + (f" (in {', '.join(blocks)})" if blocks else "")
    )
    if args.update:
        changed = [(path, old, new) for path, old, new in texts.values() if new != old]
        for path, old, _ in changed:
            if path.read_text(encoding="utf-8") != old:
                print(f"error: {path} changed while the commands ran; run again", file=sys.stderr)
                return 2
        for path, _, new in changed:
            write_atomically(path, new)
            print(f"rewrote {path}")
        return 0
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
