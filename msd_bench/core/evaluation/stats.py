"""Summaries across seeds: the result is a distribution, not a number.

docs/decisions.md §Distributions: the seed alone moves the paper agent's SSE from under 1 % to over
40 %, so every reported metric is summarised as n, mean ± sd and median over
the seeds, and N/A values (a settling time that never happens) are counted
rather than silently dropped.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass

import numpy as np


@dataclass(frozen=True)
class Summary:
    """Distribution of one metric over seeds."""

    n: int
    """Number of seeds."""
    n_defined: int
    """Seeds where the metric is defined (finite); ts is N/A when never settled."""
    mean: float
    """Mean over the defined values (NaN if none)."""
    sd: float
    """Sample standard deviation over the defined values (NaN if fewer than 2)."""
    median: float
    """Median over the defined values (NaN if none)."""
    min: float
    """Smallest defined value (NaN if none)."""
    max: float
    """Largest defined value (NaN if none)."""

    def as_dict(self) -> dict[str, float | int | None]:
        """JSON-ready: NaN becomes None."""
        return {k: _json_number(v) for k, v in asdict(self).items()}

    def text(self, digits: int = 2) -> str:
        """``mean ± sd (median m)``, or ``N/A`` when no seed defines it."""
        if self.n_defined == 0:
            return "N/A"
        sd = "" if math.isnan(self.sd) else f" ± {self.sd:.{digits}f}"
        partial = "" if self.n_defined == self.n else f" [{self.n_defined}/{self.n}]"
        return f"{self.mean:.{digits}f}{sd} (med {self.median:.{digits}f}){partial}"


def summarize(values: Iterable[float]) -> Summary:
    """Summary of the finite values among ``values`` (NaN marks N/A)."""
    arr = np.asarray(list(values), dtype=float)
    ok = arr[np.isfinite(arr)]
    if ok.size == 0:
        nan = float("nan")
        return Summary(int(arr.size), 0, nan, nan, nan, nan, nan)
    sd = float(np.std(ok, ddof=1)) if ok.size > 1 else float("nan")
    return Summary(
        int(arr.size), int(ok.size), float(ok.mean()), sd, float(np.median(ok)),
        float(ok.min()), float(ok.max()),
    )


def _json_number(v: float | int) -> float | int | None:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def wilson(k: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    """Wilson score interval of a success rate k/n (95 % by default), as fractions.

    Why Wilson: with n in the tens and rates near 0 or 1 (the regime of every
    row here), the normal interval leaves [0, 1] and is far too narrow; Wilson
    keeps close to nominal coverage down to k = 0 or k = n.
    """
    if n <= 0 or not 0 <= k <= n:
        return (float("nan"), float("nan"))
    p = k / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    lo = 0.0 if k == 0 else max(0.0, centre - half)  # exact ends: no rounding crumbs at 0 or n
    hi = 1.0 if k == n else min(1.0, centre + half)
    return (lo, hi)


def rate_text(k: int, n: int) -> str:
    """``k/n (p %, 95 % CI lo–hi %)``: how every success rate is printed."""
    lo, hi = wilson(k, n)
    if n <= 0:
        return f"{k}/{n}"
    return f"{k}/{n} ({100 * k / n:.0f} %, CI {100 * lo:.0f}–{100 * hi:.0f} %)"


def prediction_interval(k: int, n: int, m: int, level: float = 0.99) -> tuple[int, int]:
    """Counts a rerun of ``m`` trials may show, given ``k`` of ``n`` before, at ``level`` (two-sided).

    Why: a seed reproduces bit for bit only on the same machine; on another CPU
    the last digits of an identified model differ and a chaotic learner turns
    that into other outcomes, so a rerun agrees only in distribution. The
    interval is the beta-binomial predictive of the Jeffreys posterior
    Beta(k + ½, n − k + ½): it carries both the rerun's sampling noise and
    the uncertainty of the stored rate.
    """
    from scipy.special import betaln, gammaln

    a, b = k + 0.5, n - k + 0.5
    js = np.arange(m + 1)
    logp = (gammaln(m + 1) - gammaln(js + 1) - gammaln(m - js + 1)
            + betaln(js + a, m - js + b) - betaln(a, b))
    cdf = np.cumsum(np.exp(logp))
    tail = (1.0 - level) / 2.0
    lo = int(np.searchsorted(cdf, tail, side="left"))
    hi = int(np.searchsorted(cdf, 1.0 - tail, side="left"))
    return lo, min(hi, m)
