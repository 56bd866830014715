"""The check-rig clauses on synthetic arrays: each passes on a conforming record and fails on a broken one."""

from __future__ import annotations

import math

import numpy as np
import pytest

from msd_bench.core.rigs import conformance as cf
from msd_bench.core.rigs.conformance import Limits

LIM = Limits()
DT = LIM.dt
RNG = np.random.default_rng(3)


def arrivals(n: int = 500, period: float = DT, jitter: float = 0.001) -> np.ndarray:
    return 100.0 + period * np.arange(n) + RNG.uniform(0.0, jitter, n)


def lag(u: np.ndarray, tau: float, delay: int = 0) -> np.ndarray:
    """First-order discrete actuator lag after ``delay`` samples (tau 0: the command itself)."""
    a = 1.0 if tau == 0 else 1.0 - math.exp(-DT / tau)
    out, e = np.zeros_like(u), 0.0
    for k in range(u.size):
        e += a * ((u[k - delay] if k >= delay else 0.0) - e)
        out[k] = e
    return out


def test_one_line_per_clause() -> None:
    c = cf.Clause("rate", False, "80 Hz")
    assert c.line().startswith("FAIL  rate") and "\n" not in c.line()


def test_publishers_and_qos() -> None:
    ok = cf.publishers_clause({"/r/joint_states": 1, "/r/position": 1, "/r/truth/joint_states": 1}, 1, "/r")
    assert ok.passed and "(joint_states 1, position 1, truth/joint_states 1)" in ok.figure
    assert not cf.publishers_clause({"/r/joint_states": 2, "/r/position": 1}, 1).passed
    assert not cf.publishers_clause({"/r/joint_states": 1, "/r/position": 1}, 0).passed
    assert cf.qos_clause({"/r/joint_states": ["reliable"], "/r/force": ["reliable"]}).passed
    bad = cf.qos_clause({"/r/joint_states": ["best-effort"], "/r/force": ["reliable"]})
    assert not bad.passed and "/r/joint_states best-effort" in bad.figure


def test_mode() -> None:
    assert cf.mode_clause(50, None, 0.5).figure.startswith("real-time")
    assert cf.mode_clause(0, 1, 1.0).figure.startswith("lock-step")
    assert not cf.mode_clause(0, 0, 1.0).passed  # silent, even when commanded
    assert cf.mode_clause(0, 2, 1.0).passed  # lock-step; two rows per command are the steps clause's


def stamps(n: int = 500) -> np.ndarray:
    return (10_000_000 * np.arange(n)).astype(np.int64)


def test_rate_within_half_a_percent() -> None:
    assert cf.rate_clause(arrivals(), stamps(), LIM).passed
    slow = cf.rate_clause(arrivals(period=DT * 1.01), stamps(), LIM)  # 99 Hz, stamps 10 ms apart
    assert not slow.passed and slow.figure.startswith("99.0")
    assert cf.rate_clause(arrivals(period=DT * 1.01), stamps(), Limits(timing_tolerance=4)).passed
    assert not cf.rate_clause(arrivals(period=DT * 1.25), stamps(), Limits(timing_tolerance=10)).passed


def test_rate_is_not_fooled_by_a_stall_and_its_catch_up() -> None:
    t = arrivals()
    t[100:150] = t[150]  # 0.5 s without a row, then 50 rows at once (the deadline pacer's burst)
    t[-1] += 0.2  # and the very last row late
    fig = cf.rate_clause(t, stamps(), LIM)
    assert fig.passed, fig.figure


def test_stamps_period_monotonicity_and_gaps() -> None:
    s = (np.arange(500) * 10_000_000).astype(np.int64)
    assert cf.stamps_clause(s, LIM).passed
    back = s.copy()
    back[100] = back[99]
    assert "strictly increase" in cf.stamps_clause(back, LIM).figure
    assert not cf.stamps_clause((s * 1.01).astype(np.int64), LIM).passed
    gappy = np.delete(s, np.arange(10, 500, 40))  # 12 lost samples of 488 periods: 2.5 % gaps
    assert not cf.stamps_clause(gappy, LIM).passed
    assert cf.stamps_clause(gappy, Limits(timing_tolerance=5)).passed


def test_interarrival_p99() -> None:
    assert cf.interarrival_clause(arrivals(), LIM).passed
    t = arrivals()
    t[50::40] += 0.03  # 2.5 % of gaps 40 ms
    assert not cf.interarrival_clause(t, LIM).passed
    assert cf.interarrival_clause(t, Limits(timing_tolerance=2)).passed


