"""The bootstrap over rigs on hand-made cases."""

from __future__ import annotations

import pytest

from msd_bench.core.errors import ConfigError
from msd_bench.core.rigs.rig_stats import bootstrap_over_rigs, rate_summary


def test_one_rig_or_equal_rigs_give_a_point() -> None:
    assert bootstrap_over_rigs([3], [4]) == (0.75, 0.75)
    assert bootstrap_over_rigs([1, 1, 1], [2, 2, 2]) == (0.5, 0.5)


def test_two_rigs_resample_to_both_ends() -> None:
    """Rigs A = 3/4 and B = 1/4: a resample is AA (0.75), AB/BA (0.5) or BB (0.25), with probabilities
    1/4, 1/2, 1/4; so the 95 % percentile interval is exactly [0.25, 0.75]."""
    assert bootstrap_over_rigs([3, 1], [4, 4], resamples=4000) == (0.25, 0.75)


def test_rigs_pool_their_runs() -> None:
    """Rigs of 1/1 and 0/3: resamples give 1, 1/4 and 0; the rate pools runs, it is not a mean of rates."""
    lo, hi = bootstrap_over_rigs([1, 0], [1, 3], resamples=4000)
    assert (lo, hi) == (0.0, 1.0)
    assert rate_summary([1, 0], [1, 3])["rate"] == 0.25


def test_the_interval_is_wider_than_wilson_when_rigs_differ() -> None:
    """20 rigs, half of which always succeed over 4 seeds and half never: runs are not independent."""
    k, n = [4] * 10 + [0] * 10, [4] * 20
    s = rate_summary(k, n)
    assert s["rate"] == 0.5 and s["n"] == 80
    assert s["bootstrap95"][1] - s["bootstrap95"][0] > 1.5 * (s["wilson95"][1] - s["wilson95"][0])


def test_seeded() -> None:
    k, n = [2, 0, 1, 2, 2], [2] * 5
    assert bootstrap_over_rigs(k, n, seed=7) == bootstrap_over_rigs(k, n, seed=7)


@pytest.mark.parametrize(("k", "n"), [([], []), ([1], [0]), ([3], [2]), ([1, 2], [2])])
def test_bad_counts_are_one_line(k: list[int], n: list[int]) -> None:
    with pytest.raises(ConfigError):
        bootstrap_over_rigs(k, n)
