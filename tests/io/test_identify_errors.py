"""Every identification error names the bag and the record it came from (issue 21)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from msd_bench.app.bag_identification import IdentifierConfig, identify_from_bags
from msd_bench.core.errors import IdentificationError
from msd_bench.core.identification import excitation as exc
from msd_bench.core.physics.plant import PlantParams, simulate
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_writer import write_experiment

DT_NS = 10_000_000


def _bag(path: Path, u: np.ndarray, x: np.ndarray | None = None) -> Path:
    if x is None:
        x, v, _ = simulate(u, PlantParams())
    else:
        v = np.gradient(x) / 0.01
    t = np.arange(u.size, dtype=np.int64) * DT_NS
    return write_experiment(path, t, u, x, v, params={})


def _broad(n: int = 800, seed: int = 1) -> np.ndarray:
    return exc.multilevel(exc.MultilevelConfig(n_samples=n), seed)


def test_a_fit_that_fails_names_the_model_its_records_and_bags(tmp_path: Path) -> None:
    """A broad record held at the hard stop: the grey-box fit has nothing to fit, and says where from."""
    u = np.where(np.arange(800) % 40 < 20, 9.0, 10.0)
    x = np.full(800, 2.5)
    x[:5] = np.linspace(2.4, 2.5, 5)  # not constant, so the records pass; all but 5 samples at the stop
    stuck = _bag(tmp_path / "stuck", u, x)
    val = _bag(tmp_path / "val", _broad(seed=2))
    cfg = IdentifierConfig(broad_bag=str(stuck), validation_bag=str(val), models=("greybox",),
                           out_dir=str(tmp_path / "out"))
    with pytest.raises(IdentificationError) as err:
        identify_from_bags(cfg)
    text = str(err.value)
    assert text.startswith(f"fitting greybox on train record (broad range) from bag {stuck}; "
                           f"validation record (broad range) from bag {val}: grey-box record")
    assert "\n" not in text


def test_a_constant_record_names_its_bag_and_record_before_any_fit(tmp_path: Path) -> None:
    """The rig's 'record has no excitation' came from the fit; now the bag and the record are named."""
    broad = _bag(tmp_path / "broad", np.zeros(800), np.linspace(0.0, 0.1, 800))
    val = _bag(tmp_path / "val", _broad(seed=2))
    cfg = IdentifierConfig(broad_bag=str(broad), validation_bag=str(val), models=("glm",),
                           out_dir=str(tmp_path / "out"))
    with pytest.raises(BagError, match=rf"bag {broad} \(train record \(broad range\)\): no excitation: the "
                                       r"force is constant at 0 over its 800 samples"):
        identify_from_bags(cfg)
