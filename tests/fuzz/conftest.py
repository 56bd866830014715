"""The fuzz tier: property-based tests over every reader of user-supplied files.

Two Hypothesis profiles. ``default`` runs in the ordinary suite: few examples (20 in
a newcomer's ``make test``; ``.ci/run`` sets ``MSD_FUZZ_EXAMPLES=100`` for its run of the same tier),
derandomised (the same cases every run, so a red run is reproducible and never
load- or luck-dependent), no deadline (a loaded machine is slow, not wrong), no
example database written into the checkout. ``long`` is what
``benchmarks/fuzz_long.py`` selects: at least 10,000 random cases per reader.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

settings.register_profile(
    "default",
    max_examples=int(os.environ.get("MSD_FUZZ_EXAMPLES", "20")),
    derandomize=True,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
settings.register_profile(
    "long",
    max_examples=int(os.environ.get("MSD_FUZZ_EXAMPLES", "10000")),
    derandomize=False,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                           HealthCheck.filter_too_much],
)
settings.load_profile(os.environ.get("MSD_FUZZ_PROFILE", "default"))
