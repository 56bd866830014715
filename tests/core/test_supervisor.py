"""The supervisor's core: options, the filter's decisions, the run guards, the e-stop rule, parity."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.plant import PRESETS
from msd_bench.core.safety.adversaries import adversary, run_on_plant
from msd_bench.core.safety.supervisor import (
    DIVERGENCE,
    ENVELOPE,
    ESTOP,
    NONE,
    STALE,
    TIME_LIMIT,
    VELOCITY,
    Limits,
    LogThrottle,
    Supervisor,
    SupervisorOptions,
    braking_distance,
    parse_latch,
    stop_position,
)

PLANT = PRESETS["default"]


def test_defaults_are_derived_from_the_stroke_and_printed() -> None:
    lim = SupervisorOptions().limits(PLANT)
    assert lim.envelope == pytest.approx(0.9 * PLANT.x_max)
    assert lim.envelope + lim.margin < PLANT.x_max
    assert lim.brake == pytest.approx(0.6 * PLANT.F / (1.3 * PLANT.m))
    line = lim.describe()
    assert "\n" not in line and "±2.25 m" in line


@pytest.mark.parametrize(("values", "needle"), [
    ({"envelope": 2.6}, "inside the stroke"),
    ({"envelope": 2.4, "margin": 0.2}, "must stay below the stop"),
    ({"brake_share": 0.0}, "brake_share"),
    ({"v_margin": float("nan")}, "finite number"),
    ({"v_margin": "fast"}, "finite number"),
    ({"latency": -1.0}, ">= 0"),
    ({"stale_timeout": 0.0}, "stale_timeout"),
    ({"mass_factor": 0.5}, "mass_factor"),
    ({"passive_share": 1.5}, "passive_share"),
    ({"speed": 1.0}, "unknown option 'speed'"),
])
def test_a_bad_option_is_one_line(values: dict[str, object], needle: str) -> None:
    with pytest.raises(ConfigError) as err:
        SupervisorOptions.from_mapping(values).limits(PLANT)
    assert needle in str(err.value) and "\n" not in str(err.value)


def test_the_braking_distance_is_the_integral_of_its_deceleration() -> None:
    cases = [(4.6, 0.0, 3.0), (4.6, 0.385, 3.0), (1.0, 2.0, 5.0), (5.0, 1e-9, 0.5), (3.0, 0.4, 0.0)]
    for b, beta, w in cases:
        v, x, h = w, 0.0, 1e-5  # v' = -(b + beta v) by small steps, until it stops
        while v > 0.0:
            x += v * h
            v -= (b + beta * v) * h
        assert braking_distance(b, beta, w) == pytest.approx(x, abs=1e-4)


def _true_stop(lim: Limits, plant_scale: float, p: float, w: float, u: float) -> float:
    """Where the nominal plant with its spring and damper scaled by ``plant_scale`` and its mass
    ``mass_factor`` times heavier stops: ``u`` held for the latency, then brake_share of F."""
    m, dt = PLANT.m * 1.3, 1e-4
    x, v, t = p, w, 0.0
    while v > 0.0 or t < lim.latency:
        f = u if t < lim.latency else -0.6 * PLANT.F
        spring = plant_scale * (PLANT.k * np.sin(PLANT.g * x) + PLANT.h * x**3)
        v += (f - plant_scale * PLANT.c * v - spring) / m * dt
        x += v * dt
        t += dt
    return x


@pytest.mark.parametrize("p", [-1.0, 0.0, 0.5, 1.5, 2.0])
@pytest.mark.parametrize("w", [0.5, 2.0, 4.0])
def test_the_bound_holds_on_a_plant_with_half_the_stated_spring_and_damper(p: float, w: float) -> None:
    """From the far side of the origin the spring first pushes the mass outward and the bound can
    fall short of the true stop, but only below the start's mirror image ``|p|`` (the spring's
    potential is even), which is inside the envelope: the filter's claim holds either way."""
    lim = SupervisorOptions(v_margin=0.0).limits(PLANT)
    for u in (0.0, PLANT.F):
        true = _true_stop(lim, 0.5, p, w, u)
        assert max(stop_position(lim, p, w, u), abs(p)) >= true


def test_a_fast_good_approach_is_not_overridden() -> None:
    """The baselines pass about 0.5 m at about 3 m/s on their way to 1 m: with the drive alone the
    bound put the stop past the envelope (every nominal baseline run overridden), with half the
    stated spring and damper it does not."""
    assert stop_position(SupervisorOptions().limits(PLANT), 0.5, 3.0, PLANT.F) < 2.25
    drive_only = SupervisorOptions(passive_share=0.0).limits(PLANT)
    assert stop_position(drive_only, 0.5, 3.0, PLANT.F) > 2.25


def test_a_safe_command_passes_and_control_is_handed_back() -> None:
    sup = Supervisor(SupervisorOptions(), PLANT)
    assert sup.step(0.0, 1.0, 5.0) == (5.0, NONE)
    # near the upper envelope moving outward: +F would carry the mass past it, so the brake
    sup.reset()
    sup.step(2.10, 1.0, 0.0)
    d = sup.step(2.12, 1.0, 10.0)
    assert d.overridden and d.force == -PLANT.F and d.reason == ENVELOPE
    # the brake itself is not an override; once the mass moves inward the command is passed again
    assert sup.step(2.12, 1.0, -10.0) == (-10.0, NONE)
    assert sup.step(2.11, 1.0, 0.0) == (0.0, NONE)
    assert sup.counts["envelope"] == 1 and sup.steps == 4


