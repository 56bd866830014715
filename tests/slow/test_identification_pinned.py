"""The PLM's and the grey-box's fits at the paper's size, pinned to the values before the
identification-speed work (docs/decisions.md §Identification speed), identification seed 0.

Before: ``PlmConfig(jacobian="finite-difference")``, the code as it was (measured at commit
1d059e3: PLM 97.1974 % broad / 99.5655 % on the bias validation records, grey-box 100.0000 %).
The exact Jacobian lets the refinement reach a lower cost on its own criterion (2.10449 against
2.10463 m²; the finite-difference path cannot get lower even at 1e-12 tolerances), which moves
the PLM's broad-record fit by -0.016; its own figure (the bias records) moves by -0.0002.

Pins hold across machines only in distribution (a seed reproduces bit for bit on one CPU, not
across Intel and AMD): the finite-difference path read 97.1974 where it was pinned and 97.1890 on
another machine, so every pin here is held to the width that separates a real change of the
method (a fit moving by tenths) from a CPU's rounding (hundredths or less).
"""

from __future__ import annotations

import pytest

from msd_bench.app.pipeline import records_from_plan
from msd_bench.app.plan import paper_plan
from msd_bench.core.identification.identify import (
    GreyboxConfig,
    PlmConfig,
    evaluate,
    identify_greybox,
    identify_plm,
)
from msd_bench.core.physics import plant

pytestmark = pytest.mark.slow

PLM_BROAD_BEFORE = 97.1974
PLM_BIAS_BEFORE = 99.5655
GREYBOX_BEFORE = 100.0000
CPU_WIDTH = 0.02
"""How far a pinned fit (%) may read on another CPU: 2.4x the widest difference seen (0.0084)."""


@pytest.fixture(scope="module")
def records():
    return records_from_plan(plant.preset("default"), paper_plan(0))


def _bias_val(records):
    parts = list(records.bias_val.values())
    out = parts[0]
    for r in parts[1:]:
        out = out.merge(r)
    return out


def test_the_plm_fits_as_before(records):
    p = plant.preset("default")
    model = identify_plm(records.bias_train, PlmConfig(stroke=p.L))
    assert evaluate(model, _bias_val(records)).sim_fit == pytest.approx(PLM_BIAS_BEFORE, abs=0.01)
    assert evaluate(model, records.broad_val).sim_fit == pytest.approx(PLM_BROAD_BEFORE, abs=0.02)
    assert model.info["refinement"]["kept"]


def test_the_finite_difference_path_is_the_earlier_code(records):
    p = plant.preset("default")
    model = identify_plm(records.bias_train, PlmConfig(stroke=p.L, jacobian="finite-difference"))
    assert evaluate(model, records.broad_val).sim_fit == pytest.approx(PLM_BROAD_BEFORE, abs=CPU_WIDTH)


def test_the_greybox_fits_as_before(records):
    p = plant.preset("default")
    model = identify_greybox(records.broad_train, GreyboxConfig(stroke=p.L, force=p.F))
    assert evaluate(model, records.broad_val).sim_fit == pytest.approx(GREYBOX_BEFORE, abs=0.01)
