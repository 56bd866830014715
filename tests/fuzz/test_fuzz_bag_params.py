"""Fuzz tier, bag parameters: the excitation a bag's ``custom_data`` describes, checked before it is built.

Properties (each case in a forked child under the memory bound and the alarm of
:func:`tests.fuzz.test_fuzz_bags.in_child`):

* in process, :func:`~msd_bench.core.identification.excitation.config_from_params` on any parameters either
  refuses them with one ``ConfigError`` line or returns a config whose signal is at most
  ``MAX_SIGNAL_SAMPLES`` long, with finite forces — and rebuilding it gives exactly that length;
* through the readers, a bag written with such parameters is either taken (its role, bias and
  settle as stored) or refused with one BagError line naming the bag — never a traceback.

The values are the ones that broke the readers (issue 20: ``steps.dwell = 1e13``, ``"bias": "abc"``,
``"prbs": 7``) and their neighbours: huge, negative, non-integer, non-finite, wrong types.
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from msd_bench.core.errors import ConfigError
from msd_bench.core.identification import excitation as exc
from msd_bench.io.bags.bag_records import load_records, roles_from_dir
from msd_bench.io.bags.reader import write_experiment
from tests.fuzz.test_fuzz_bags import assert_clean, run_readers

MAX = exc.MAX_SIGNAL_SAMPLES
BUILD_LIMIT = 200_000
"""Configs longer than this are checked for their length only: building 10^7 multilevel samples of
dwell 1 takes the generator seconds, which the default tier cannot spend per case."""

COUNTS = st.sampled_from([-1, 0, 1, 2, 7, 60, 120, 1000, MAX, MAX + 1, 10**13, 2**64, 1e13, 30.0,
                          True, "30", None, float("nan")])
FORCES = st.sampled_from([0.0, -10.0, 5, 1e300, float("inf"), float("nan"), 10**400, "abc", True, None])
NASTY = st.one_of(COUNTS, FORCES, st.lists(FORCES, max_size=3), st.dictionaries(st.text(max_size=3), COUNTS,
                                                                               max_size=2))
FIELDS = {
    "prbs": ["bias", "amplitude", "n_samples", "hold", "register_bits", "settle"],
    "multilevel": ["levels", "n_samples", "min_dwell", "max_dwell"],
    "steps": ["levels", "dwell"],
}


def _value(name: str) -> st.SearchStrategy[Any]:
    if name == "levels":
        return st.lists(FORCES, max_size=4) | st.lists(st.floats(-10, 10), min_size=1, max_size=6) | NASTY
    if name in ("bias", "amplitude"):
        return FORCES | st.floats(-10, 10)
    if name == "register_bits":
        return st.sampled_from([7, 9, 10, 11, 15, 8, 0, -7, 7.0]) | NASTY
    return COUNTS | st.integers(1, 400) | NASTY


@st.composite
def bag_params(draw: st.DrawFn) -> dict[str, Any]:
    """Parameters as a bag stores them, every part possibly wrong."""
    kind = draw(st.sampled_from([*FIELDS, "chirp", 7, None]))
    params: dict[str, Any] = {"role": draw(st.sampled_from(["train", "validation", 3, ["train"]]))}
    if draw(st.integers(0, 4)) > 0:  # mostly: a bag without "signal" only skips the rebuild
        params["signal"] = kind
    if kind in FIELDS and draw(st.integers(0, 9)) > 0:
        names = draw(st.lists(st.sampled_from([*FIELDS[kind], "colour"]), unique=True, max_size=6))
        params[kind] = {n: draw(_value(n)) for n in names}
    elif draw(st.booleans()):
        params[str(kind)] = draw(NASTY)
    if draw(st.booleans()):
        params["seed"] = draw(st.sampled_from([0, 3, -1, 2**64, 2**64 - 1, 2.5, "1", None, True]))
    if draw(st.booleans()):
        params["bias"] = draw(FORCES)
    return params


def _length(cfg: exc.SignalConfig) -> int:
    if isinstance(cfg, exc.PrbsConfig):
        return cfg.settle + cfg.n_samples
    if isinstance(cfg, exc.MultilevelConfig):
        return cfg.n_samples
    return len(cfg.levels) * cfg.dwell


def _rebuild(params: dict[str, Any]) -> bool:
    """The property in process; True if the parameters were refused (a clean project error)."""
    try:
        found = exc.config_from_params(params)
    except ConfigError as err:
        assert str(err) and "\n" not in str(err)
        return True
    if found is None:  # no signal named, or its config not stored: nothing to rebuild
        assert "signal" not in params or params.get(params["signal"]) is None
        return False
    cfg, seed = found
    length = _length(cfg)
    assert 1 <= length <= MAX and 0 <= seed < 2**64
    assert all(math.isfinite(v) for v in getattr(cfg, "levels", ()))
    if length <= BUILD_LIMIT:
        signal = exc.signal_from_params(params)
        assert signal is not None and signal.size == length and np.isfinite(signal).all()
    return False


@given(params=bag_params())
def test_signal_parameters_in_process(params: dict[str, Any]) -> None:
    assert_clean(lambda: _rebuild(params))


@pytest.fixture()
def bags(tmp_path: Path) -> Path:
    return tmp_path / "bags"


N = 150


@given(params=bag_params())
def test_signal_parameters_through_the_readers(bags: Path, params: dict[str, Any]) -> None:
    shutil.rmtree(bags, ignore_errors=True)  # the previous example's bag: examples share tmp_path
    case = bags / "case"
    t = np.arange(N, dtype=np.int64) * 10_000_000
    try:
        cfg = exc.config_from_params(params)
    except ConfigError:
        cfg = None
    write_experiment(case / "broad", t, np.zeros(N), np.zeros(N), np.zeros(N), params=params)
    small = cfg is None or _length(cfg[0]) <= BUILD_LIMIT

    def identify() -> object:
        roles = roles_from_dir(case)
        assert [r.role for r in roles] == [params["role"]]
        return load_records(roles, need_plm=False) if small else roles

    assert_clean(lambda: run_readers([identify]))
