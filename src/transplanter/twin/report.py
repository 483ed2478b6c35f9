"""Presenting trial results: the summary table, a progress bar, text safe for a terminal."""

from __future__ import annotations

from transplanter.twin.results import DAMAGE_KINDS, TrialResult

__all__ = [
    "SEEDLING_WALL_S",
    "estimate_line",
    "format_failures_table",
    "format_seed_row",
    "format_summary",
    "printable",
    "progress_bar",
    "seed_row_header",
    "seedling_wall_s",
    "seeds_bar",
]

SEEDLING_WALL_S = 0.25
"""Wall time of one seedling of the paper trial (8 rows of 5 pots, every pot a body) on one
core of the 2-core reference machine, start-up included: `python benchmarks/bench_belt.py
--rows 8,24,100 --seedlings 30` (and 40) measured 0.23-0.25 s a seedling, rounded up. What the
estimates before long work are made of; a faster machine finishes sooner."""
REFERENCE_POTS = 40
POTS_EXPONENT = 0.93
"""How the cost of a seedling grows with the pots that are *bodies* in the physics (the window
of live rows: min(conveyor.rows, conveyor.live_rows) x cols; the pots beyond it cost nothing).
Measured on the reference machine with benchmarks/bench_belt.py (`--one ROWS,LIVE,N,1`: the
trial's wall time per seedling, one run at a time, each twice, the lower kept): 40
bodies (8 rows) 0.21 s, 60 (24 or 100 rows, live_rows 12: the same) 0.28 s, 120 (24 rows,
live_rows 24) 0.45 s, 240 (48 rows) 0.95 s, 500 (100 rows, a body per pot) 2.2 s: a power
law through 40 and 500, (500/40)^0.93 = 10.5, which with the 0.25 s above lies 1.2-1.5x above
every one of them. The README's soak (100 rows, live_rows 12, 500 seedlings) measured 188 s,
0.38 s a seedling, twice (more than its first 40 seedlings cost): estimated 0.36 s."""
ESTIMATE_ABOVE_S = 60.0
"""Work estimated to take longer than this is announced before it starts."""


def seedling_wall_s(pots: int = REFERENCE_POTS) -> float:
    """The estimated wall time of one seedling (s) with ``pots`` pots as bodies in the physics
    (min(rows, live_rows) x cols) on one core of the reference machine."""
    return SEEDLING_WALL_S * max(1.0, pots / REFERENCE_POTS) ** POTS_EXPONENT


def estimate_line(seedlings: int, pots: int = REFERENCE_POTS, workers: int = 1) -> str | None:
    """'about 12 min of work (...)' for ``seedlings`` seedlings of trials with ``pots`` pots
    as bodies in the physics (the window of live rows: min(rows, live_rows) x cols, not the
    belt's length), on ``workers`` cores; None when it is estimated under a minute."""
    each = seedling_wall_s(pots)
    seconds = seedlings * each / max(1, workers)
    if seconds <= ESTIMATE_ABOVE_S:
        return None
    if seconds < 3600:
        shown = f"{seconds / 60:.0f} min"
    elif seconds < 48 * 3600:
        shown = f"{seconds / 3600:.1f} h"
    else:
        shown = f"{seconds / 86400:.1f} days"
    cores = f" on {workers} cores" if workers > 1 else " on one core"
    return (
        f"about {shown} of work: {seedlings} seedlings{cores} at ~{each:.2g} s each with "
        f"{pots} pots as bodies on the belt (the reference machine's cost; Ctrl-C keeps what "
        "finished)"
    )


def _failures_text(failures: dict[str, int]) -> str:
    return ", ".join(f"{kind} {n}" for kind, n in failures.items() if n) or "-"


def seed_row_header() -> str:
    """The header of `trial --seeds`'s per-seed lines."""
    return f"{'seed':>8}  {'success':>9}  {'rate':>7}  {'clustered':<9}  failures"


def format_seed_row(seed: int, result: TrialResult) -> str:
    """One seed's line of `trial --seeds`: successes, rate, whether failures cluster, and the
    failures by kind as words ('not_gripped 3, knocked_over 1')."""
    d = result.to_dict()
    rate = f"{100 * d['success_rate']:.1f} %"
    cluster = "yes" if d["failures_clustered"] else "no"
    success = f"{d['successes']}/{d['seedlings']}"
    return f"{seed:>8}  {success:>9}  {rate:>7}  {cluster:<9}  {_failures_text(d['failures'])}"


