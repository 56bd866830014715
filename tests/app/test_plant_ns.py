"""bench.py --plant-ns: which kinds and scenarios run against a foreign node, its domain, its duration."""

from __future__ import annotations

import os

import pytest

from msd_bench.app import plant_ns
from msd_bench.core.errors import ConfigError
from msd_bench.graph import domains
from msd_bench.graph import main as bench_main


def test_kinds_on_the_emulators_model_are_left_out_with_a_note() -> None:
    kept, dropped = plant_ns.split_kinds(("plm", "plant", "plant+improved", "plant+robust", "dyna-q",
                                          "plant@away"))
    assert kept == ("plm", "dyna-q")
    assert dropped == ("plant", "plant+improved", "plant+robust", "plant@away")
    note = plant_ns.left_out_note(dropped)
    assert "\n" not in note and "plant+robust" in note and "emulator's own model" in note
    assert plant_ns.left_out_note(()) == ""


def test_only_emulator_kinds_is_a_one_line_error() -> None:
    with pytest.raises(ConfigError, match="needs the emulator's own model"):
        plant_ns.split_kinds(("plant", "plant+robust"))


def test_default_kinds_need_no_emulator_model_and_include_dyna() -> None:
    assert not any(plant_ns.is_emulator_kind(k) for k in plant_ns.DEFAULT_AGENTS)
    assert "dyna-q" in plant_ns.DEFAULT_AGENTS
    assert set(plant_ns.DEFAULT_SCENARIO_KINDS) <= set(plant_ns.DEFAULT_AGENTS)


@pytest.mark.parametrize("text", ["setpoint=0.5", "disturbance=2@15", "setpoint=-1,disturbance=-2@10"])
def test_hardware_scenarios_are_accepted(text: str) -> None:
    assert plant_ns.hardware_scenario(text).id == text


@pytest.mark.parametrize("text,word", [("noise=0.002", "noise"), ("setpoint=0.5,delay=1", "delay"),
                                        ("mass=1.2", "mass"), ("nominal", "always validated")])
def test_scenarios_a_rig_cannot_be_given_are_refused(text: str, word: str) -> None:
    with pytest.raises(ConfigError) as err:
        plant_ns.hardware_scenario(text)
    assert word in str(err.value) and "\n" not in str(err.value)


def test_full_size_duration_counts_the_papers_samples() -> None:
    """12 experiments, 106,000 samples = 1,060 s at 100 Hz, plus a rest and a start-up each."""
    d = plant_ns.expected_seconds(
        samples=12_000, val_samples=4_000, agents=plant_ns.DEFAULT_AGENTS, seeds=3, validation_steps=3000,
        dyna_episodes=2, steps=3000, scenarios=plant_ns.DEFAULT_SCENARIOS,
        scenario_kinds=plant_ns.DEFAULT_SCENARIO_KINDS)
    overhead = plant_ns.REST_ESTIMATE_S + plant_ns.STARTUP_ESTIMATE_S
    assert d.record == pytest.approx(1060.0 + 12 * overhead)
    episode = 30.0 + plant_ns.REST_ESTIMATE_S
    assert d.validation == pytest.approx(len(plant_ns.DEFAULT_AGENTS) * 3 * episode)
    assert d.scenarios == pytest.approx(2 * 2 * 3 * episode)
    assert d.dyna == pytest.approx(3 * 2 * episode)
    assert 40 * 60 < d.total < 60 * 60  # about an hour with identification and training on top
    assert f"about {d.total / 60:.0f} min" in d.line()


def test_a_run_without_bias_kinds_records_only_the_broad_pair() -> None:
    d = plant_ns.expected_seconds(samples=1000, val_samples=500, agents=("glm+improved",), seeds=1,
                                  validation_steps=100, dyna_episodes=1, steps=100, scenarios=(),
                                  scenario_kinds=())
    assert d.record == pytest.approx(15.0 + 2 * (plant_ns.REST_ESTIMATE_S + plant_ns.STARTUP_ESTIMATE_S))
    assert d.dyna == 0.0 and d.scenarios == 0.0


def _config(argv: list[str]):  # type: ignore[no-untyped-def]
    return bench_main.config(bench_main.parse(argv))


def test_plant_ns_config_is_real_time_without_plant_kinds(tmp_path) -> None:  # type: ignore[no-untyped-def]
    cfg = _config(["--plant-ns", "/rig", "--out", str(tmp_path), "--agents", "plm,plant,dyna-q"])
    assert cfg.realtime and cfg.plant_ns == "/rig" and cfg.namespace == "/rig"
    assert cfg.run.agents == ("plm", "dyna-q") and cfg.left_out == ("plant",)
    assert cfg.node_scenarios == plant_ns.DEFAULT_SCENARIOS
    assert cfg.scenario_kinds == ()  # neither default scenario kind runs here


