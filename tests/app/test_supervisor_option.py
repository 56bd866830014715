"""``--supervisor on|off`` of the in-process commands: every kind validated behind the compiled filter,
its overrides in the risk records of Table 1 and robustness; off by default."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from msd_bench.app.config import RunConfig
from msd_bench.app.options import add_run_arguments, add_supervisor_argument, run_config_from_args
from msd_bench.app.pipeline import train_and_validate
from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation import robustness
from msd_bench.core.evaluation.scenarios import parse
from msd_bench.core.safety.supervisor import SupervisorOptions
from msd_bench.io.storage.artifacts import load_model

PINNED = Path(__file__).resolve().parents[1] / "data" / "pinned"


def _cfg(*argv: str) -> RunConfig:
    p = argparse.ArgumentParser()
    add_run_arguments(p)
    add_supervisor_argument(p)
    return run_config_from_args(p.parse_args(list(argv)))


def test_the_option_is_off_by_default_and_on_gives_the_default_limits() -> None:
    assert _cfg().supervisor is False and _cfg().supervisor_limits is None
    lim = _cfg("--supervisor", "on").supervisor_limits
    assert lim is not None and lim.envelope == pytest.approx(2.25)
    with pytest.raises(SystemExit):
        _cfg("--supervisor", "yes")
    with pytest.raises(ConfigError, match="supervisor must be true or false"):
        RunConfig(supervisor="on")  # type: ignore[arg-type]


def test_a_baseline_validated_behind_the_supervisor_records_its_overrides(
        monkeypatch: pytest.MonkeyPatch) -> None:
    glm = load_model(PINNED / "glm.json")
    base = {"agents": ("glm+pid",), "validation_steps": 1500, "window": 500}
    off = train_and_validate("glm+pid", glm, RunConfig(**base), [0])
    on = train_and_validate("glm+pid", glm, RunConfig(**base, supervisor=True), [0])
    r_off, r_on = off.metrics[0]["risk"], on.metrics[0]["risk"]
    assert r_off["override_share"] == 0.0 and r_off["overrides"] == {}
    # The default bound counts half the spring: the PID's good nominal run is left alone, bit for bit.
    assert r_on["override_share"] == 0.0 and r_on["aborted"] is None and (on.x == off.x).all()
    # A bound that leaves the spring out brakes the PID's full-force start: the records say so.
    monkeypatch.setattr(RunConfig, "supervisor_limits",
                        property(lambda self: SupervisorOptions(passive_share=0.0).limits(self.plant)))
    strict = train_and_validate("glm+pid", glm, RunConfig(**base, supervisor=True), [0])
    r_strict = strict.metrics[0]["risk"]
    assert r_strict["override_share"] > 0.0 and set(r_strict["overrides"]) == {"envelope"}
    assert r_strict["aborted"] is None and r_strict["contacts"] == 0
    assert strict.record(None).per_seed[0]["risk"] == r_strict
    assert (strict.x != off.x).any()


def test_robustness_cells_behind_the_supervisor_count_overrides_per_run() -> None:
    glm = load_model(PINNED / "glm.json")
    cfg = RunConfig(agents=("glm+pid",), validation_steps=1500, window=500, supervisor=True)
    policy = train_and_validate("glm+pid", glm, cfg, [0, 1]).policy
    sc = parse("noise=0.002")
    cells = robustness.evaluate_policy(policy, cfg.plant, [0, 1], [sc], 1500, 500, cfg.supervisor_limits)
    c = cells[sc.id]
    assert c["n"] == 2 and len(c["risks"]) == 2 and c["risk"]["runs"] == 2
    assert c["risk"]["runs_overridden"] >= 1
    plain = robustness.evaluate_policy(policy, cfg.plant, [0, 1], [sc], 1500, 500)[sc.id]
    assert plain["risk"]["runs_overridden"] == 0 and plain["risk"]["override_share"] == 0.0
