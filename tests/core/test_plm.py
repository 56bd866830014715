"""The PLM blend (msd_bench.core.identification.plm): exact where a membership is 1, known-truth recovery,
scheduling on the local operating points and the global refinement on the real plant."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.signal import lfilter

from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.identification.data import IOData
from msd_bench.core.identification.excitation import MultilevelConfig, PrbsConfig, prbs
from msd_bench.core.identification.fit import fit_percent
from msd_bench.core.identification.identify import (
    PlmConfig,
    bias_record,
    broad_record,
    evaluate,
    free_run,
    identify_plm,
)
from msd_bench.core.identification.linear import LinearFit
from msd_bench.core.identification.plm import PLM_BIASES, blend, local_from_params
from msd_bench.core.physics import kernels, plant
from msd_bench.core.physics.model import StepModel
from msd_bench.core.physics.sensor import SensorModel

DT = 0.01
# Five distinct stable systems; operating points inside each membership's plateau/peak
# (model 1 below -2 and model 5 above 1.5, where f1 / f5 are exactly 1).
TRUTH = [
    LinearFit(1.0e-4, 0.2e-4, -1.96, 0.9640, -10.0, -2.3, DT),
    LinearFit(0.8e-4, 0.4e-4, -1.97, 0.9720, -5.0, -1.0, DT),
    LinearFit(1.2e-4, 0.1e-4, -1.98, 0.9810, 0.0, 0.0, DT),
    LinearFit(0.9e-4, 0.3e-4, -1.95, 0.9540, 5.0, 1.0, DT),
    LinearFit(1.1e-4, 0.5e-4, -1.94, 0.9450, 10.0, 2.0, DT),
]


def _linear(fit: LinearFit) -> StepModel:
    return StepModel(kernels.KIND_LINEAR, fit.to_params(5.0))


def _step(model: StepModel, x: float, xp: float, up: float, u: float) -> float:
    return model.step(np.array([x, xp, up, 0.0]), u)


@pytest.mark.parametrize(
    ("x", "index"), [(0.0, 2), (1.0, 3), (-1.0, 1), (-2.3, 0), (-2.0001, 0), (1.7, 4), (2.4, 4)]
)
def test_blend_is_the_local_model_where_its_membership_is_one(x, index):
    plm = blend(TRUTH, 5.0)
    for u in (-3.0, 0.5, 7.0):
        expected = _step(_linear(TRUTH[index]), x, x - 0.004, u + 0.2, u)
        assert _step(plm, x, x - 0.004, u + 0.2, u) == pytest.approx(expected, abs=1e-14)


def test_blend_between_models_four_and_five_is_their_average_at_1_25():
    """f4(1.25) = 2 (1.5 - 1.25) = 0.5 and f5(1.25) = 2 (1.25 - 1) = 0.5: equal weights."""
    plm = blend(TRUTH, 5.0)
    a = _step(_linear(TRUTH[3]), 1.25, 1.24, 4.0, 4.5)
    b = _step(_linear(TRUTH[4]), 1.25, 1.24, 4.0, 4.5)
    assert _step(plm, 1.25, 1.24, 4.0, 4.5) == pytest.approx(0.5 * (a + b), abs=1e-14)


CENTRES = [-2.3, -1.0, 0.0, 1.0, 2.0]


@pytest.mark.parametrize(
    ("x", "index"), [(-2.3, 0), (-3.0, 0), (-1.0, 1), (0.0, 2), (1.0, 3), (2.0, 4), (2.4, 4)]
)
def test_scheduled_blend_is_the_local_model_at_its_centre_and_beyond_the_outer_ones(x, index):
    plm = blend(TRUTH, 5.0, centres=CENTRES)
    for u in (-3.0, 0.5, 7.0):
        expected = _step(_linear(TRUTH[index]), x, x - 0.004, u + 0.2, u)
        assert _step(plm, x, x - 0.004, u + 0.2, u) == pytest.approx(expected, abs=1e-14)


def test_scheduled_blend_interpolates_linearly_between_neighbouring_centres():
    plm = blend(TRUTH, 5.0, centres=CENTRES)
    x = 0.25  # a quarter of the way from centre 0 (model 3) to centre 1 (model 4)
    a = _step(_linear(TRUTH[2]), x, x - 0.01, 4.0, 4.5)
    b = _step(_linear(TRUTH[3]), x, x - 0.01, 4.0, 4.5)
    assert _step(plm, x, x - 0.01, 4.0, 4.5) == pytest.approx(0.75 * a + 0.25 * b, abs=1e-14)
    assert plm.params.size == kernels.PLM_SCHEDULED_SIZE
    assert [f.coefficients for f in local_from_params(plm.params, DT)] == [f.coefficients for f in TRUTH]


def test_scheduling_centres_must_increase():
    with pytest.raises(InvalidInputError, match="strictly increasing"):
        blend(TRUTH, 5.0, centres=[-2.0, -1.0, 0.0, 0.0, 2.0])
    with pytest.raises(ConfigError, match="scheduling"):
        PlmConfig(scheduling="nearest")  # type: ignore[arg-type]


def test_blend_round_trips_through_packed_params():
    plm = blend(TRUTH, 5.0)
    assert plm.kind == kernels.KIND_PLM and plm.params.size == kernels.PLM_SIZE
    back = local_from_params(plm.params, DT)
    for got, want in zip(back, TRUTH, strict=True):
        assert got.coefficients == want.coefficients and (got.u0, got.y0) == (want.u0, want.y0)


def _records_from_truth() -> dict[float, IOData]:
    records = {}
    for i, (bias, truth) in enumerate(zip(PLM_BIASES, TRUTH, strict=True)):
        u = prbs(PrbsConfig(bias=bias, settle=0, n_samples=3000), seed=i + 1)
        dy = lfilter([0.0, truth.n1, truth.n2], [1.0, truth.d1, truth.d2], u - bias)
        records[bias] = IOData.single(u, truth.y0 + dy, DT, name=f"bias={bias:+g}")
    return records


def test_plm_from_five_known_linear_systems_recovers_them():
    # The paper's construction (printed memberships, separate local fits): each local fit is
    # exactly its system. The refinement would trade that for agreement on the blend.
    records = _records_from_truth()
    plm = identify_plm(records, PlmConfig(scheduling="paper", refine=False))
    for got, want in zip(local_from_params(plm.params, DT), TRUTH, strict=True):
        np.testing.assert_allclose(got.coefficients, want.coefficients, rtol=1e-6, atol=1e-12)
        assert got.u0 == want.u0
        assert got.y0 == pytest.approx(want.y0, abs=1e-8)
    # In the outer regions (f1 = 1 below -2, f5 = 1 above 1.5) the blend is the system itself.
    # The synthetic truth is driven to ±11 N, beyond the plant's F that a surrogate saturates
    # at by default, so the blend is compared with the limit raised to the record's forces.
    unsaturated = replace(plm, force_limit=11.0)
    for bias in (-10.0, 10.0):
        exp = records[bias].experiments[0]
        assert fit_percent(exp.y, free_run(unsaturated, exp)) > 99.999


def test_plm_accepts_pairs_in_any_order():
    """identify_plm sorts the pairs before anything else, so the cheaper unrefined construction
    (the refinement starts from it and sees the same sorted records) shows order cannot matter."""
    records = _records_from_truth()
    shuffled = [(b, records[b]) for b in (5.0, -10.0, 0.0, 10.0, -5.0)]
    unrefined = PlmConfig(refine=False)
    a = identify_plm(records, unrefined)
    b = identify_plm(shuffled, unrefined)
    np.testing.assert_array_equal(a.params, b.params)
    assert a.info["biases"] == list(PLM_BIASES)


def test_wrong_number_of_biases_is_rejected():
    records = _records_from_truth()
    del records[0.0]
    with pytest.raises(InvalidInputError, match="5 distinct biases, got 4"):
        identify_plm(records)
    with pytest.raises(InvalidInputError, match="exactly 5 local models"):
        blend(TRUTH[:3], 5.0)


def test_mixed_sample_times_are_rejected():
    records = _records_from_truth()
    e = records[5.0].experiments[0]
    records[5.0] = IOData.single(e.u, e.y, dt=0.02)
    with pytest.raises(InvalidInputError, match="different sample times"):
        identify_plm(records)


def _default_plant_records(sigma: float) -> tuple[dict[float, IOData], IOData]:
    default = plant.preset("default")
    sensor = SensorModel(noise_std=sigma)
    records = {b: bias_record(default, b, 1000 + i, sensor=sensor) for i, b in enumerate(PLM_BIASES)}
    return records, broad_record(default, 5007, MultilevelConfig(n_samples=4000), sensor=sensor)


def test_scheduling_on_operating_points_and_refining_the_blend_beat_the_paper_construction():
    """On the default plant the bias forces hold the mass at ±1.38 m and ±1.98 m, not at the printed
    memberships' centres ±1 and ±2: at 1.38 m f5 weighs 0.75 and the 5 N model only 0.25. Scheduling on
    the identified operating points and refining all local models on the blend's free-run error fixes
    the region between the centres. Broad-range record of identification seed 0, against the truth:
    paper construction 94.43 %, operating-point scheduling alone 92.84 %, refinement alone 94.40 %,
    both 97.19 % (neither half helps alone here; see docs/decisions.md §PLM).
    """
    records, valid = _default_plant_records(0.0)
    paper = evaluate(identify_plm(records, PlmConfig(scheduling="paper", refine=False)), valid).sim_fit_truth
    model = identify_plm(records)
    ours = evaluate(model, valid).sim_fit_truth
    assert paper is not None and ours is not None
    assert ours >= 96.5
    assert ours >= paper + 2.0
    ref = model.info["refinement"]
    assert ref["kept"] and ref["cost_after"] < 0.1 * ref["cost_before"]
    # The centres are where the plant rests under each bias, whatever the refinement did.
    for b, c in zip(PLM_BIASES, model.info["centres"], strict=True):
        assert c == pytest.approx(plant.equilibrium(b, plant.preset("default")), abs=0.02)


def test_two_mm_of_sensor_noise_costs_the_plm_almost_nothing():
    """Records of the default plant, clean and with 2 mm noise, scored against the noise-free
    truth from estimated initial states.

    Pipeline identification seeds 0, 1, 2 (``msd-bench paper``), before scheduling on the operating
    points and refining the blend: clean 94.43, 92.94, 93.13 %; 2 mm 94.43, 92.96, 93.14 %; after:
    clean 97.19, 96.55, 97.18 %; 2 mm 97.19, 96.53, 97.17 %. Before the output-error fit estimated
    its initial conditions and ranked a prefiltered ARX start, 2 mm gave 94.59, 79.79, 93.31 %.
    """
    fits = {}
    for sigma in (0.0, 0.002):
        records, valid = _default_plant_records(sigma)
        report = evaluate(identify_plm(records), valid)
        assert report.sim_fit_truth is not None
        fits[sigma] = report.sim_fit_truth
    assert fits[0.002] >= 95.0
    assert abs(fits[0.002] - fits[0.0]) < 0.5
