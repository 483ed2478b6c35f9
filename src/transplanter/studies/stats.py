"""Pooled success over several trials, with an interval from the spread between trials.

Picks within one trial are not independent: one lost-step strike can spoil every later pick
of that trial. The pooled interval therefore resamples whole trials (a cluster bootstrap,
`scipy.stats.bootstrap` with paired successes and counts), and is never narrower than the
Wilson interval over all picks, which is what independent picks would give.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from transplanter.twin.results import wilson_interval

__all__ = [
    "PooledRate",
    "SETTING_FIELDS",
    "aggregate",
    "mean_interval",
    "parse_seeds",
    "pool_runs",
    "pooled_rate",
    "seedlings_to_decide",
]

BOOTSTRAP_RESAMPLES = 9999
BOOTSTRAP_SEED = 20201  # fixed: the same trials give the same interval
CI_DIGITS = 12
"""Decimals an interval's ends are rounded to, after clipping to [0, 1]: the floating-point
noise around 0 and 1 (Wilson's 0 of 6 has a lower end of 2.8e-17, 10 of 10 an upper one of
0.9999999999999999) never reaches settings.csv, compare.csv or a JSON."""


@dataclass(frozen=True)
class PooledRate:
    successes: int
    seedlings: int
    trials: int
    success_rate: float
    ci95: tuple[float, float]
    method: str

    def to_dict(self) -> dict:
        return {
            "successes": self.successes,
            "seedlings": self.seedlings,
            "trials": self.trials,
            "success_rate": self.success_rate,
            "ci95": list(self.ci95),
            "method": self.method,
        }


def pooled_rate(successes: Sequence[int], seedlings: Sequence[int]) -> PooledRate:
    """Pooled success rate of trials with these successes and seedlings, 95 % interval."""
    k = np.asarray(successes, dtype=float)
    n = np.asarray(seedlings, dtype=float)
    if k.shape != n.shape or k.ndim != 1 or k.size == 0 or (n <= 0).any() or (k > n).any():
        raise ValueError("pooled_rate needs one (successes <= seedlings > 0) pair per trial")
    total_k, total_n = int(k.sum()), int(n.sum())
    rate = total_k / total_n
    lo, hi = wilson_interval(total_k, total_n)
    method = "Wilson over all picks"
    rates = k / n
    if k.size >= 3 and np.ptp(rates) > 0:
        from scipy import stats

        boot = stats.bootstrap(
            (k, n),
            lambda a, b: a.sum() / b.sum(),
            paired=True,
            vectorized=False,
            n_resamples=BOOTSTRAP_RESAMPLES,
            method="percentile",
            random_state=np.random.default_rng(BOOTSTRAP_SEED),
        )
        b_lo, b_hi = float(boot.confidence_interval.low), float(boot.confidence_interval.high)
        if b_lo < lo or b_hi > hi:
            method = "cluster bootstrap over trials (at least the Wilson interval)"
        lo, hi = min(lo, b_lo), max(hi, b_hi)
    lo, hi = (round(min(1.0, max(0.0, end)), CI_DIGITS) for end in (lo, hi))
    return PooledRate(total_k, total_n, int(k.size), rate, (lo, hi), method)


def seedlings_to_decide(rate: float, floor: float, limit: int = 10**7) -> int | None:
    """Seedlings (picks) that would put the 95 % Wilson interval of a success rate `rate`
    wholly on one side of `floor`, were the rate what it is now (the smallest such n); None
    when no number would (the rate is the floor) or more than `limit` would. What
    `transplanter compare` prints for a row whose interval holds its floor; the cluster
    bootstrap over trials can widen an interval past Wilson's, so it is a lower bound."""
    if not 0.0 <= rate <= 1.0 or rate == floor:
        return None

    def decided(n: int) -> bool:
        lo, hi = wilson_interval(round(rate * n), n)
        return lo >= floor if rate > floor else hi < floor

    hi = 1
    while not decided(hi):
        hi *= 2
        if hi > limit:
            return None
    lo = hi // 2
    while hi - lo > 1:  # decided(hi), not decided(lo) (rounding aside: the first n found)
        mid = (lo + hi) // 2
        if decided(mid):
            hi = mid
        else:
            lo = mid
    return hi


