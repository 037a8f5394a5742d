"""The growth rule: did a resource of the node grow beyond noise? Pure (rows of numbers in, verdicts out).

Two views, each with the same estimator, "late minus early by medians" (``late_minus_early``): the median of
the last third of a series minus the median of its first third, so one odd sample moves neither end.

* **Within a lifetime**, after the warm-up: the samples of one node process from ``warmup_s`` of age on. A leak
  in the node shows here as its late samples above its early ones.
* **Across lifetimes, at the same age**: for each age every lifetime was sampled at, the series of that age's
  values over the lifetimes in order; the median over the ages of their late-minus-early. Each lifetime is a
  fresh process, so this sees what outlives a node: ghosts of the dead ones in the DDS graphs, the sim's
  matched readers, or anything a node inherits from its predecessors. Comparing like ages keeps a node's
  start-up (discovery, first transitions) from reading as growth.

A metric grew if either view exceeds its threshold (``THRESHOLDS``: from the noise of measured runs, docs/soak.md).

Memory is judged as ``anon_net_kb``: the node's private memory (RssAnon, what its allocators hold) less the most
its flight ring has held so far in the lifetime (its own count on /diagnostics).

* Private, not all of VmRSS: the rest is pages of mapped files, a shared library's code read in the first time a
  path through it runs (192 kB of numpy's ``_multiarray_umath`` at one transition, in one lifetime of a measured
  run: docs/soak.md). Shared with every process that maps the file, given back under memory pressure, and bounded
  by the file's size: not memory the node keeps.
* Less the ring's most: the ring's content follows the load, bounded by its caps: a window busier than any before
  it raises the RSS, and a quieter one does not give the memory back to the system. That is the recorder's stated
  memory, not growth; what the private memory gains beyond it is.
"""

from __future__ import annotations

import statistics
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

Row = Mapping[str, float]

#: Judged metrics and the growth each may show before it counts, in its unit, from two measured runs (seeds 101 and
#: 202: three lifetimes of 263-310 s and one of 1185 s; docs/soak.md#the-noise-thresholds). RSS: a clean node's RSS
#: creeps (0.9 kB/s in its first ten minutes, 0.35 kB/s after): at most 274 kB late-minus-early in a ~5-minute
#: lifetime (454 kB in the 20-minute one); twice the ~5-minute figure, rounded up, is allowed, and judged on the
#: private memory less the ring's most, which is what of that RSS the node itself holds. Threads and fds never
#: moved after the warm-up; one is allowed (a pool that makes a worker lazily). The node's rt/lowstate reader exists
#: only while a mode needs it (the sim sees one reader fewer meanwhile), so its counts may move by one. Every other
#: DDS entity count is fixed by design: none.
THRESHOLDS: dict[str, float] = {
    "anon_net_kb": 600.0,
    "threads": 1.0,
    "fds": 1.0,
    "ros_nodes": 0.0,
    "ros_pubs": 0.0,
    "ros_subs": 0.0,
    "ros_services": 0.0,
    "ros_clients": 0.0,
    "sdk_participants": 0.0,
    "sdk_node_writers": 0.0,
    "sdk_node_readers": 1.0,
    "sim_matched_readers": 1.0,
}
#: Samples younger than this are not judged within a lifetime, s: the node makes its SDK entities and threads at
#: its first transition (0.5 s after its start) and has all of them by its 10 s sample.
WARMUP_S = 60.0


@dataclass(frozen=True)
class Growth:
    metric: str
    where: str  # "lifetime 3" or "across lifetimes"
    amount: float
    threshold: float

    def text(self) -> str:
        amount = f"{self.amount / 1024:+.1f} MB" if self.metric.endswith("_kb") else f"{self.amount:+g}"
        return f"{self.metric} {amount} {self.where}"


def late_minus_early(values: Sequence[float]) -> float:
    """Median of the last third minus median of the first third (at least one value each); 0 for < 2 values."""
    n = len(values)
    if n < 2:
        return 0.0
    k = max(1, n // 3)
    return statistics.median(values[-k:]) - statistics.median(values[:k])


def within_lifetime(rows: Sequence[Row], metric: str, warmup_s: float = WARMUP_S) -> float | None:
    """Late minus early of one lifetime's samples from ``warmup_s`` of age on; None with fewer than 2."""
    values = [r[metric] for r in sorted(rows, key=lambda r: r["age_s"]) if r["age_s"] >= warmup_s]
    return late_minus_early(values) if len(values) >= 2 else None


def across_lifetimes(lifetimes: Sequence[Sequence[Row]], metric: str) -> float | None:
    """The median over the ages every lifetime was sampled at of late minus early over the lifetimes at that age;
    None with fewer than 2 lifetimes or no common age."""
    if len(lifetimes) < 2:
        return None
    by_age = [{r["age_s"]: r[metric] for r in rows} for rows in lifetimes]
    common = sorted(set.intersection(*(set(ages) for ages in by_age)))
    if not common:
        return None
    return statistics.median(late_minus_early([ages[a] for ages in by_age]) for a in common)


def group_lifetimes(rows: Sequence[Row]) -> list[list[Row]]:
    """The rows of each lifetime, lifetimes in order."""
    out: dict[float, list[Row]] = {}
    for r in rows:
        out.setdefault(r["lifetime"], []).append(r)
    return [out[k] for k in sorted(out)]


def judge_growth(rows: Sequence[Row], thresholds: Mapping[str, float] = THRESHOLDS,
                 warmup_s: float = WARMUP_S) -> list[Growth]:
    """Every growth beyond its threshold, within each lifetime and across lifetimes; [] if none."""
    lifetimes = group_lifetimes(rows)
    grew: list[Growth] = []
    for metric, limit in thresholds.items():
        for rows_k in lifetimes:
            amount = within_lifetime(rows_k, metric, warmup_s)
            if amount is not None and amount > limit:
                grew.append(Growth(metric, f"in lifetime {int(rows_k[0]['lifetime'])}", amount, limit))
        amount = across_lifetimes(lifetimes, metric)
        if amount is not None and amount > limit:
            grew.append(Growth(metric, "across lifetimes", amount, limit))
    return grew


def noise(rows: Sequence[Row], metric: str, warmup_s: float = WARMUP_S) -> float:
    """The largest late-minus-early of either view in ``rows``, in absolute value: what a clean run shows, from
    which a threshold is set."""
    lifetimes = group_lifetimes(rows)
    views = [within_lifetime(k, metric, warmup_s) for k in lifetimes] + [across_lifetimes(lifetimes, metric)]
    return max((abs(v) for v in views if v is not None), default=0.0)