def format_failures_table(seeds, results) -> str:
    """Failures by kind as columns (only the kinds that occurred), a row per seed and a
    total row; '' when nothing failed."""
    rows = [(seed, r.to_dict()["failures"]) for seed, r in zip(seeds, results, strict=False)]
    kinds = [k for k in (rows[0][1] if rows else {}) if any(f.get(k) for _, f in rows)]
    if not kinds:
        return ""
    widths = [max(len(k), 5) for k in kinds]
    lines = [f"{'seed':>8}  " + "  ".join(k.rjust(w) for k, w in zip(kinds, widths, strict=True))]
    for seed, failures in rows:
        cells = (str(failures.get(k, 0)).rjust(w) for k, w in zip(kinds, widths, strict=True))
        lines.append(f"{seed:>8}  " + "  ".join(cells))
    totals = (
        str(sum(f.get(k, 0) for _, f in rows)).rjust(w) for k, w in zip(kinds, widths, strict=True)
    )
    lines.append(f"{'all':>8}  " + "  ".join(totals))
    return "failures by kind:\n" + "\n".join(lines)


def printable(text: str) -> str:
    """Text safe to print on a terminal: control characters shown escaped (`\\x1b`)."""
    return "".join(
        c if c.isprintable() or c == " " else c.encode("unicode_escape").decode("ascii")
        for c in text
    )


def definitions_block(definitions: dict[str, str]) -> str:
    """A job's definitions as the summary prints them under `--explain`."""
    return "definitions:\n" + "\n".join(f"  {k}: {v}" for k, v in definitions.items())


def _throughput(d: dict) -> str:
    """The summary's plants per hour: the rate at the pick pitch, and what it counts."""
    if d["plants_per_hour"] is None:
        return "n/a (a rate needs two picks started)"
    counted = (
        f"over {d['pick_pitch_picks']} picks in whole rows: cycles, indexes and recoveries"
        if d["pick_pitch_whole_rows"]
        else f"over {d['pick_pitch_picks']} picks within one row: no index counted"
    )
    return (
        f"{d['plants_per_hour']:.0f} (a pick every {d['pick_pitch_s']:.3f} s start to start, "
        f"{counted}; the homing before the first, {d['first_pick_start_s']:.2f} s, left out)"
    )


def _placed(d: dict) -> str:
    """The summary's shift figure: the seedlings placed an hour of the whole run."""
    if d["placed_per_hour"] is None:
        return "n/a"
    return (
        f"{d['placed_per_hour']:.0f} over the whole run ({d['successes']} placed in "
        f"{d['sim_time_s']:.1f} s: the homing, indexes, failed picks and recoveries included)"
    )


def _damage(d: dict) -> str:
    """The summary's damage: the seedlings whose shoot was bent too far or crushed, and the
    largest bend of any shoot."""
    kinds = {k: d["failures"].get(k, 0) for k in DAMAGE_KINDS}
    n = sum(kinds.values())
    bend = f"largest shoot bend {d['max_stem_bend_deg']:.1f} deg"
    if not n:
        return f"none (no shoot bent past metrics.damage_bend_deg or crushed); {bend}"
    shown = ", ".join(f"{k} {v}" for k, v in kinds.items() if v)
    share = 100 * n / max(d["seedlings"], 1)
    return f"{n}/{d['seedlings']} seedlings ({share:.1f} %: {shown}); {bend}"


