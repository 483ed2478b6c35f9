"""Orthogonal designs and their range analysis (pure numpy), as the plug-seedling papers
report them: Zhao, Cheng, Dong, Ma, Xiong and Tong, *Research on the End Effector and Optimal
Motion Control Strategy for a Plug Seedling Transplanting Parallel Robot* (Agriculture 2022),
Table 2: an L9(3^4) test of substrate moisture (A), seedling age (B) and extraction
acceleration (C), each run scored, and per factor the mean score at each level (k1, k2, k3),
its range R = max k - min k, the factors ordered by R and the best level of each.

The paper's comprehensive score (its Eq. 1) weighs four indices, each turned into a membership
(x - min) / (max - min) over the nine runs: 0.3 healthy-seedling success + 0.3 inferior-
seedling success + 0.2 substrate retention + 0.2 substrate cleanness (recomputed from its
Table 2 in this order, these weights give its scores within 0.04). `twin_score` is that score
from the two indices the twin measures.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "L9",
    "FactorRange",
    "comprehensive_score",
    "format_range_table",
    "membership",
    "range_analysis",
    "twin_score",
]

L9 = np.array(
    [
        [1, 1, 1, 1],
        [1, 2, 2, 2],
        [1, 3, 3, 3],
        [2, 1, 2, 3],
        [2, 2, 3, 1],
        [2, 3, 1, 2],
        [3, 1, 3, 2],
        [3, 2, 1, 3],
        [3, 3, 2, 1],
    ]
)
"""The standard L9(3^4) array: nine runs, up to four factors at levels 1-3; its first three
columns are the paper's runs (A B C = 111, 122, 133, 212, 223, 231, 313, 321, 332)."""

PAPER_WEIGHTS = (0.3, 0.3, 0.2, 0.2)
"""Eq. 1: healthy-seedling success, inferior-seedling success, retention, cleanness."""


@dataclass(frozen=True)
class FactorRange:
    """One factor's row of a range analysis: the mean response at each level, the range and
    the level with the highest (or, for a response to minimise, lowest) mean."""

    name: str
    k: tuple[float, ...]
    r: float
    best: int  # 1-based level


def membership(values: Sequence[float]) -> np.ndarray:
    """(x - min) / (max - min) over the runs; all 0 when every run has the same value."""
    x = np.asarray(values, dtype=float)
    span = x.max() - x.min()
    return np.zeros_like(x) if span == 0 else (x - x.min()) / span


def comprehensive_score(
    indices: Sequence[Sequence[float]], weights: Sequence[float] = PAPER_WEIGHTS
) -> np.ndarray:
    """Eq. 1: the weighted sum of each index's membership over the runs. `indices` holds one
    sequence per index (each over the runs), in the order of `weights`."""
    if len(indices) != len(weights):
        raise ValueError(f"{len(indices)} indices for {len(weights)} weights")
    return sum(w * membership(x) for w, x in zip(weights, indices, strict=True))


def twin_score(success: Sequence[float], retention: Sequence[float]) -> np.ndarray:
    """Eq. 1 from the twin's two indices. The twin's inferior seedling is pulled by the same
    claws out of the same substrate as a healthy one, so its success is the healthy one's and
    its cleanness (substrate leaving the cell with it) the retention: Eq. 1 becomes
    0.6 membership(success) + 0.4 membership(retention)."""
    return comprehensive_score([success, success, retention, retention])


def range_analysis(
    levels: np.ndarray, values: Sequence[float], names: Sequence[str], maximise: bool = True
) -> list[FactorRange]:
    """k1..kn (the mean of `values` over the runs at each level), R and the best level of
    each factor; `levels` is (runs, factors) of 1-based levels. In the factors' order."""
    lv = np.asarray(levels, dtype=int)
    y = np.asarray(values, dtype=float)
    if lv.ndim != 2 or lv.shape[0] != y.size or lv.shape[1] != len(names):
        raise ValueError("levels must be (runs, factors) with one value per run and a name each")
    out = []
    for f, name in enumerate(names):
        present = sorted(set(lv[:, f].tolist()))
        k = tuple(float(y[lv[:, f] == level].mean()) for level in present)
        best = present[int(np.argmax(k) if maximise else np.argmin(k))]
        out.append(FactorRange(name, k, max(k) - min(k), best))
    return out


def order(ranges: Sequence[FactorRange]) -> list[FactorRange]:
    """The factors by falling R (the paper's "order of factors")."""
    return sorted(ranges, key=lambda fr: -fr.r)


LETTERS = "ABCDEFGH"


def format_range_table(
    title: str, ranges: Sequence[FactorRange], digits: int = 3, letters: str = LETTERS
) -> str:
    """The range analysis as the paper prints it: a row per k and R, a column per factor,
    then the order of the factors and the best combination."""
    names = [f"{letters[i]} {fr.name}" for i, fr in enumerate(ranges)]
    width = max(12, *(len(n) for n in names))
    lines = [title, " " * 4 + "".join(f"  {n:>{width}}" for n in names)]
    nk = max(len(fr.k) for fr in ranges)
    for i in range(nk):
        cells = [f"{fr.k[i]:.{digits}f}" if i < len(fr.k) else "-" for fr in ranges]
        lines.append(f"k{i + 1:<3}" + "".join(f"  {c:>{width}}" for c in cells))
    lines.append("R   " + "".join(f"  {fr.r:>{width}.{digits}f}" for fr in ranges))
    ranked = order(ranges)
    letter = {fr.name: letters[i] for i, fr in enumerate(ranges)}
    text = letter[ranked[0].name]
    for prev, fr in zip(ranked, ranked[1:], strict=False):
        text += (" = " if _same(prev.r, fr.r) else " > ") + letter[fr.name]
    lines.append("order: " + text)
    best = []
    for fr in ranges:  # levels tied with the best are named too: A1|A2
        top = fr.k[fr.best - 1]
        tied = [i + 1 for i, k in enumerate(fr.k) if _same(k, top)]
        best.append("|".join(f"{letter[fr.name]}{level}" for level in tied))
    lines.append("best levels: " + " ".join(best))
    return "\n".join(lines)


