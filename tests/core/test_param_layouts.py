"""Every model kind's parameter vector is checked against its layout before a kernel sees it.

The kernels index the vector without checks; these tests pin the registry's
layouts to the kernels' own sizes, show that every model the project fits or
pins passes, and that each way of breaking a vector (the issue's
reproductions among them) is one InvalidInputError line naming the slot.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.identification.model_kinds import KERNEL_LAYOUTS, KERNELS, NLARX_MAX_UNITS
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel
from msd_bench.core.physics.plant import preset

PINNED = Path(__file__).resolve().parents[1] / "data" / "pinned"
KINDS = {name: kind for kind, name in kernels.KIND_NAMES.items()}


def _pinned(name: str) -> np.ndarray:
    return np.array(json.loads((PINNED / f"{name}.json").read_text())["params"], dtype=float)


def test_layouts_agree_with_the_kernels() -> None:
    # a held model (issue 37's decision period) wraps another model at run time and is never read
    # from a file, so it has no layout of its own to check
    assert tuple(k for k in kernels.KIND_NAMES.values() if k != "held") == KERNELS
    assert KERNEL_LAYOUTS["plant"].sizes(0) == (kernels.PLANT_SIZE,)
    assert [s.name for s in KERNEL_LAYOUTS["plant"].head] == list(kernels.Plant._fields)
    assert KERNEL_LAYOUTS["linear"].sizes(0) == (kernels.LINEAR_SIZE,)
    assert KERNEL_LAYOUTS["plm"].sizes(5) == (kernels.PLM_SIZE, kernels.PLM_SCHEDULED_SIZE)
    nlarx = KERNEL_LAYOUTS["nlarx"]
    assert (len(nlarx.head), len(nlarx.block)) == (kernels.NLARX_HEAD, kernels.NLARX_UNIT)
    assert nlarx.max_size == kernels.NLARX_HEAD + kernels.NLARX_UNIT * NLARX_MAX_UNITS
    assert KERNEL_LAYOUTS["greybox-rig"].sizes(0) == (kernels.RIG_SIZE,)


@pytest.mark.parametrize("name", ["glm", "plm", "nlarx-paper", "nlarx-improved", "greybox"])
def test_every_pinned_fit_passes(name: str) -> None:
    doc = json.loads((PINNED / f"{name}.json").read_text())
    limits = {k: doc[k] for k in ("dt", "force_limit") if k in doc}
    model = StepModel(KINDS[doc["kind"]], np.array(doc["params"]), name, **limits)
    assert np.all(np.isfinite(model.simulate(np.full(300, 5.0))))


def test_a_scheduled_plm_passes() -> None:
    p = np.concatenate([_pinned("plm"), [-1.9, -1.3, 0.0, 1.3, 1.9]])
    assert StepModel(kernels.KIND_PLM, p).simulate(np.ones(50)).size == 50


def _nlarx(units: int) -> np.ndarray:
    p = _pinned("nlarx-improved")
    head, unit = p[: kernels.NLARX_HEAD], p[kernels.NLARX_HEAD: kernels.NLARX_HEAD + kernels.NLARX_UNIT]
    head[1] = units
    return np.concatenate([head, np.tile(unit, units)])


def test_nlarx_unit_counts_at_the_bounds_pass() -> None:
    for units in (1, NLARX_MAX_UNITS):
        assert StepModel(kernels.KIND_NLARX, _nlarx(units)).simulate(np.ones(20)).size == 20


def _with(p: np.ndarray, i: int, v: float) -> np.ndarray:
    q = p.copy()
    q[i] = v
    return q


BAD = {
    # the reproductions: a unit count reading 300 MB past the vector; one value for seven
    "nlarx 5e7 units": ("nlarx", [1, 5e7, 1, 1, 0, 0, 0, 0, 0], r"parameter 1 \(S\) = 50000000.0"),
    "linear one value": ("linear", [0.5], r"got 1 parameter value\(s\); its layout \[L, n1"),
    "nlarx units disagree with length": ("nlarx", _with(_pinned("nlarx-paper"), 1, 11.0), "needs 75"),
    "nlarx fractional units": ("nlarx", _with(_pinned("nlarx-paper"), 1, 10.5), r"\(S\) = 10.5"),
    "nlarx zero units": ("nlarx", _pinned("nlarx-paper")[:9] * [1, 0, 1, 1, 1, 1, 1, 1, 1], r"\(S\) = 0.0"),
    "nlarx zero x scale": ("nlarx", _with(_pinned("nlarx-paper"), 2, 0.0), r"\(x_scale\) = 0.0"),
    "nlarx negative u scale": ("nlarx", _with(_pinned("nlarx-paper"), 3, -7.0), r"\(u_scale\) = -7.0"),
    "nlarx huge weight": ("nlarx", _with(_pinned("nlarx-paper"), 20, 1e12), r"\(b0\) = 1000000000000.0 must"),
    "nlarx too long": ("nlarx", np.zeros(kernels.NLARX_HEAD + 6 * (NLARX_MAX_UNITS + 1)), "6159 parameter"),
    "plm 30 values": ("plm", _pinned("plm")[:30], "needs 31 or 36"),
    "plm centres not increasing": ("plm", np.concatenate([_pinned("plm"), [0, 1, 1, 2, 3]]), "increasing"),
    "plm zero stroke": ("plm", _with(_pinned("plm"), 0, 0.0), r"parameter 0 \(L\) = 0.0"),
    "linear negative stroke": ("linear", _with(_pinned("glm"), 0, -5.0), r"\(L\) = -5.0"),
    "plant zero mass": ("plant", _with(preset("default").as_array(), 0, 0.0), r"\(m\) = 0.0"),
    "plant 7 values": ("plant", preset("default").as_array()[:7], "got 7 parameter"),
    "nan": ("linear", _with(_pinned("glm"), 3, np.nan), "finite"),
    "empty": ("plm", [], "got 0 parameter"),
}


@pytest.mark.parametrize("case", BAD, ids=list(BAD))
def test_a_bad_vector_is_one_line_naming_the_slot(case: str) -> None:
    kind, params, match = BAD[case]
    limits = {"dt": 0.01, "force_limit": 10.0}
    with pytest.raises(InvalidInputError, match=match) as info:
        StepModel(KINDS[kind], np.asarray(params, dtype=float), "m", **limits)
    assert "\n" not in str(info.value)


def test_dt_and_force_limit_are_bounded() -> None:
    for field, value in (("dt", 1e6), ("force_limit", np.inf), ("dt", 0.0)):
        with pytest.raises(InvalidInputError, match=field):
            StepModel(kernels.KIND_LINEAR, _pinned("glm"), **{field: value})
    with pytest.raises(InvalidInputError, match="must be numbers"):
        StepModel(kernels.KIND_LINEAR, ["a"] * 7)  # type: ignore[arg-type]
