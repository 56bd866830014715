"""`msd_bench.load_model`: one call from an artifact to a steppable model and python-control forms."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import control
import numpy as np
import pytest

import msd_bench
from msd_bench.core.errors import IdentificationError, InvalidInputError
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel
from msd_bench.io.storage import artifacts

PINNED = Path(__file__).resolve().parents[1] / "data" / "pinned"


def test_import_stays_light() -> None:
    """`import msd_bench` must not pull in the compiled kernels, python-control or rclpy."""
    code = ("import sys, msd_bench; heavy = [m for m in ('numba', 'control', 'rclpy', 'torch') "
            "if m in sys.modules]; print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_loader_line_from_the_issue_works() -> None:
    """`control.step_response(msd_bench.load_model(glm).to_transfer_function())` as written."""
    resp = control.step_response(msd_bench.load_model(str(PINNED / "glm.json")).to_transfer_function())
    model = msd_bench.load_model(PINNED / "glm.json")
    assert isinstance(model, StepModel) and model.kind == kernels.KIND_LINEAR
    # The GLM is stable: its static gain is the artifact's and the step response heads there.
    assert control.dcgain(model.to_transfer_function()) == pytest.approx(model.info["dc_gain"], rel=1e-12)
    assert resp.outputs[-1] == pytest.approx(model.info["dc_gain"], rel=0.01)


def test_transfer_function_simulates_like_the_model() -> None:
    """The discrete TF, driven by the same small force, gives the model's own free run."""
    model = msd_bench.load_model(PINNED / "glm.json")
    tf = model.to_transfer_function()
    assert tf.dt == model.dt
    u = 0.5 * np.sin(np.arange(400) * 0.05)  # small: stays far from the stroke limits
    x_model = model.simulate(u)  # x[k]: position after u[0..k-1], x[0] = 0
    resp = control.forced_response(tf, T=np.arange(u.size) * model.dt, U=u)
    x_tf = np.asarray(resp.outputs)
    assert np.max(np.abs(x_model)) > 1e-3  # the test drives the model visibly
    np.testing.assert_allclose(x_tf, x_model, rtol=1e-9, atol=1e-12)


def test_continuous_form_discretises_back() -> None:
    """ZOH of the continuous form is the discrete model again (the inverse is exact)."""
    model = msd_bench.load_model(PINNED / "glm.json")
    back = control.c2d(model.to_continuous(), model.dt, "zoh")
    num, den = (np.ravel(a) for a in control.tfdata(back))
    fit = model.linear_fit()
    np.testing.assert_allclose(den / den[0], [1.0, fit.d1, fit.d2], rtol=1e-9)
    np.testing.assert_allclose(num / den[0], [fit.n1, fit.n2], rtol=1e-6)


def test_operating_point_is_carried(tmp_path: Path) -> None:
    """A model around (u0, y0) keeps them in its LinearFit (the TF is in deviations)."""
    p = np.array([5.0, 0.001, 0.0009, -1.9, 0.91, 2.0, 0.3])
    path = artifacts.save_model(StepModel(kernels.KIND_LINEAR, p, "glm"), tmp_path / "g.json",
                                artifacts.Provenance())
    fit = msd_bench.load_model(path).linear_fit()
    assert (fit.u0, fit.y0, fit.n1, fit.d2) == (2.0, 0.3, 0.001, 0.91)


def test_nonlinear_kinds_refuse_a_transfer_function_in_one_line() -> None:
    for name in ("plm", "nlarx-paper"):
        model = msd_bench.load_model(PINNED / f"{name}.json")
        with pytest.raises(InvalidInputError, match="only a linear model") as exc:
            model.to_transfer_function()
        assert "\n" not in str(exc.value)
        with pytest.raises(InvalidInputError, match="only a linear model"):
            model.to_continuous()


def test_no_continuous_form_for_a_pole_on_the_negative_axis() -> None:
    p = np.array([5.0, 0.001, 0.0, 0.5, 0.0, 0.0, 0.0])  # pole at z = -0.5
    with pytest.raises(IdentificationError, match="no continuous-time equivalent"):
        StepModel(kernels.KIND_LINEAR, p, "glm").to_continuous()


def test_missing_file_is_a_one_line_error(tmp_path: Path) -> None:
    with pytest.raises(artifacts.ArtifactError, match="no such artifact"):
        msd_bench.load_model(tmp_path / "nope.json")
