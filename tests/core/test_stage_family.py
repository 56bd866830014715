"""The stage family's draws, its hold loop and the records of the held system (issue 38 item 3)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from msd_bench.app.pipeline import identify_each
from msd_bench.app.plan import paper_plan
from msd_bench.core.physics.plant import DT
from msd_bench.core.rigs import stage_family
from msd_bench.core.rigs.hold import HoldLoop, beyond_loop
from msd_bench.core.rigs.rest import RestConfig
from msd_bench.core.rigs.rig import Rig
from msd_bench.core.rigs.rig_play import play, play_plan, records_of
from msd_bench.core.rigs.stage_family import STAGES, draw

SEEDS = range(1, 401)


@pytest.fixture(scope="module")
def stages() -> list:
    return [draw(s) for s in SEEDS]


def test_a_seed_names_one_stage_and_seeds_differ() -> None:
    assert draw(7) == draw(7) and draw(7) != draw(8)
    assert draw(7).family == "stage" and draw(7).hold is not None


def test_every_draw_lies_in_the_stated_ranges_and_covers_them(stages) -> None:
    d = STAGES
    shares = {"m": [], "L": [], "F": [], "friction": [], "offset": [], "spring": []}
    for s in stages:
        p, i = s.params, s.imperfections
        shares["m"].append(p.m), shares["L"].append(p.L), shares["F"].append(p.F)
        shares["friction"].append(i.friction / p.F), shares["offset"].append(i.offset / p.F)
        half = p.L / 2
        shares["spring"].append((p.k * math.sin(p.g * half) + p.h * half**3) / p.F)
        assert 1.0 / p.dt in d.rates and i.sensor_quant in d.quant and i.sensor_noise == 0.0
        assert p.m / p.c == pytest.approx(np.clip(p.m / p.c, *d.coast))
        assert d.lag[0] <= i.actuator_tau <= d.lag[1] and i.jitter < p.dt
        assert 0 <= i.delay_samples <= round(d.delay[1] / p.dt)
    for name, span in (("m", d.mass), ("L", d.stroke), ("F", d.force), ("friction", d.friction),
                       ("spring", d.spring)):
        lo, hi = min(shares[name]), max(shares[name])
        assert span[0] * (1 - 1e-9) <= lo and hi <= span[1] * (1 + 1e-9), name
        assert lo < span[0] + 0.2 * (span[1] - span[0]) and hi > span[1] - 0.2 * (span[1] - span[0]), name
    offsets = np.array(shares["offset"])
    assert np.abs(offsets).max() <= d.offset[1] and (offsets > 0).any() and (offsets < 0).any()
    assert {1.0 / s.params.dt for s in stages} == set(d.rates)


def test_the_owner_states_the_time_unit_and_the_loop_from_a_nominal_mass(stages) -> None:
    """The pace and the loop's damping come from the owner's estimate of the mass, never the drawn one;
    a decision is the paper's 10 ms in the stage's time unit, whole samples, at least one."""
    off = 0
    for s in stages:
        p = s.params
        truth = stage_family.time_unit(p.L, p.F, p.m)
        ratio = (s.pace / truth) ** 2  # the nominal mass over the drawn one
        assert STAGES.mass_known[0] * (1 - 1e-9) <= ratio <= STAGES.mass_known[1] * (1 + 1e-9)
        off += abs(ratio - 1) > 0.01
        stated = HoldLoop.stated(p.L, p.F, p.m * ratio)
        assert (s.hold.stiffness, s.hold.damping, s.hold.held) == pytest.approx(
            (stated.stiffness, stated.damping, 0.0))
        assert s.decision_samples() == max(1, round(DT * s.pace / p.dt)) >= 1
        scales = s.scales()
        assert (scales.length, scales.force, scales.pace) == pytest.approx((p.L / 5, p.F / 10, s.pace))
    assert off > 0.8 * len(stages)


def _broad_plan(spec):
    scales = spec.scales()
    return [i for i in paper_plan(0, scales.samples(1500), scales.samples(600), scales.samples(100),
                                  scales=scales) if i.bias is None]


def test_open_loop_a_stage_walks_into_a_stop_and_its_hold_loop_keeps_it_inside() -> None:
    spec = draw(3)
    peaks = {}
    for name, hold in (("open", None), ("held", spec.hold)):
        rig = Rig(spec.params, spec.imperfections, seed=3)
        played = play_plan(rig, _broad_plan(spec), RestConfig().scaled(spec.scales()), hold)
        peaks[name] = max(np.abs(p.truth).max() for p in played) / spec.params.x_max
        assert all(p.rest.still for p in played)
    assert peaks["open"] == 1.0 and peaks["held"] < 0.95


def test_the_held_systems_input_is_the_signal_on_an_ideal_drive() -> None:
    """No drive dynamics and no saturation: the force beyond the loop's is the planned signal exactly,
    so what the held records carry is the external excitation (the indirect method's input)."""
    spec = draw(5)
    imp = replace(spec.imperfections, delay_samples=0, actuator_tau=0.0, sensor_quant=0.0)
    rig = Rig(spec.params, imp, seed=1)
    signal = 0.3 * spec.params.F * np.sign(np.sin(np.arange(2000) / 37.0))
    command, effort, measured, _, _ = play(rig, signal, spec.hold)
    assert np.array_equal(command, effort) and not np.array_equal(command, signal)
    assert np.allclose(beyond_loop(effort, measured, spec.hold, spec.params.dt), signal, rtol=0, atol=1e-9)


def test_the_held_system_is_identified_where_the_open_loop_fit_drifts() -> None:
    """A design stage's held records: a simulation-error fit of the held system (bounded: it is stable)
    reproduces the validation record, the same records read as the plant's drift away."""
    spec = draw(2)
    scales = spec.scales()
    rig = Rig(spec.params, spec.imperfections, seed=2)
    played = play_plan(rig, _broad_plan(spec), RestConfig().scaled(scales), spec.hold)
    wide = replace(spec.params, F=3 * spec.params.F)  # the held system's input reaches past ±F
    in_wide = replace(scales, force=scales.force * 3)
    fit = {}
    for name, hold in (("plant", None), ("held", spec.hold)):
        records = records_of(played, spec.params.dt, hold)
        _, fits, failed = identify_each(records, ["glm"], 0, wide, 1.0, scales=in_wide)
        assert not failed
        fit[name] = fits["glm"].as_row()["fit_sim_percent"]
    assert fit["held"] >= 90.0 and fit["held"] > fit["plant"] + 20.0, fit