def test_lockstep_steps_and_clock() -> None:
    s = (np.arange(20) * 10_000_000).astype(np.int64)
    assert cf.lockstep_steps_clause([1] * 20, [1] * 20, 0, s, DT).passed
    assert not cf.lockstep_steps_clause([1] * 19 + [2], [1] * 20, 0, s, DT).passed
    assert not cf.lockstep_steps_clause([1] * 20, [1] * 20, 3, s, DT).passed
    assert not cf.lockstep_steps_clause([1] * 20, [1] * 20, 0, s * 2, DT).passed
    expected = [int(v) + 10_000_000 for v in s]
    assert cf.clock_clause(["/msd/plant"], "/msd/plant", expected, expected).passed
    assert cf.clock_clause([], "/surrogate/plm/surrogate", [], expected).passed
    assert cf.clock_clause(["/msd/plant"], "/surrogate/plm/surrogate", [], expected).passed
    assert not cf.clock_clause(["/msd/plant", "/s/surrogate"], "/msd/plant", expected, expected).passed
    assert not cf.clock_clause(["/msd/plant"], "/msd/plant", [int(v) for v in s], expected).passed


def test_a_position_count_shortfall_fails_strictly_and_is_a_timing_matter_when_lenient() -> None:
    x = np.cumsum(RNG.normal(0, 0.01, 600))
    short = x[:450]  # 150 fewer position messages than rows: a subscriber starved at the end
    assert not cf.position_clause(x, short, LIM).passed
    assert cf.position_clause(x, short, Limits(timing_tolerance=10.0)).passed
    assert not cf.position_clause(x, x[590:], Limits(timing_tolerance=10.0)).passed  # too few to align


def test_position_agrees_with_joint_states_at_any_subscription_offset() -> None:
    x = np.cumsum(RNG.normal(0, 0.01, 300))
    assert cf.position_clause(x[:-1], x[4:], LIM).passed  # position is x_{k+1}; streams start 3 apart
    assert not cf.position_clause(x, x * 1000.0, LIM).passed  # millimetres on one topic
    assert not cf.position_clause(x, x + RNG.normal(0, 0.002, x.size), LIM).passed  # drawn twice
    jump = x.copy()
    jump[150] += 0.5  # the one sample a real-time reset replaces
    assert not cf.position_clause(x, jump, LIM).passed
    assert cf.position_clause(x, jump, LIM, resets=1).passed


@pytest.mark.parametrize(("tau", "delay"), [(0.0, 0), (0.0, 1), (0.03, 1), (0.08, 2)])
def test_step_response_measures_delay_and_time_constant(tau: float, delay: int) -> None:
    u = np.r_[np.zeros(10), np.full(80, 3.0)]
    e = lag(u, tau, delay)
    resp = cf.step_response(e, 10, 0.0, 3.0, LIM)
    assert resp.delay == delay
    assert resp.tau == pytest.approx(tau, abs=1e-9)
    assert cf.effort_step_clause(resp, 3.0, LIM).passed


@pytest.mark.parametrize("tau", [0.005, 0.02, 0.05])
def test_time_constant_of_an_effort_reported_as_the_lag_mean_over_each_sample(tau: float) -> None:
    """The rig emulator reports the lag's mean over the sample: U (1 - beta e^(-j dt/tau))."""
    beta = (tau / DT) * (1.0 - math.exp(-DT / tau))
    j = np.arange(80, dtype=np.float64)
    e = np.r_[np.zeros(11), 3.0 * (1.0 - beta * np.exp(-j * DT / tau))]
    resp = cf.step_response(e, 10, 0.0, 3.0, LIM)
    assert resp.delay == 1 and resp.tau == pytest.approx(tau, rel=1e-6)


def test_first_carrier_counts_from_the_send_time_on_the_stamps() -> None:
    stamps = (1_000_000_000 + 10_000_000 * np.arange(50)).astype(np.int64)
    late = stamps + 40_000_000  # rows read 40 ms late by a starved checker
    sent = int(stamps[20]) - 3_000_000
    assert cf.first_carrier(stamps, late, sent, fallback=24) == 20
    other_clock = stamps - 10**15  # a driver stamping on its own clock: count from arrival instead
    assert cf.first_carrier(other_clock, late, sent, fallback=24) == 24


def test_effort_that_never_reaches_or_exceeds_the_limit_fails() -> None:
    u = np.r_[np.zeros(10), np.full(80, 3.0)]
    slow = cf.step_response(lag(u, 0.3), 10, 0.0, 3.0, LIM)
    assert slow.tau == pytest.approx(0.3) and not cf.effort_step_clause(slow, 3.0, LIM).passed
    stuck = cf.step_response(np.zeros(90), 10, 0.0, 3.0, LIM)
    assert stuck.delay == -1 and "never" in cf.effort_step_clause(stuck, 3.0, LIM).figure
    spike = lag(u, 0.0)
    spike[12] = 11.0
    over = cf.step_response(spike, 10, 0.0, 3.0, LIM)
    assert "exceeds the limit" in cf.effort_step_clause(over, 3.0, LIM).figure