def test_the_lower_side_is_guarded_the_same() -> None:
    sup = Supervisor(SupervisorOptions(), PLANT)
    sup.step(-2.10, -1.0, 0.0)
    assert sup.step(-2.12, -1.0, -10.0) == (PLANT.F, ENVELOPE)


def test_the_velocity_limit_brakes_only_a_push_along_the_motion() -> None:
    sup = Supervisor(SupervisorOptions(v_max=1.0), PLANT)
    sup.step(-0.1, 0.0, 0.0)
    assert sup.step(-0.08, 0.0, -5.0) == (-5.0, NONE)  # 2 m/s inward, pushing against the motion
    sup.reset()
    sup.step(0.0, 0.0, 0.0)
    assert sup.step(0.02, 0.0, 5.0) == (-PLANT.F, VELOCITY)  # 2 m/s, pushing along the motion
    assert sup.step(0.04, 0.0, -5.0) == (-5.0, NONE)  # braking is allowed


def test_time_limit_and_divergence_abort_the_run() -> None:
    sup = Supervisor(SupervisorOptions(time_limit=0.05), PLANT)
    reasons = [sup.step(0.0, 0.0, 5.0).reason for _ in range(6)]
    assert reasons[:4] == [NONE] * 4 and reasons[4:] == [TIME_LIMIT] * 2
    assert sup.aborted == "time_limit"
    sup = Supervisor(SupervisorOptions(div_time=0.1, div_tol=0.02), PLANT)
    # the error falls to 0.98, then grows 1 cm a sample: above 0.98 + 0.02 from sample 5 on
    errors = [1.0, 0.99, 0.98] + [0.99 + 0.01 * i for i in range(14)]
    out = [sup.step(1.0 - e, 1.0, 2.0) for e in errors]
    assert all(d == (2.0, NONE) for d in out[:14]) and out[14].reason == DIVERGENCE
    assert out[-1] == (0.0, DIVERGENCE) and sup.aborted == "divergence"


def test_a_stale_state_aborts_with_zero_force() -> None:
    sup = Supervisor(SupervisorOptions(), PLANT)
    sup.step(0.5, 1.0, 5.0)
    assert sup.stale() == (0.0, STALE)
    assert sup.step(0.5, 1.0, 5.0) == (0.0, STALE) and sup.aborted == "stale"


def test_the_estop_latches_and_clears_only_by_naming_its_latch() -> None:
    sup = Supervisor(SupervisorOptions(), PLANT)
    assert sup.latch_estop() == 1
    assert sup.step(0.0, 1.0, 5.0) == (0.0, ESTOP)
    assert sup.latch_estop() == 2
    sup.reset()  # a new run never clears it
    assert sup.step(0.0, 1.0, 5.0) == (0.0, ESTOP)
    assert not sup.clear_estop(1)  # a clear sent before the later latch clears nothing
    assert sup.estop_latched
    assert sup.clear_estop(2)
    assert not sup.clear_estop(2)  # replayed
    assert sup.step(0.0, 1.0, 5.0) == (0.0, ESTOP)  # the aborted run stays aborted
    sup.reset()
    assert sup.step(0.0, 1.0, 5.0) == (5.0, NONE)


@pytest.mark.parametrize("name", ["random", "bang_bang", "turncoat"])
def test_the_stepwise_form_is_the_compiled_one_bit_for_bit(name: str) -> None:
    n = 2000
    adv = adversary(name, PLANT, n, [7])
    noise = np.random.default_rng(5).normal(0.0, 0.002, (1, n))
    batch = run_on_plant(PLANT, SupervisorOptions().limits(PLANT), adv, noise)
    assert np.count_nonzero(batch.reason) > 0  # the filter acted: the comparison is not vacuous
    sup = Supervisor(SupervisorOptions(), PLANT)
    y = batch.x[0] + noise[0]
    for k in range(n):
        d = sup.step(y[k], 1.0, batch.command[0, k])
        assert d.force == batch.force[0, k] and d.reason == batch.reason[0, k], k
    assert int(sup.state[5]) == batch.aborts[0]


@pytest.mark.parametrize(("text", "latch"), [
    ("1", 1), (" 12 ", 12), ("01", -1), ("001", -1), ("+1", -1), ("1.0", -1), ("١", -1), ("", -1),
    ("0", 0), ("00", -1), ("1" * 21, -1),
])
def test_a_clear_names_its_latch_in_one_spelling_only(text: str, latch: int) -> None:
    assert parse_latch(text) == latch


def test_wrong_clears_are_one_line_a_second_with_their_count() -> None:
    throttle = LogThrottle(1.0)
    lines = [c for c in (throttle.note(i / 1000) for i in range(3000)) if c]  # 3,000 clears in 3 s
    assert lines == [1, 1000, 1000] and throttle.pending == 999
    assert throttle.note(10.0) == 1000  # the next line carries the ones held back
