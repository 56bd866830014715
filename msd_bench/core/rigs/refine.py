"""Refinement on a rig: identify → train → try → re-identify from the closed-loop records → retrain.

Why here and generic: the loop, the choice between rounds and what each round
costs in real samples are the method; fitting, training and trying are the
caller's (``app/rig_refine.py`` passes the registered fitters, designs and the
rig's supervised loop), so this module needs none of them.

One round (of at most ``rounds``): the model is refitted from the open-loop
records plus every closed-loop record tried so far, the agent retrained on it,
and the new policy tried once on the rig (behind the supervisor). Every try is
a record of the rig, whichever policy made it, so each refit sees them all.

Which policy is kept is judged on what a rig owner has: the *measured* record
of each try (its SSE on the measured position; a try the supervisor aborted
loses to any that ran to its end), never the true position. A round that made
things worse is thus detected and the better policy kept. The caller reports a
fresh validation run of the kept policy, never the tries the choice was made on.

Closed-loop identification (why refitting from records made under feedback is
sound here): under feedback the input depends on past measurement noise, which
biases a fit that regresses on noisy outputs (an equation-error or one-step
ARX fit) whatever the data. The fitters used here minimise the *simulation*
error: the model is driven by the measured applied force alone and its output
compared with the measured position (the grey-box kinds by simulation-error
least squares, the NLARX's last stage likewise). The rig's sensor noise is
white and added to the output, so the true system has exactly that
output-error structure; the model steps at least one sample from force to
position, so the simulated output up to sample k depends on the noise only up
to k-1 and is uncorrelated with the noise at k. The expected squared error is
then the model error plus the noise variance, smallest at the true system:
the direct prediction-error method is consistent in closed loop when the noise
model is right (Ljung, System Identification, 2nd ed., §13.4), and an
output-error model with white output noise needs none. Informativity comes
from the open-loop records kept in every fit; the closed-loop tries add the
operating region the controller actually visits (the step to the set-point
and the hold there).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.identification.data import Experiment

P = TypeVar("P")
M = TypeVar("M")


@dataclass(frozen=True)
class Try:
    """One closed-loop try on the rig, as its bag holds it, and what the choice may read of it."""

    record: Experiment
    """Applied force and measured position (truth beside, for scoring only): a refit's data."""
    sse_measured: float
    """SSE (%) on the measured position: what the choice reads."""
    aborted: bool
    """The supervisor stopped the run."""
    samples: int
    """Real samples the try played (charged)."""
    rest: int = 0
    """Zero-force samples the rig took to come to rest before the try (charged too: no reset)."""
    report: dict[str, Any] = field(default_factory=dict)
    """What the report shows of it (risk, overrides, the true SSE): never read by the choice."""


@dataclass(frozen=True)
class Round:
    """One round's outcome: its try, and why it ended early when it did."""

    index: int
    """0: the open-loop policy's try; r: the policy retrained after the r-th refit."""
    tried: Try | None
    """None when the refit or the retraining failed (no new policy to try)."""
    fit: dict[str, Any] = field(default_factory=dict)
    """The refitted model's facts (its fit on the validation record), empty for round 0."""
    failed: str = ""
    """Why the round made no policy (a fitter's or a design's one-line error)."""


@dataclass(frozen=True)
class Refined(Generic[P]):
    """The outcome of :func:`refine`: the kept policy and every round."""

    policy: P
    """The policy kept (the one with the best measured try)."""
    chosen: int
    """Its round."""
    rounds: tuple[Round, ...]

    @property
    def try_samples(self) -> int:
        """Real samples every try played (charged, whatever was kept)."""
        return sum(r.tried.samples for r in self.rounds if r.tried is not None)

    @property
    def try_runs(self) -> list[tuple[int, int]]:
        """Each try's (samples played, rest before it): what the bill of a refined route charges."""
        return [(r.tried.samples, r.tried.rest) for r in self.rounds if r.tried is not None]


def choose(tries: Sequence[Try | None]) -> int:
    """The round whose try is best on the measured record: a try that ran to its end beats an aborted
    one, then the lower measured SSE; ties go to the earlier round (keep what is known to work)."""
    ranked = [(t.aborted, t.sse_measured if math.isfinite(t.sse_measured) else math.inf, i)
              for i, t in enumerate(tries) if t is not None]
    if not ranked:
        raise InvalidInputError("no round was tried: nothing to choose from")
    return min(ranked)[2]


def refine(first: P, rounds: int, try_: Callable[[P, int], Try],
           refit: Callable[[Sequence[Experiment]], tuple[M, dict[str, Any]]],
           retrain: Callable[[M], P],
           failures: tuple[type[Exception], ...] = (InvalidInputError,)) -> Refined[P]:
    """Try ``first`` on the rig, then up to ``rounds`` times refit from every closed-loop record so
    far, retrain and try again; keep the policy with the best measured try (:func:`choose`).

    ``try_(policy, round)`` runs it once on the rig; ``refit(records)`` fits the model from the
    open-loop records plus ``records`` and says how it fits; ``retrain(model)`` makes the policy.
    A refit or retraining raising one of ``failures`` ends the loop (that round is recorded with its
    reason); the policies already tried stay candidates.
    """
    if rounds < 0:
        raise InvalidInputError(f"refinement rounds must be >= 0, got {rounds}")
    policies = [first]
    done = [Round(0, try_(first, 0))]
    for r in range(1, rounds + 1):
        records = [d.tried.record for d in done if d.tried is not None]
        try:
            model, facts = refit(records)
            policy = retrain(model)
        except failures as exc:
            done.append(Round(r, None, failed=" ".join(str(exc).split())))
            break
        policies.append(policy)
        done.append(Round(r, try_(policy, r), fit=facts))
    tried = [d.tried for d in done if d.tried is not None]
    best = choose(tried)
    return Refined(policies[best], best, tuple(done))
