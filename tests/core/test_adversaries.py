"""The proof against bad controllers: behind the supervisor no adversary touches a stop or leaves
the envelope by more than its margin, on the plant and on the rig emulator; without it they do."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation.risk import RunRisk, run_risk
from msd_bench.core.physics.plant import PRESETS, PlantParams
from msd_bench.core.rigs.rig import RigImperfections
from msd_bench.core.safety.adversaries import (
    ADVERSARIES,
    Runs,
    adversary,
    resonance,
    run_on_plant,
    run_on_rig,
)
from msd_bench.core.safety.supervisor import Limits, SupervisorOptions

PLANT = PRESETS["default"]
STEPS = 3000  # one validation episode, 30 s
LIM = SupervisorOptions().limits(PLANT)
RIGS = {
    "defaults": RigImperfections(),
    "ideal": RigImperfections.none(),
    "laggy": RigImperfections(delay_samples=2, actuator_tau=0.05, friction=0.0),
    "noisy": RigImperfections(sensor_noise=0.005, sensor_quant=0.001, friction=0.5),
}
"""Rig imperfections the proof runs under (the rig's own plant: docs/rig.md §Preset)."""


def risks(runs: Runs, plant: PlantParams, lim: Limits) -> list[RunRisk]:
    return [run_risk(runs.x[j], runs.v[j], dt=plant.dt, half_stroke=plant.x_max, envelope=lim.envelope,
                     margin=lim.margin, reasons=runs.reason[j], abort=int(runs.aborts[j]))
            for j in range(runs.x.shape[0])]


def test_the_resonance_is_the_plants() -> None:
    assert resonance(PLANT) == pytest.approx(np.sqrt(2.4), rel=1e-12)


def test_an_unknown_adversary_is_one_line() -> None:
    with pytest.raises(ConfigError, match="unknown adversary 'nice'"):
        adversary("nice", PLANT, 10)


@pytest.mark.parametrize("name", sorted(ADVERSARIES))
def test_on_the_plant_no_adversary_reaches_a_stop_behind_the_supervisor(name: str) -> None:
    seeds = list(range(100)) if name == "random" else [0]
    adv = adversary(name, PLANT, STEPS, seeds)
    free = risks(run_on_plant(PLANT, LIM, adv, np.zeros((len(seeds), STEPS)), supervised=False), PLANT, LIM)
    guarded = risks(run_on_plant(PLANT, LIM, adv, np.zeros((len(seeds), STEPS))), PLANT, LIM)
    assert sum(r.contacts for r in guarded) == 0
    assert sum(r.exits_beyond_margin for r in guarded) == 0
    assert max(r.peak_x for r in guarded) < LIM.envelope + LIM.margin
    if name != "turncoat":  # the others drive the unguarded mass into a stop
        assert sum(r.contacts for r in free) >= 1
    else:
        assert max(r.peak_x for r in free) > LIM.envelope  # it leaves the envelope unguarded


def test_the_random_alphabet_behind_the_supervisor_under_sensor_noise() -> None:
    seeds = list(range(100))
    adv = adversary("random", PLANT, STEPS, seeds)
    noise = np.random.default_rng(11).normal(0.0, 0.002, (len(seeds), STEPS))
    guarded = risks(run_on_plant(PLANT, LIM, adv, noise), PLANT, LIM)
    assert sum(r.contacts + r.exits_beyond_margin for r in guarded) == 0


def test_the_turncoat_is_left_alone_while_it_behaves() -> None:
    runs = run_on_plant(PLANT, LIM, adversary("turncoat", PLANT, STEPS), np.zeros((1, STEPS)))
    switch = int(15.0 / PLANT.dt)
    assert np.count_nonzero(runs.reason[0, :switch]) == 0
    assert np.count_nonzero(runs.reason[0, switch:]) > 0
    assert risks(runs, PLANT, LIM)[0].aborted == "divergence"


@pytest.mark.parametrize("rig", sorted(RIGS))
@pytest.mark.parametrize("name", sorted(ADVERSARIES))
def test_on_the_rig_emulator_no_adversary_reaches_a_stop_behind_the_supervisor(name: str, rig: str) -> None:
    plant = PRESETS["rig"]  # the supervisor is told the nominal plant; the rig is another
    adv = adversary(name, plant, STEPS, [3])
    guarded = run_on_rig(plant, RIGS[rig], SupervisorOptions().limits(PLANT), adv, STEPS, seed=3)
    r = risks(guarded, plant, LIM)[0]
    assert r.contacts == 0 and r.exits_beyond_margin == 0


def test_without_the_supervisor_the_rig_is_driven_into_its_stops() -> None:
    plant = PRESETS["rig"]
    contacts = {name: risks(run_on_rig(plant, RigImperfections(), None, adversary(name, plant, STEPS, [3]),
                                       STEPS, seed=3), plant, LIM)[0].contacts
                for name in ("always_plus", "always_minus", "bang_bang")}
    assert all(c >= 1 for c in contacts.values()), contacts


def test_a_stated_envelope_is_held_too() -> None:
    opts = SupervisorOptions(envelope=1.5, margin=0.1)
    lim = opts.limits(PLANT)
    for name in ("always_plus", "bang_bang"):
        runs = run_on_plant(PLANT, lim, adversary(name, PLANT, STEPS), np.zeros((1, STEPS)))
        assert risks(runs, PLANT, lim)[0].peak_x < 1.6
    lim_heavy = opts.limits(replace(PLANT, m=1.2))  # told a heavier mass: still holds on the plant
    runs = run_on_plant(PLANT, lim_heavy, adversary("bang_bang", PLANT, STEPS), np.zeros((1, STEPS)))
    assert risks(runs, PLANT, lim_heavy)[0].peak_x < 1.6
