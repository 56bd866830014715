"""Success over a population of rigs: the Wilson interval and a bootstrap over rigs.

Why both: the Wilson interval treats every (rig, seed) run as an independent
trial. Runs on one rig are not independent — they share the rig's records,
its surrogate and its imperfections — so with several seeds per rig the
Wilson interval is too narrow for the question "how often does the method
work on a rig I have not seen". The bootstrap resamples *rigs* with
replacement (each drawn rig brings all of its runs) and takes the percentile
interval of the pooled success rate; it is as wide as the spread between
rigs makes it. Seeded, so a report reproduces.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation.stats import wilson

DEFAULT_RESAMPLES = 2000
"""Bootstrap resamples: the percentile ends then move by about 0.5 point between seeds."""
BOOTSTRAP_STREAM = 0xB007
"""Mixed into the bootstrap's seed."""


def bootstrap_over_rigs(successes: Sequence[int], runs: Sequence[int], resamples: int = DEFAULT_RESAMPLES,
                        seed: int = 0, level: float = 0.95) -> tuple[float, float]:
    """Percentile interval of the pooled rate sum(k)/sum(n) when the rigs are resampled with replacement.

    ``successes[i]`` of ``runs[i]`` runs succeeded on rig i. A rig with no runs
    is refused (it would make resampled rates undefined).
    """
    k = np.asarray(successes, dtype=np.int64)
    n = np.asarray(runs, dtype=np.int64)
    if k.shape != n.shape or k.ndim != 1 or k.size == 0:
        raise ConfigError("bootstrap over rigs needs one success count and one run count per rig")
    if np.any(n < 1) or np.any(k < 0) or np.any(k > n):
        raise ConfigError("every rig needs at least one run and 0 <= successes <= runs")
    if resamples < 1 or not 0.0 < level < 1.0:
        raise ConfigError(f"bootstrap needs resamples >= 1 and a level in (0, 1), got {resamples}, {level}")
    g = np.random.default_rng((BOOTSTRAP_STREAM, int(seed)))
    idx = g.integers(0, k.size, size=(int(resamples), k.size))
    rates = k[idx].sum(axis=1) / n[idx].sum(axis=1)
    tail = 100.0 * (1.0 - level) / 2.0
    lo, hi = np.percentile(rates, [tail, 100.0 - tail])
    return float(lo), float(hi)


def rate_summary(successes: Sequence[int], runs: Sequence[int], resamples: int = DEFAULT_RESAMPLES,
                 seed: int = 0) -> dict[str, Any]:
    """n, successes, rate, Wilson 95 % over runs and the bootstrap-over-rigs 95 % interval."""
    k, n = int(sum(successes)), int(sum(runs))
    return {"n": n, "successes": k, "rate": k / n if n else None, "wilson95": list(wilson(k, n)),
            "bootstrap95": list(bootstrap_over_rigs(successes, runs, resamples, seed)), "rigs": len(runs)}
