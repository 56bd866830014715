"""The grey-box kinds' integrator rule never fires on the rig population (issue 33 item 1): every
design rig's broad training record puts omega dt far inside the Euler limit, so ``greybox`` and
``greybox-rig`` fit on rigs exactly what they fitted before the rule existed (no RK4 candidate is
fitted, nothing is chosen). The population's extremes (mass x0.8, springs x1.25) move omega by at
most x1.25 from the default plant's."""

from __future__ import annotations

import pytest

from msd_bench.app.plan import paper_plan
from msd_bench.core.identification.integrator_choice import EULER_OMEGA_DT, omega_dt
from msd_bench.core.rigs import population
from msd_bench.core.rigs.rig import Rig
from msd_bench.core.rigs.rig_play import play_plan, records_of

RIGS = (1, 2, 3, 4, 5)
"""Design rigs only (never report held-out ones from a test that chose nothing)."""


@pytest.mark.parametrize("seed", RIGS)
def test_design_rigs_stay_inside_the_euler_limit(seed: int) -> None:
    drawn = population.draw(seed)
    rig = Rig(drawn.params, drawn.imperfections, seed=seed)
    played = play_plan(rig, paper_plan(0, 3000, 500))
    wdt = omega_dt(records_of(played, drawn.params.dt).broad_train)
    assert 0.0 < wdt < EULER_OMEGA_DT / 4