def _same(a: float, b: float) -> bool:
    """Equal but for rounding (a tie of two means or two ranges)."""
    return abs(a - b) <= 1e-9 * max(1.0, abs(a), abs(b))


RESPONSES = (
    ("success_rate", "success", True),
    ("substrate_retention", "retention", True),
    ("score", "score (Eq. 1 from success and retention)", True),
    ("cycle_time_s", "cycle s", False),
)
"""The responses a sweep's range analysis ranks: (column, title, maximise)."""


def _responses(table: Sequence[dict]) -> dict[str, np.ndarray]:
    """Each response column present in every row of `table` (plus the twin's score when both
    of its indices are), over the rows."""
    out: dict[str, np.ndarray] = {}
    for col, _, _ in RESPONSES:
        values = [_value(r, col) for r in table]
        if col != "score" and table and all(v is not None for v in values):
            out[col] = np.array(values, dtype=float)
    if "success_rate" in out and "substrate_retention" in out:
        out["score"] = twin_score(out["success_rate"], out["substrate_retention"])
    return out


def _value(row: dict, col: str) -> float | None:
    """A response of a row; the retention of a row where no plug arrived is 0 (no substrate
    was delivered), as the paper's runs count what reaches the target cell."""
    v = row.get(col)
    if v is None and col == "substrate_retention" and row.get("success_rate") == 0:
        return 0.0
    return v


def sweep_range_analysis(
    axes: Sequence[tuple[str, Sequence]],
    settings: Sequence[dict],
    rows: Sequence[dict] = (),
) -> tuple[str, list[dict]]:
    """The range analysis of a finished sweep: `axes` (key, values in level order), its
    settings table (one row per setting, seeds pooled) and its runs (for the spread of R
    over the seeds). Returns the text printed after the sweep and the CSV rows."""
    keys = [k for k, _ in axes]
    levels = np.array(
        [[list(values).index(s[k]) + 1 for k, values in axes] for s in settings], dtype=int
    )
    names = [k.split(".", 1)[1] if "." in k else k for k in keys]
    responses = _responses(settings)
    seeds = sorted({r["seed"] for r in rows})
    lines = [
        f"range analysis over {len(settings)} settings ("
        + ", ".join(f"{LETTERS[i]} = {k}: levels {', '.join(map(str, v))}" for i, (k, v)
                    in enumerate(axes))
        + ")"
    ]  # fmt: skip
    lines.append("run  " + " ".join(LETTERS[i] for i in range(len(keys))) + "  "
                 + "  ".join(f"{c:>12}" for c in responses))  # fmt: skip
    for i, lv in enumerate(levels):
        lines.append(f"{i + 1:>3}  " + " ".join(map(str, lv)) + "  "
                     + "  ".join(f"{responses[c][i]:>12.4f}" for c in responses))  # fmt: skip
    csv_rows: list[dict] = []
    for col, title, maximise in RESPONSES:
        if col not in responses:
            continue
        ranges = range_analysis(levels, responses[col], names, maximise)
        lines += ["", format_range_table(f"{title}:", ranges, digits=3)]
        spread = _seed_spread(axes, rows, seeds, col, names, maximise)
        if spread:
            lines.append(
                f"R over the {len(seeds)} seeds one at a time: "
                + ", ".join(f"{LETTERS[i]} {lo:.3f}-{hi:.3f}" for i, (lo, hi) in enumerate(spread))
            )
        rank = {fr.name: n + 1 for n, fr in enumerate(order(ranges))}
        for i, fr in enumerate(ranges):
            csv_rows.append(
                {
                    "response": col,
                    "factor": f"{LETTERS[i]} {keys[i]}",
                    **{f"k{j + 1}": fr.k[j] for j in range(len(fr.k))},
                    "R": fr.r,
                    "rank": rank[fr.name],
                    "best_level": fr.best,
                    "best_value": list(axes[i][1])[fr.best - 1],
                    "R_seed_min": spread[i][0] if spread else None,
                    "R_seed_max": spread[i][1] if spread else None,
                }
            )
    return "\n".join(lines), csv_rows


def _seed_spread(axes, rows, seeds, col, names, maximise):
    """(min, max) of each factor's R when the analysis is done on each seed's runs alone;
    empty with fewer than two seeds or a run without the response."""
    if len(seeds) < 2:
        return []
    keys = [k for k, _ in axes]
    per: list[list[float]] = []
    for seed in seeds:
        mine = [r for r in rows if r["seed"] == seed]
        responses = _responses(mine)
        if col not in responses or len(mine) < 2:
            return []
        lv = np.array([[list(v).index(r[k]) + 1 for k, v in axes] for r in mine], dtype=int)
        per.append([fr.r for fr in range_analysis(lv, responses[col], names, maximise)])
    arr = np.array(per)
    return [(float(arr[:, i].min()), float(arr[:, i].max())) for i in range(len(keys))]
