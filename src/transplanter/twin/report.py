"""Presenting trial results: the summary table, a progress bar, text safe for a terminal."""

from __future__ import annotations

from transplanter.twin.results import TrialResult

__all__ = ["format_summary", "printable", "progress_bar"]


def printable(text: str) -> str:
    """Text safe to print on a terminal: control characters shown escaped (`\\x1b`)."""
    return "".join(
        c if c.isprintable() or c == " " else c.encode("unicode_escape").decode("ascii")
        for c in text
    )


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
        (
            "cycle time",
            "n/a"
            if d["cycle_time_s"] is None
            else f"{d['cycle_time_s']:.3f} s mean, sd {d['cycle_time_sd_s'] or 0:.3f} s",
        ),
        ("seedlings per minute", f"{d['seedlings_per_min']:.1f}"),
        ("simulated time", f"{d['sim_time_s']:.1f} s"),
        ("wall time", f"{d['wall_time_s']:.1f} s"),
        ("real-time factor", f"{d['real_time_factor']:.1f}x" if d["real_time_factor"] else "n/a"),
    ]
    rows += [(f"failures: {k}", str(v)) for k, v in d["failures"].items()]
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
    if d["fault"]:
        rows.append(("firmware fault", printable(d["fault"])))
        rows.append(("fault kind", str(d["fault_kind"])))
    if d["interrupted"]:
        rows.append(("interrupted", f"yes, after {result.judged} seedlings"))
    if result.recording_error:
        rows.append(("recording", f"FAILED: {printable(result.recording_error)}"))
    rows += [("warning", printable(w)) for w in d["warnings"]]
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"{k:<{width}}  {v}" for k, v in rows)


def progress_bar(total: int, enabled: bool):
    """A tqdm bar over the trial's seedlings, and the callback run_trial updates it with;
    (None, None) when disabled."""
    if not enabled:
        return None, None
    from tqdm import tqdm

    bar = tqdm(total=total, unit="seedling", dynamic_ncols=True)

    def update(done: int, sim_t: float) -> None:
        bar.set_postfix_str(f"sim {sim_t:.1f} s", refresh=False)
        bar.update(done - bar.n)

    return bar, update
