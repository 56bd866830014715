"""Property: any scenario text is a Scenario or one ConfigError line; any rig seed a member or one line.

The scenario text form is read from the command line (``--scenario``, node scenarios) and a
rig seed from ``-p population_seed:=N`` or a report; neither may crash or accept a value the
compiled loop would misread (a negative lag, a lag beyond the emulator's range).
"""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation.scenarios import parse
from msd_bench.core.rigs import population

KEYS = ("setpoint", "noise", "quant", "delay", "lag", "disturbance", "friction", "mass", "damping",
        "spring", "hardening", "bogus", "")
VALUES = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr),
                   st.integers(-100, 100).map(str), st.text(max_size=6),
                   st.tuples(st.floats(-5, 5), st.floats(-1, 60)).map(lambda t: f"{t[0]}@{t[1]}"))
ITEM = st.tuples(st.sampled_from(KEYS), st.sampled_from(("=", "", "==")), VALUES).map("".join)
TEXT = st.one_of(st.lists(ITEM, min_size=1, max_size=4).map(",".join), st.text(max_size=40))


@given(TEXT)
def test_any_scenario_text_is_a_scenario_or_one_line(text: str) -> None:
    try:
        sc = parse(text)
    except ConfigError as err:
        assert "\n" not in str(err) and str(err)
        return
    assert 0.0 <= sc.lag <= 1.0 and sc.delay >= 0
    assert all(math.isfinite(v) for v in (sc.setpoint, sc.noise, sc.quant, sc.lag, sc.friction))


@given(st.one_of(st.integers(-2**40, 2**40), st.floats(), st.text(max_size=5), st.booleans(), st.none()))
def test_any_seed_is_a_member_within_the_ranges_or_one_line(seed: object) -> None:
    try:
        spec = population.draw(seed)  # type: ignore[arg-type]
    except ConfigError as err:
        assert "\n" not in str(err) and "rig seed" in str(err)
        return
    d = population.DISTRIBUTION
    assert all(d.multiplier[0] <= r <= d.multiplier[1] for r in spec.multipliers().values()) \
        or spec.seed == population.EMULATOR_SEED
    i = spec.imperfections
    assert d.friction[0] <= i.friction <= d.friction[1] and d.lag[0] <= i.actuator_tau <= d.lag[1]
    assert i.delay_samples in range(d.delay[0], d.delay[1] + 1) and i.sensor_quant in d.quant
    assert "\n" not in spec.line()