def format_summary(result: TrialResult) -> str:
    """The trial's numbers as an aligned two-column table."""
    d = result.to_dict()
    if d["success_rate_ci95"] is None:
        interval = "no single-trial interval: failures cluster (pool seeds: --seeds)"
    else:
        lo, hi = d["success_rate_ci95"]
        interval = f"95 % CI {100 * lo:.1f}-{100 * hi:.1f} %"
    rows = [
        ("scenario", f"{printable(d['scenario'])} (seed {d['seed']})"),
        ("valid", "yes" if d["valid"] else f"NO: {printable(d['invalid_reason'])}"),
        ("seedlings", f"{d['seedlings']}"),
        (
            "success rate",
            f"{100 * d['success_rate']:.1f} % ({d['successes']}/{d['seedlings']}), {interval}",
        ),
        ("plants per hour", _throughput(d)),
        ("placed per hour", _placed(d)),
        (
            "cycle time",
            "n/a"
            if d["cycle_time_s"] is None
            else f"{d['cycle_time_s']:.3f} s mean, sd {d['cycle_time_sd_s'] or 0:.3f} s (a "
            "pot's approach to the end of its release)",
        ),
        ("damage", _damage(d)),
        ("simulated time", f"{d['sim_time_s']:.1f} s"),
        ("wall time", f"{d['wall_time_s']:.1f} s"),
        ("real-time factor", f"{d['real_time_factor']:.1f}x" if d["real_time_factor"] else "n/a"),
    ]
    # only the failure kinds that occurred (every kind, zeros too, is in the JSON)
    occurred = [(f"failures: {k}", str(v)) for k, v in d["failures"].items() if v]
    rows += occurred or [("failures:", "none")]
    realign = max((abs(r["offset_mm"]) for r in d["belt_realignments"]), default=0.0)
    rows.append(
        (
            "belt off its hold",
            f"{d['max_belt_displacement_mm']:.3f} mm at most during a pick; "
            f"{realign:.3f} mm at most taken back by an index",
        )
    )
    bends = result.stem_bends_in_tube
    if bends:
        rows.append(
            (
                "shoot bend",
                f"{max(bends):.1f} deg at most, {sum(bends) / len(bends):.1f} deg mean over "
                "the pots in the tube (largest sway from the pot's axis, approach to landing)",
            )
        )
    pressed = [r.shoot_pressed_deg for r in result.per_seedling if r.shoot_touched_by]
    if pressed:
        rows.append(
            (
                "shoots touched",
                f"{len(pressed)} by the gripper's bridge, bent {max(pressed):.1f} deg at most "
                "(the bridge too low over them: gripper.bridge_clearance_mm, taught.z_low_mm)",
            )
        )
    for i, e in enumerate(d["lost_step_events"]):
        cost = sum(r.lost_step_event == i for r in result.per_seedling if r.outcome != "success")
        touching = ", ".join(e["contacts"]) or "nothing"
        after = "stall detected, re-homed" if e.get("detected") else f"cost {cost} seedlings"
        rows.append(
            (
                f"lost steps #{i}",
                f"t {e['t_s']:.3f} s, motor {e['motor'] + 1}, {e['microsteps']} microsteps, "
                f"touching {printable(touching)}; {after}",
            )
        )
    for i, j in enumerate(d["funnel_jams"]):
        tilt = "" if j["tilt_deg"] is None else f", tilted {j['tilt_deg']:.0f} deg"
        kinds = ", ".join(f"{n} {k}" for k, n in j["later_failures_by_kind"].items())
        rows.append(
            (
                f"funnel jam #{i}",
                f"seedling {j['seedling']} (pot {j['pot']}) released at {j['t_release_s']:.2f} s "
                f"stuck {abs(j['below_top_mm']):.1f} mm "
                f"{'below' if j['below_top_mm'] >= 0 else 'above'} the funnel's top, "
                f"{j['off_axis_mm']:.1f} mm off its axis{tilt}; {j['later_failures']} later "
                f"failures while it stood"
                + (f" ({kinds})" if kinds else "")
                + (
                    ""
                    if j["next_strike"] is None
                    else f"; the next strike {j['next_strike_after_s']:.1f} s after its release "
                    f"(lost steps #{j['next_strike']}, cost {j['next_strike_cost']} seedlings)"
                ),
            )
        )
    if d["fault"]:
        rows.append(("firmware fault", printable(d["fault"])))
        rows.append(("fault kind", str(d["fault_kind"])))
    if d["interrupted"]:
        rows.append(("interrupted", f"yes, after {result.judged} seedlings"))
    if result.recording_error:
        rows.append(("recording", f"FAILED: {printable(result.recording_error)}"))
    rows += [("warning", printable(w)) for w in d["warnings"]]
    # the labels' column as wide as every failure kind's would make it: the same layout
    # whichever kinds occurred
    width = max(max(len(k) for k, _ in rows), *(len(f"failures: {k}") for k in d["failures"]))
    return "\n".join(f"{k:<{width}}  {v}" for k, v in rows)


def progress_bar(total: int | None, enabled: bool, unit: str = "seedling"):
    """A tqdm bar over the trial's units (seedlings, cells, tomatoes: `unit`, singular), and
    the callback a trial updates it with, `update(done, sim_t, total=None)` (a total known
    only once the run has planned its work, as the trays' cells); (None, None) when
    disabled."""
    if not enabled:
        return None, None
    from tqdm import tqdm

    bar = tqdm(total=total, unit=unit, dynamic_ncols=True)

    def update(done: int, sim_t: float, total: int | None = None) -> None:
        if total is not None and bar.total != total:
            bar.total = total
            bar.refresh()
        bar.set_postfix_str(f"sim {sim_t:.1f} s", refresh=False)
        bar.update(done - bar.n)

    return bar, update


class _SeedsBar:
    """One tqdm bar over the seedlings of every seed of `trial --seeds`."""

    def __init__(self, total: int) -> None:
        from tqdm import tqdm

        self.bar = tqdm(total=total, unit="seedling", dynamic_ncols=True)

    def for_trial(self, seed: int, before: int):
        """The progress callback of one seed's trial, `before` seedlings into the bar."""

        def update(done: int, sim_t: float) -> None:
            self.bar.set_postfix_str(f"seed {seed}, sim {sim_t:.1f} s", refresh=False)
            self.bar.update(before + done - self.bar.n)

        return update

    def write(self, line: str) -> None:
        """A line printed above the bar (stdout), the bar redrawn below it."""
        import sys

        self.bar.write(line, file=sys.stdout)

    def close(self) -> None:
        self.bar.close()


def seeds_bar(total: int, enabled: bool) -> _SeedsBar | None:
    """The bar over all seeds' seedlings of `trial --seeds` (None when not on a terminal)."""
    return _SeedsBar(total) if enabled else None