def test_a_stall_before_the_effort_moves_is_a_timing_matter_a_slow_rise_is_not() -> None:
    u = np.r_[np.zeros(10), np.full(130, 3.0)]
    stalled = cf.step_response(lag(u, 0.0, delay=60), 10, 0.0, 3.0, LIM)  # 0.6 s of dead time
    assert not cf.effort_step_clause(stalled, 3.0, LIM).passed
    assert cf.effort_step_clause(stalled, 3.0, Limits(timing_tolerance=2)).passed
    slow = cf.step_response(lag(u, 0.3), 10, 0.0, 3.0, LIM)
    assert not cf.effort_step_clause(slow, 3.0, Limits(timing_tolerance=10)).passed


def test_saturation() -> None:
    assert cf.saturation_clause(lag(np.full(60, -10.0), 0.05), -12.5, LIM).passed
    assert not cf.saturation_clause(np.full(60, -12.5), -12.5, LIM).passed  # not clamped
    assert not cf.saturation_clause(np.full(60, -5.0), -12.5, LIM).passed  # clamped too low
    assert not cf.saturation_clause(np.array([]), -12.5, LIM).passed


def test_nonfinite() -> None:
    held = np.full(12, 3.0)
    assert cf.nonfinite_clause(held, np.zeros(12), 3.0, 3.0, 6, LIM).passed
    assert cf.nonfinite_clause(np.linspace(3.0, 0.0, 12), np.zeros(12), 3.0, 3.0, 6, LIM).passed  # safe stop
    assert not cf.nonfinite_clause(np.r_[held[:5], math.nan, held[6:]], np.zeros(12), 3.0, 3.0, 6, LIM).passed
    inf_as_f = np.r_[held[:5], 10.0, held[6:]]
    assert not cf.nonfinite_clause(inf_as_f, np.zeros(12), 3.0, 3.0, 6, LIM).passed
    assert not cf.nonfinite_clause(held, np.r_[np.zeros(11), math.inf], 3.0, 3.0, 6, LIM).passed


def test_watchdog() -> None:
    t = 0.01 * np.arange(100)
    resp = cf.StepResponse(0, 0.0, 0.0, 3.0)
    allowance = cf.watchdog_allowance(resp, LIM)
    ok = np.where(t < 0.51, 3.0, 0.0)
    assert cf.watchdog_clause(t, ok, 0.0, 3.0, allowance, LIM).passed
    assert not cf.watchdog_clause(t, np.full(100, 3.0), 0.0, 3.0, allowance, LIM).passed  # never stops
    assert not cf.watchdog_clause(t, np.where(t < 0.8, 3.0, 0.0), 0.0, 3.0, allowance, LIM).passed  # late
    assert not cf.watchdog_clause(t, np.where(t < 0.1, 3.0, 0.0), 0.0, 3.0, allowance, LIM).passed  # early
    lagging = cf.StepResponse(1, 0.05, 0.2, 3.0)  # a lagging actuator gets its measured lag on top
    assert cf.watchdog_allowance(lagging, LIM) == pytest.approx(allowance + 0.01 + 0.25)


def test_reset_realtime_and_lockstep() -> None:
    t = 0.01 * np.arange(50)
    x = np.where(t < 0.1, 0.4, 0.0)
    e = np.where(t < 0.1, 3.0, 0.0)
    assert cf.reset_realtime_clause(True, t, x, e, 0.05, 0.4, LIM).passed
    assert not cf.reset_realtime_clause(True, t, np.full(50, 0.4), e, 0.05, 0.4, LIM).passed  # ignored
    assert not cf.reset_realtime_clause(True, t, x, e, 0.05, 0.001, LIM).passed  # cannot be seen
    unsupported = cf.reset_realtime_clause(False, t, x, e, 0.0, 0.0, LIM)
    assert unsupported.passed and "unsupported" in unsupported.figure
    assert cf.reset_lockstep_clause(True, [0.0], 0, 0, 0.0).passed
    assert not cf.reset_lockstep_clause(True, [], 0, 0, 0.0).passed  # not acknowledged
    assert not cf.reset_lockstep_clause(True, [0.0], 1, 0, 0.0).passed  # stepped on reset
    assert not cf.reset_lockstep_clause(True, [0.0], 0, 10_000_000, 0.0).passed  # not sample 0
    assert cf.reset_lockstep_clause(False, [], 0, None, None).passed


def test_joint_clause_names_the_joint_and_its_entry() -> None:
    from msd_bench.core.rigs.conformance import joint_clause

    ok = joint_clause(300, 0, "slider_to_cart", ["pole_joint", "slider_to_cart"])
    assert ok.passed and "entry 2 of 2" in ok.figure
    missing = joint_clause(300, 12, "cart", ["pole_joint", "slider_to_cart"])
    assert not missing.passed and "12 of 300 rows lack joint 'cart'" in missing.figure
    assert not joint_clause(0, 0, "cart", []).passed
