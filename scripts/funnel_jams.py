"""Funnel jams as a long-run rate: soak trials of a scenario, then jams per 1,000 seedlings
at risk with a 95 % interval and what each jam cost (docs/results.md, "Funnel jams").

    python scripts/funnel_jams.py --seeds 1-10 --seedlings 500 --out results/jams

runs `transplanter trial SCENARIO --set conveyor.rows=ROWS --seedlings N --seed S --json`
for each seed not yet in --out (a rerun resumes; --workers trials at once), then reads every
`seed_S.json` there. A seedling is *at risk* when no jam stands in the funnel as it is
judged (a jam standing, a released pot lands on it: that failure is the jam's, not a new
jam's), so the rate is jams / seedlings at risk, its interval Poisson's exact one
(scipy.stats.chi2). Each jam's cost is the failures judged while it stood, by kind.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from transplanter.studies.stats import parse_seeds, poisson_interval


def _run(scenario: str, seed: int, seedlings: int, rows: int, sets: list[str], out: Path) -> Path:
    target = out / f"seed_{seed}.json"
    if target.is_file():
        return target
    cmd = [sys.executable, "-m", "transplanter.cli", "trial", scenario, "--seed", str(seed),
           "--seedlings", str(seedlings), "--set", f"conveyor.rows={rows}", "--quiet",
           "--json", str(target)]  # fmt: skip
    for s in sets:
        cmd += ["--set", s]
    subprocess.run(cmd, check=False, capture_output=True)
    return target


STRIKE_WINDOW_S = 30.0
"""A strike this soon after a jam's release counts as following it (about 8 cycles)."""


def first_strike(r: dict) -> tuple[float | None, int, float | None]:
    """The trial's first lost-step event that cost seedlings: its time (None: none), the
    seedlings it cost, and how long after the last jam released before it (None: no jam)."""
    for i, e in enumerate(r.get("lost_step_events", [])):
        cost = sum(1 for s in r["per_seedling"]
                   if s.get("lost_step_event") == i and s["outcome"] != "success")  # fmt: skip
        if cost:
            released = [j.get("t_release_s") for j in r.get("funnel_jams", [])]
            before = [t for t in released if t is not None and t <= e["t_s"]]
            return e["t_s"], cost, (e["t_s"] - max(before)) if before else None
    return None, 0, None


def summarise(results: list[dict]) -> str:
    jams, at_risk, seedlings, cost, kinds = 0, 0, 0, [], {}
    after_jam, alone = [], []
    lines = []
    for r in results:
        t_strike, strike_cost, since = first_strike(r)
        if t_strike is not None:
            (after_jam if since is not None and since <= STRIKE_WINDOW_S else alone).append(
                strike_cost
            )
        per = [s for s in r["per_seedling"] if s["outcome"] not in ("not_run", "pending")]
        risk = sum(1 for s in per if s.get("after_jam") is None)
        these = r.get("funnel_jams", [])
        jams += len(these)
        at_risk += risk
        seedlings += len(per)
        for j in these:
            cost.append(j["later_failures"])
            for k, n in j["later_failures_by_kind"].items():
                kinds[k] = kinds.get(k, 0) + n
        first = these[0]["seedling"] if these else "-"
        strike = "no strike" if t_strike is None else (
            f"first strike at {t_strike:.1f} s cost {strike_cost}"
            + ("" if since is None else f", {since:.1f} s after a jam's release")
        )  # fmt: skip
        lines.append(f"  seed {r['seed']:>3}: {r['successes']:>4}/{len(per)} successes, "
                     f"{len(these)} jam(s), first at seedling {first}, "
                     f"{risk} seedlings at risk; {strike}")  # fmt: skip
    lo, hi = poisson_interval(jams, at_risk) if at_risk else (float("nan"),) * 2
    rate = 1000 * jams / at_risk if at_risk else float("nan")
    lines.append(
        f"{jams} funnel jams in {at_risk} seedlings at risk ({seedlings} judged, "
        f"{len(results)} trials): {rate:.2f} per 1,000 (95 % {1000 * lo:.2f}-{1000 * hi:.2f})"
    )
    if cost:
        by_kind = ", ".join(f"{n} {k}" for k, n in sorted(kinds.items(), key=lambda x: -x[1]))
        lines.append(f"failures while a jam stood: {sum(cost)} ({by_kind}); per jam "
                     f"{min(cost)}-{max(cost)}, mean {sum(cost) / len(cost):.1f}")  # fmt: skip
    lines.append(
        f"first strikes (a motor losing steps, nothing noticing): {len(after_jam)} within "
        f"{STRIKE_WINDOW_S:g} s of a jam's release, costing {sum(after_jam)} seedlings; "
        f"{len(alone)} with no jam released in the {STRIKE_WINDOW_S:g} s before, "
        f"costing {sum(alone)}"
    )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scenario", default="paper")
    p.add_argument("--seeds", default="1-10")
    p.add_argument("--seedlings", type=int, default=500)
    p.add_argument("--rows", type=int, default=100, help="conveyor.rows (the window keeps 12 live)")
    p.add_argument("--set", action="append", default=[], help="more scenario keys, as --set")
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--out", type=Path, required=True)
    args = p.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    seeds = parse_seeds(args.seeds)
    with ThreadPoolExecutor(args.workers) as pool:
        paths = list(pool.map(
            lambda s: _run(args.scenario, s, args.seedlings, args.rows, args.set, args.out), seeds
        ))  # fmt: skip
    results = [json.loads(path.read_text()) for path in paths if path.is_file()]
    missing = len(seeds) - len(results)
    print(summarise(results))
    if missing:
        print(f"{missing} trial(s) wrote no result (rerun to retry)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
