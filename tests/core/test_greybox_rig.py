"""The greybox-rig model kind: its kernel is the rig emulator, its fit finds a rig's truth.

Records are made through :class:`msd_bench.core.rigs.rig.Rig` with known friction,
delay and lag, as a rig's bags would hold them (the commanded force, the
measured position).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.identification import greybox_rig as gr
from msd_bench.core.identification import identify
from msd_bench.core.identification import model_kinds as registry
from msd_bench.core.identification.data import IOData
from msd_bench.core.identification.excitation import MultilevelConfig, multilevel
from msd_bench.core.identification.fit import fit_percent
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.rigs.rig import Rig, RigImperfections
from msd_bench.io.storage import artifacts
from msd_bench.io.storage.artifacts import ArtifactError

PLANT = PlantParams(m=1.1, c=0.9, k=2.6, h=1.1)
TRUTH = RigImperfections(sensor_noise=0.002, sensor_quant=0.0001, delay_samples=2, actuator_tau=0.026,
                         friction=0.3, jitter=0.0)


def rig_model(p: PlantParams, imp: RigImperfections) -> StepModel:
    """The greybox-rig model with a rig's own values."""
    params = np.concatenate([p.as_array(), [imp.friction, imp.actuator_tau, float(imp.delay_samples)]])
    return StepModel(kernels.KIND_GREYBOX_RIG, params, "truth", dt=p.dt, force_limit=p.F)


def record(imp: RigImperfections, seed: int, n: int) -> IOData:
    """A multilevel record played through a rig with ``imp`` (commands as ``u``)."""
    commands = multilevel(MultilevelConfig(n_samples=n), seed)
    return IOData((gr.record_through_rig(Rig(PLANT, imp, seed), commands, f"seed={seed}"),), PLANT.dt)


@pytest.mark.parametrize(("delay", "tau", "friction"), [(0, 0.0, 0.0), (1, 0.02, 0.0), (2, 0.04, 0.45),
                                                        (2, 0.0, 0.2), (0, 0.005, 0.1)])
def test_the_kernel_with_a_rigs_values_is_that_rig_bit_for_bit(delay: int, tau: float,
                                                                friction: float) -> None:
    imp = RigImperfections(sensor_noise=0.0, sensor_quant=0.0, delay_samples=delay, actuator_tau=tau,
                           friction=friction, jitter=0.0)
    data = record(imp, 3, 2_000).experiments[0]
    assert np.array_equal(rig_model(PLANT, imp).simulate(data.u), data.y_true)


@pytest.fixture(scope="module")
def fitted() -> StepModel:
    return gr.identify_greybox_rig(record(TRUTH, 1, 8_000))


def test_the_fit_from_commands_finds_friction_and_the_plant(fitted: StepModel) -> None:
    p = fitted.params
    assert abs(p[8] - TRUTH.friction) <= 0.05
    for i, true in enumerate((PLANT.m, PLANT.c, PLANT.k, PLANT.h)):
        assert abs(p[(0, 1, 2, 4)[i]] / true - 1.0) < 0.05
    val = record(RigImperfections(**{**TRUTH.__dict__, "sensor_noise": 0.0, "sensor_quant": 0.0}), 2, 3_000)
    assert fit_percent(val.experiments[0].y_true, fitted.simulate(val.experiments[0].u)) > 99.0


@pytest.mark.xfail(reason="known miss (docs/greybox-rig.md §Evidence): on this rig the true delay's "
                   "fit stalls at 20x the cost at the truth (0.32 vs 0.016) and a shifted restart of delay 3 "
                   "with a 15 ms lag reaches 0.18; the first version passed as the stalled fit still won")
def test_the_fit_from_commands_finds_delay_and_lag(fitted: StepModel) -> None:
    p = fitted.params
    assert int(p[10]) == TRUTH.delay_samples
    assert abs(p[9] - TRUTH.actuator_tau) <= 0.25 * TRUTH.actuator_tau


def test_a_fixed_parameter_stays_where_it_was_put() -> None:
    specs = {"m": gr.ParamSpec(0.5, 2.0, fixed=True, value=1.25), "tau": gr.ParamSpec(0.0, 0.1)}
    model = gr.identify_greybox_rig(record(TRUTH, 1, 3_000), gr.GreyboxRigConfig(params=specs, max_iter=3))
    assert model.params[0] == 1.25 and model.info["fixed"] == ["m"]
    assert 0.0 <= model.params[9] <= 0.1