def mean_interval(values: Sequence[float]) -> tuple[float, float] | None:
    """The 95 % Student-t interval of the mean of per-trial values (`scipy.stats`); None for
    fewer than two. The same value in every trial (a planned cycle) gives a zero-width one."""
    v = np.asarray([float(x) for x in values], dtype=np.float64)
    if v.size < 2:
        return None
    mean = float(v.mean())
    sd = float(v.std(ddof=1))
    if sd == 0.0:
        return mean, mean
    from scipy import stats

    half = float(stats.t.ppf(0.975, v.size - 1)) * sd / float(np.sqrt(v.size))
    return mean - half, mean + half


def poisson_interval(k: int, exposure: float) -> tuple[float, float]:
    """The exact 95 % interval of a Poisson rate: `k` events over `exposure` (units of
    exposure, e.g. seedlings), from the chi-square quantiles (Garwood's interval)."""
    from scipy.stats import chi2

    if not exposure > 0:
        raise ValueError(f"a rate needs an exposure > 0, got {exposure!r}")
    lo = chi2.ppf(0.025, 2 * k) / 2 if k else 0.0
    hi = chi2.ppf(0.975, 2 * k + 2) / 2
    return float(lo) / exposure, float(hi) / exposure


def parse_seeds(text: str) -> list[int]:
    """'41-44' or '1,3,5-7' -> seeds, in order; ValueError naming the bad part."""
    seeds: list[int] = []
    for part in text.split(","):
        part = part.strip()
        lo, dash, hi = part.partition("-")
        if not (lo.isascii() and lo.isdigit()) or (dash and not (hi.isascii() and hi.isdigit())):
            raise ValueError(f"seeds {text!r}: {part!r} is not N or N-M (whole numbers >= 0)")
        a, b = int(lo), int(hi) if dash else int(lo)
        if b < a:
            raise ValueError(f"seeds {text!r}: {part!r} runs backwards")
        if b - a >= 10000:
            raise ValueError(f"seeds {text!r}: {part!r} is more than 10000 trials")
        seeds.extend(range(a, b + 1))
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds {text!r}: a seed is given twice")
    return seeds


SETTING_FIELDS = (
    "runs",
    "errors",
    "successes",
    "seedlings",
    "success_rate",
    "ci95_low",
    "ci95_high",
    "ci_method",
    "cycle_time_s",
)
"""The columns of a sweep's settings table after the varied keys."""


def aggregate(
    rows: Iterable[Mapping[str, Any]], keys: Sequence[str], means: Sequence[str] = ()
) -> list[dict[str, Any]]:
    """One row per distinct value of `keys` (in first-seen order): the runs pooled with
    `stats.pooled_rate` (runs that raised or were refused are counted in `errors` only) and
    the mean cycle time over all their timed cycles; each of `means` (a job's own columns)
    averaged over the counted runs that have it."""
    groups: dict[str, list[Mapping[str, Any]]] = {}
    for row in rows:
        groups.setdefault(json.dumps([row[k] for k in keys]), []).append(row)
    out = []
    for members in groups.values():
        agg: dict[str, Any] = {k: members[0][k] for k in keys}
        counted = [r for r in members if r["successes"] is not None]
        agg.update(runs=len(members), errors=sum(r["error"] is not None for r in members))
        agg.update({f: None for f in SETTING_FIELDS[2:]})
        if counted:
            pooled, agg["cycle_time_s"] = pool_runs(counted)
            agg.update(
                successes=pooled.successes,
                seedlings=pooled.seedlings,
                success_rate=pooled.success_rate,
                ci95_low=pooled.ci95[0],
                ci95_high=pooled.ci95[1],
                ci_method=pooled.method,
            )
        for name in means:
            values = [r[name] for r in counted if r.get(name) is not None]
            agg[name] = sum(values) / len(values) if values else None
        out.append(agg)
    return out


def pool_runs(rows: Sequence[Mapping[str, Any]]) -> tuple[PooledRate, float | None]:
    """Runs that were counted (none refused or raised), pooled: their success with
    `stats.pooled_rate`, and the mean cycle time over all their timed cycles (None if none
    was timed)."""
    pooled = pooled_rate([r["successes"] for r in rows], [r["seedlings"] for r in rows])
    n = sum(r["cycles"] or 0 for r in rows)
    cycle = sum(r["cycle_time_s"] * r["cycles"] for r in rows if r["cycles"]) / n if n else None
    return pooled, cycle
