"""``compare``, ``resid`` and the simulation band: the checks, and the commands on model files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from msd_bench.cli import main
from msd_bench.core.errors import InvalidInputError
from msd_bench.core.identification import diagnostics, greybox_rk4, identify
from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel
from msd_bench.io.storage.artifacts import Provenance, load_model, save_model

PINNED = Path(__file__).resolve().parents[1] / "data" / "pinned"
DT = 0.01
TRUTH = np.array([1.0, 0.8, 6.0, 0.0, 4.0, 100.0, 50.0, DT, 0.0, 0.0, 0.0, 0.01, 0.0, 1.0, 0.0])


def _record(n: int, seed: int, noise: float) -> Experiment:
    rng = np.random.default_rng(seed)
    u = np.convolve(rng.normal(0, 5.0, n), np.ones(4) / 4, mode="same")
    y = kernels.rk4_simulate(TRUTH, u, 0.0, 0.0, 0.0)
    return Experiment(u, y + rng.normal(0, noise, n))


@pytest.fixture(scope="module")
def fitted() -> StepModel:
    exp = _record(2000, 1, 1e-3)
    return greybox_rk4.identify_greybox_rk4(IOData((exp,), DT), greybox_rk4.Rk4Config(
        stroke=100.0, force=50.0, structures=("hold",), starts=(1.0,)))


def test_k_step_one_is_the_one_step_predictor() -> None:
    glm = load_model(PINNED / "glm.json")
    exp = Experiment(np.sin(np.arange(400) * 0.1) * 3, np.sin(np.arange(400) * 0.1 - 0.4), "sine")
    assert np.allclose(diagnostics.k_step(glm, exp, 1)[2:], identify.one_step(glm, exp)[2:], atol=1e-12)
    five = diagnostics.k_step(glm, exp, 5)
    assert not np.allclose(five[10:], identify.one_step(glm, exp)[10:])


def test_resid_passes_the_true_model_and_fails_a_wrong_one() -> None:
    exp = _record(4000, 3, 1e-3)  # white noise: every lag inside its 99 % band on this draw
    true = StepModel(kernels.KIND_RK4, TRUTH, "true", dt=DT, force_limit=50.0)
    right = diagnostics.resid(true, exp, lags=20)
    assert right.source == "simulation" and right.whiteness_pass and right.independence_pass
    wrong_params = TRUTH.copy()
    wrong_params[0] *= 1.3
    wrong = StepModel(kernels.KIND_RK4, wrong_params, "wrong", dt=DT, force_limit=50.0)
    res = diagnostics.resid(wrong, exp, lags=20)
    assert not res.whiteness_pass
    assert "FAIL" in res.lines()[0] and "pass" in right.lines()[0]


def test_compare_and_band_of_a_grey_box(fitted: StepModel) -> None:
    exp = _record(1500, 3, 1e-3)
    cmp = diagnostics.compare(fitted, exp, window=50)
    assert cmp.predicted is None and "equals its simulation" in cmp.note
    assert cmp.fit > 95.0 and cmp.rmse < 3e-3
    lo, hi = diagnostics.sim_band(fitted, exp, draws=20, window=50)
    inside = np.mean((lo[50:] <= cmp.sim[50:] + 1e-9) & (cmp.sim[50:] <= hi[50:] + 1e-9))
    assert inside > 0.9 and np.all(hi >= lo)
    with pytest.raises(InvalidInputError, match="stores no parameter covariance"):
        diagnostics.sim_band(load_model(PINNED / "glm.json"), exp)


def _files(tmp_path: Path, model: StepModel) -> tuple[Path, Path]:
    exp = _record(1500, 4, 1e-3)
    npz = tmp_path / "rec.npz"
    np.savez(npz, force=exp.u, pos=exp.y)
    path = save_model(model, tmp_path / "fit_greybox-rk4.json", Provenance())
    return path, npz


def test_commands_on_model_files(tmp_path: Path, fitted: StepModel,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    model, npz = _files(tmp_path, fitted)
    args = ["--record", str(npz), "--u", "force", "--y", "pos", "--window", "50"]
    assert main(["compare", str(model), *args, "--png", str(tmp_path / "c.png"), "--band"]) == 0
    out = capsys.readouterr().out
    assert "greybox-rk4: fit 9" in out and "  k3 = 4" in out and "assume white residuals" in out
    assert (tmp_path / "c.png").stat().st_size > 1000
    assert main(["resid", str(model), *args, "--png", str(tmp_path / "r.png")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2 and all(": pass (" in line for line in lines)
    assert main(["compare", str(model), *args, "--json"]) == 0
    assert '"fit_percent"' in capsys.readouterr().out
    from scipy.io import savemat

    with np.load(npz) as d:
        savemat(tmp_path / "rec.mat", {"V1": d["force"].reshape(-1, 1), "V2": d["pos"].reshape(-1, 1)})
        rows = "".join(f"{float(y)!r},{float(u)!r}\n" for u, y in zip(d["force"], d["pos"], strict=True))
        (tmp_path / "rec.csv").write_text("pos,force\n" + rows)
    for rec, u, y in (("rec.mat", "V1", "V2"), ("rec.csv", "force", "pos")):
        assert main(["compare", str(model), "--record", str(tmp_path / rec), "--u", u, "--y", y,
                     "--window", "50", "--json"]) == 0
        assert '"fit_percent": 9' in capsys.readouterr().out


@pytest.mark.parametrize(("extra", "match"), [
    (["--u", "nope"], "no column 'nope'"),
    (["--range", "10:5"], "--range 10:5 is out of bounds"),
    (["--range", "a:b"], "--range must be A:B"),
    (["--dt", "0.02"], "record sampled at dt=0.02"),
    (["--png", "EXISTS"], "exists"),
    (["--window", "1"], "initial-state window"),
])
def test_bad_input_is_one_line(tmp_path: Path, fitted: StepModel, capsys: pytest.CaptureFixture[str],
                               extra: list[str], match: str) -> None:
    model, npz = _files(tmp_path, fitted)
    (tmp_path / "EXISTS").write_bytes(b"mine")
    extra = [str(tmp_path / "EXISTS") if e == "EXISTS" else e for e in extra]
    args = ["compare", str(model), "--record", str(npz), "--u", "force", "--y", "pos", "--window", "50",
            *extra]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert match in err and "\n" not in err
    assert (tmp_path / "EXISTS").read_bytes() == b"mine"


def test_a_missing_record_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["resid", str(PINNED / "glm.json"), "--record", str(tmp_path / "none.npz")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_compare_reads_a_bag(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from msd_bench.core.physics.plant import PlantParams, simulate
    from msd_bench.io.bags.bag_writer import write_experiment

    p = PlantParams()
    u = np.sin(np.arange(800) * 0.05) * 4.0
    x, v, ua = simulate(u, p)
    bag = write_experiment(tmp_path / "bag", np.arange(800) * 10_000_000, ua, x, v, params={})
    glm = str(PINNED / "glm.json")
    assert main(["compare", glm, "--record", str(bag), "--k", "3", "--range", "0:600"]) == 0
    out = capsys.readouterr().out
    assert "glm: fit" in out and "3-step prediction fit" in out