def test_plant_ns_defaults_are_paper_sized(tmp_path) -> None:  # type: ignore[no-untyped-def]
    cfg = _config(["--plant-ns", "/rig", "--out", str(tmp_path)])
    assert cfg.run.agents == plant_ns.DEFAULT_AGENTS
    assert (cfg.run.samples, cfg.run.val_samples, cfg.run.validation_steps) == (12_000, 4_000, 3000)
    assert cfg.run.dyna_episodes == plant_ns.DEFAULTS["dyna_episodes"] and len(cfg.seeds) == 3
    assert cfg.scenario_kinds == plant_ns.DEFAULT_SCENARIO_KINDS


def test_quick_look_parses() -> None:
    cfg = _config(["--plant-ns", "/rig", *plant_ns.QUICK_LOOK])
    assert cfg.node_scenarios == ("setpoint=0.5",) and cfg.scenario_kinds == ("greybox+robust",)


@pytest.mark.parametrize("argv,needle", [
    (["--plant-ns", "/rig", "--via-ros"], "--via-ros"),
    (["--plant-ns", "rig"], "absolute namespace"),
    (["--node-scenarios", "setpoint=0.5"], "need --plant-ns"),
    (["--plant-ns", "/rig", "--node-scenarios", "noise=0.01"], "noise"),
    (["--plant-ns", "/rig", "--scenario-kinds", "glm"], "not among"),
    (["--plant-ns", "/rig", "--validation-steps", "1000"], "after the 10 s validation episode ends"),
])
def test_plant_ns_mistakes_are_one_line(argv: list[str], needle: str, tmp_path,  # type: ignore[no-untyped-def]
                                        capsys: pytest.CaptureFixture[str]) -> None:
    assert bench_main.main([*argv, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_a_default_scenario_no_kind_validates_under_does_not_refuse_a_short_episode(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """``--agents plm`` validates no kind under the default ``disturbance=2@15``: 5 s episodes are fine."""
    cfg = _config(["--plant-ns", "/rig", "--agents", "plm", "--validation-steps", "500",
                   "--out", str(tmp_path)])
    assert cfg.scenario_kinds == () and cfg.run.validation_steps == 500
    with pytest.raises(ConfigError, match="after the 5 s validation episode ends"):
        _config(["--plant-ns", "/rig", "--agents", "plm,plm+robust", "--validation-steps", "500"])


def test_plant_ns_keeps_the_callers_domain_and_discovery(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROS_DOMAIN_ID", "77")
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "SUBNET")
    assert bench_main.use_domain(bench_main.parse(["--plant-ns", "/rig"])) is None
    assert os.environ["ROS_DOMAIN_ID"] == "77" and os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SUBNET"


def _unheld(domain: int) -> bool:
    """Whether no run holds ``domain`` now (a lock *file* may outlive its run: only the flock counts)."""
    fh = domains._try_lock(domain)
    if fh is None:
        return False
    fh.close()
    return True


def test_an_explicit_domain_id_still_wins(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROS_DOMAIN_ID", "77")
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "SUBNET")
    free = next(d for d in range(201, 233) if _unheld(d))
    lock = bench_main.use_domain(bench_main.parse(["--plant-ns", "/rig", "--domain-id", str(free)]))
    try:
        assert lock is not None and os.environ["ROS_DOMAIN_ID"] == str(free)
        assert os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SUBNET"  # the caller's range stays
    finally:
        assert lock is not None
        lock.close()


def _squash(text: str) -> str:
    return " ".join(text.replace("\\\n", " ").split())


def test_readme_and_docs_give_the_tested_quick_look_and_the_computed_durations() -> None:
    """The short configuration docs/own-bags.md gives is the one the e2e test runs, and the minutes they
    state are what :func:`expected_seconds` computes from the sample counts (no hand-typed timing)."""
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    readme, page = (repo / "docs" / "own-bags.md").read_text(), (repo / "docs" / "plant-ns.md").read_text()
    quick = "python launch_scripts/bench.py --plant-ns /rig " + " ".join(plant_ns.QUICK_LOOK)
    assert quick in _squash(readme) and quick in _squash(page)
    full = bench_main.expected_duration(_config(["--plant-ns", "/rig"])).total / 60
    short = bench_main.expected_duration(_config(["--plant-ns", "/rig", *plant_ns.QUICK_LOOK])).total / 60
    assert f"about {full:.0f} minutes" in _squash(readme) and f"about {full:.0f} min**" in page
    assert f"about {short:.0f} minutes" in _squash(readme) and f"about {short:.0f} minutes" in _squash(page)
