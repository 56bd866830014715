"""Learning floor: the improved agent, trained on the true plant at the paper budget, must learn.

Every other learner test pins *what* is learned (bit for bit) or checks one
update by hand; none fails if a change leaves the code consistent but the agent
no longer learns to hold the set-point. This one does.

The floor. N = 20 agents of ``improved_config()`` (seeds 20000..20019), each
trained 300 episodes x 3000 steps on the default true plant and validated as
the pipeline does (greedy, 3000 steps from rest to 1 m, SSE over the last 500
samples); at least K = 13 must succeed (SSE < 5 %).

Where N and K come from (measured on *other* seeds, so the test seeds did not
choose them; record in docs/results/learning_floor_*.json, produced by
``python -m tests.core.learning_floor``):

* improved agent, seeds 10000..10199: 189 / 200 succeed, p = 0.945
  (95 % Clopper-Pearson interval 0.904..0.972);
* paper agent (a weaker learner), seeds 10000..10099: 43 / 100, p = 0.43
  (interval 0.33..0.53);
* an untrained (all-zero) table: 0 succeed (greedy picks -F, the mass sits at
  the lower stop) — :func:`test_the_floor_rejects_an_untrained_table`.

Binomial arithmetic, P(X >= 13) for X ~ Bin(20, p):

* working learner, p = 0.945: 0.999994; at the interval's low end p = 0.904:
  0.99969 — above 0.999 either way;
* the paper agent's p = 0.43: 0.040 (0.21 at its interval's high end 0.53);
* an agent that does not learn (p = 0): 0.

About 15 s on the 2-core bench machine (one compiled batch of 20 agents).
"""

from __future__ import annotations

import numpy as np

from msd_bench.core.learning.qconfig import improved_config
from tests.core.learning_floor import successes, trained_sse, validation_sse

SEEDS = tuple(range(20_000, 20_020))
FLOOR = 13


def test_improved_agent_on_the_true_plant_meets_the_floor() -> None:
    sse = trained_sse("improved", SEEDS)
    assert successes(sse) >= FLOOR, (
        f"only {successes(sse)} / {len(SEEDS)} improved agents succeed (floor {FLOOR}); "
        f"SSE % = {[round(s, 2) for s in sse]}")


def test_the_floor_rejects_an_untrained_table() -> None:
    cfg = improved_config()
    n_states = 2 * len(cfg.error_edges) + 2
    sse = validation_sse(np.zeros((len(SEEDS), n_states, 5)), cfg)
    assert successes(sse) == 0
