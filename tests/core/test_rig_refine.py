"""The refinement loop (core/rigs/refine.py) and the rig's own simulator (core/rigs/truth.py)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError, IdentificationError, InvalidInputError
from msd_bench.core.identification.data import Experiment
from msd_bench.core.rigs.refine import Try, choose, refine


def _try(sse: float, aborted: bool = False, name: str = "t") -> Try:
    return Try(Experiment(np.ones(5), np.zeros(5), name=name), sse, aborted, 5, rest=300 + len(name))


def test_the_choice_reads_the_measured_try_and_prefers_a_run_that_was_not_aborted() -> None:
    assert choose([_try(9.0), _try(3.0), _try(4.0)]) == 1
    assert choose([_try(9.0), _try(1.0, aborted=True)]) == 0  # an aborted try loses to any finished one
    assert choose([_try(2.0), _try(2.0)]) == 0  # a tie keeps the earlier policy
    assert choose([_try(float("nan")), _try(50.0)]) == 1
    with pytest.raises(InvalidInputError, match="nothing to choose"):
        choose([])


class _Fake:
    """A rig whose tries score the policy's number: policy p's measured SSE is ``sse[p]``."""

    def __init__(self, sse: Sequence[float], fail_at: int | None = None) -> None:
        self.sse, self.fail_at = list(sse), fail_at
        self.fitted_on: list[list[str]] = []
        self.trained = 0

    def try_(self, policy: int, r: int) -> Try:
        return _try(self.sse[policy], name=f"try{r}")

    def refit(self, records: Sequence[Experiment]) -> tuple[int, dict[str, Any]]:
        self.fitted_on.append([e.name for e in records])
        if self.fail_at is not None and len(self.fitted_on) == self.fail_at:
            raise IdentificationError("refit failed")
        return len(self.fitted_on), {"fit": len(records)}

    def retrain(self, model: int) -> int:
        self.trained += 1
        return model


def test_each_refit_sees_every_try_so_far_and_a_worse_round_is_not_kept() -> None:
    rig = _Fake([10.0, 4.0, 7.0])  # round 1 helps, round 2 makes things worse
    got = refine(0, 2, rig.try_, rig.refit, rig.retrain, (IdentificationError,))
    assert rig.fitted_on == [["try0"], ["try0", "try1"]]
    assert got.policy == 1 and got.chosen == 1
    assert [r.index for r in got.rounds] == [0, 1, 2] and got.try_samples == 15
    assert got.try_runs == [(5, 304)] * 3  # each try with the rest before it: what the bill charges
    assert got.rounds[2].fit == {"fit": 2}


def test_zero_rounds_is_the_first_try_only_and_a_failed_refit_ends_the_loop() -> None:
    rig = _Fake([3.0])
    got = refine(0, 0, rig.try_, rig.refit, rig.retrain)
    assert got.policy == 0 and len(got.rounds) == 1 and rig.fitted_on == []
    rig = _Fake([10.0, 4.0, 1.0], fail_at=2)
    got = refine(0, 3, rig.try_, rig.refit, rig.retrain, (IdentificationError,))
    assert [r.index for r in got.rounds] == [0, 1, 2] and got.rounds[2].tried is None
    assert got.rounds[2].failed == "refit failed" and got.policy == 1 and rig.trained == 1
    with pytest.raises(InvalidInputError, match="rounds must be >= 0"):
        refine(0, -1, rig.try_, rig.refit, rig.retrain)


def test_the_rigs_own_simulator_is_the_rig_sample_for_sample() -> None:
    """The ceiling's model driven by the commands gives the rig's true positions (noise aside)."""
    from msd_bench.core.physics import kernels
    from msd_bench.core.rigs import population
    from msd_bench.core.rigs.rig import Rig
    from msd_bench.core.rigs.truth import rig_model

    for seed in (3, 1000):
        spec = population.draw(seed)
        rig = Rig(spec.params, replace(spec.imperfections, sensor_noise=0.0, sensor_quant=0.0), seed=seed)
        u = np.random.default_rng(seed).choice([-10.0, -5.0, 0.0, 5.0, 10.0], 1500)
        truth = np.array([*[rig.step(float(v)).x for v in u][1:], rig.x])
        model, state = rig_model(spec.params, spec.imperfections), np.zeros(kernels.RIG_STATE_SIZE)
        simulated = np.array([kernels.advance(model.kernel, state, float(v)) for v in u])
        assert np.abs(simulated - truth).max() < 1e-12
    with pytest.raises(ConfigError, match="exceeds the greybox-rig model's"):
        rig_model(spec.params, replace(spec.imperfections, delay_samples=kernels.RIG_DELAY_MAX + 1))