@pytest.mark.parametrize(("specs", "words"), [
    ({"c": gr.ParamSpec(2.0, 1.0)}, "c bounds are inverted"),
    ({"friction": gr.ParamSpec(0.0, 1.0, fixed=True, value=2.0)}, "friction value 2.0 is outside"),
    ({"tau": gr.ParamSpec(0.0, 1.0, fixed=True)}, "tau is fixed but has no value"),
    ({"m": gr.ParamSpec(0.0, 1.0)}, "m minimum must be > 0"),
    ({"mass": gr.ParamSpec(0.1, 1.0)}, "unknown parameter(s) ['mass']"),
    ({"h": gr.ParamSpec(float("nan"), 1.0)}, "h bounds must be finite"),
])
def test_a_bad_config_is_one_line(specs: dict[str, gr.ParamSpec], words: str) -> None:
    with pytest.raises(ConfigError) as err:
        gr.GreyboxRigConfig(params=specs)
    assert words in str(err.value) and "\n" not in str(err.value)


def test_max_delay_beyond_the_delay_line_is_refused() -> None:
    with pytest.raises(ConfigError, match="max_delay must be an integer in"):
        gr.GreyboxRigConfig(max_delay=kernels.RIG_DELAY_MAX + 1)


@pytest.mark.parametrize(("slot", "value", "words"), [(10, 6.0, "delay"), (10, 1.5, "delay"),
                                                      (8, -0.1, "friction"), (9, -1.0, "tau")])
def test_a_parameter_vector_out_of_its_layout_is_refused(slot: int, value: float, words: str) -> None:
    params = rig_model(PLANT, TRUTH).params.copy()
    params[slot] = value
    with pytest.raises(InvalidInputError, match=words):
        StepModel(kernels.KIND_GREYBOX_RIG, params, "bad", dt=PLANT.dt, force_limit=PLANT.F)


def test_the_registry_states_the_kernels_delay_line() -> None:
    assert registry.RIG_DELAY_MAX == kernels.RIG_DELAY_MAX
    assert registry.model_kind("greybox-rig").kernel == "greybox-rig"


def test_a_short_state_is_refused_not_read_past() -> None:
    model = rig_model(PLANT, TRUTH)
    with pytest.raises(InvalidInputError, match="too short"):
        kernels.advance(model.kernel, np.zeros(4), 1.0)


def test_the_artifact_round_trip_keeps_the_model(tmp_path: Path) -> None:
    model = rig_model(PLANT, TRUTH)
    loaded = artifacts.load_model(artifacts.save_model(model, tmp_path / "m.json", artifacts.Provenance()))
    assert loaded.kind == kernels.KIND_GREYBOX_RIG and np.array_equal(loaded.params, model.params)
    u = multilevel(MultilevelConfig(n_samples=500), 4)
    assert np.array_equal(loaded.simulate(u), model.simulate(u))


def test_a_crafted_artifact_delay_is_one_line(tmp_path: Path) -> None:
    path = artifacts.save_model(rig_model(PLANT, TRUTH), tmp_path / "m.json", artifacts.Provenance())
    path.write_text(path.read_text().replace('\n  2.0\n ]', '\n  99.0\n ]'))
    with pytest.raises(ArtifactError, match="delay") as err:
        artifacts.load_model(path)
    assert "\n" not in str(err.value)


def test_evaluate_scores_it_like_every_kind() -> None:
    imp = RigImperfections(**{**TRUTH.__dict__, "sensor_noise": 0.0, "sensor_quant": 0.0})
    report = identify.evaluate(rig_model(PLANT, imp), record(imp, 5, 1_500))
    assert report.sim_fit > 99.9 and report.one_step_fit > 99.9


@pytest.mark.parametrize(("friction", "tau", "delay"), [(0.2, 0.02, 1), (0.2, 0.0, 2), (0.0, 0.013, 0),
                                                        (0.0, 0.0, 0), (0.4, 0.03, kernels.RIG_DELAY_MAX)])
def test_a_rollout_is_the_models_steps_bit_for_bit(friction: float, tau: float, delay: int) -> None:
    """The rollout computes the lag's constants once; every sample is still :func:`kernels.advance`'s."""
    model = StepModel(kernels.KIND_GREYBOX_RIG, np.concatenate([PLANT.as_array(), [friction, tau, delay]]),
                      "greybox-rig", dt=PLANT.dt, force_limit=PLANT.F)
    u = np.random.default_rng(5).uniform(-13.0, 13.0, 3_000)  # beyond ±F too: saturated alike
    rolled, stepped = model.initial_state(), model.initial_state()
    x = kernels.rollout(model.kernel, u, rolled)
    steps = [0.0] + [model.step(stepped, float(v)) for v in u[:-1]]
    model.step(stepped, float(u[-1]))
    assert np.array_equal(x, steps) and np.array_equal(rolled, stepped)
