"""The rig description: the shipped default is the emulator's plant; every bad key is one line."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import DT, PlantParams
from msd_bench.core.rigs.description import (
    RigDescription,
    decision_samples,
    default_description,
    parse_description,
)
from msd_bench.io.rigs.rig_file import read_rig

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_FILE = ROOT / "config" / "rigs" / "default.yaml"
FAST = {"rate": 1000.0, "stroke": 0.25, "force_limit": 350.0}


def test_shipped_default_file_is_exactly_the_default_plant() -> None:
    rig = read_rig(DEFAULT_FILE)
    assert rig == default_description()
    assert rig.dt == DT and rig.stroke == PlantParams().L and rig.force_limit == PlantParams().F
    assert rig.samples_per_decision == 1
    scales = rig.scales()
    assert (scales.length, scales.force, scales.time) == (1.0, 1.0, 1.0)


def test_fast_rig_holds_its_command_over_whole_samples() -> None:
    rig = parse_description(FAST)
    assert rig.samples_per_decision == 10
    assert (rig.position_min, rig.position_max) == (-0.125, 0.125)
    assert parse_description({**FAST, "decision_period": 0.002}).samples_per_decision == 2


def test_position_limits_and_known_facts_are_read() -> None:
    rig = parse_description({"rate": 610.35, "position_min": -0.3, "position_max": 0.2,
                             "force_limit": 1.0, "position_unit": "V", "force_unit": "V",
                             "interface": "ros2_control", "joint": "stage",
                             "controller_joints": ["stage"], "actuator_delay": 2 / 610.35,
                             "lag": 0.01, "decision_period": 1 / 610.35})
    assert rig.stroke == pytest.approx(0.5) and rig.actuator_delay_samples == 2
    assert (rig.interface, rig.joint, rig.controller_joints, rig.lag) == (
        "ros2_control", "stage", ("stage",), 0.01)


@pytest.mark.parametrize(("params", "named"), [
    ({"stroke": 5.0, "force_limit": 10.0}, "rate in rig.yaml is missing"),
    ({**FAST, "rate": 0.0}, "rate in rig.yaml must be > 0"),
    ({**FAST, "rate": -5}, "rate in rig.yaml must be > 0"),
    ({**FAST, "stroke": 0}, "stroke in rig.yaml must be > 0"),
    ({"rate": 100.0, "force_limit": 10.0}, "stroke in rig.yaml is missing"),
    ({**FAST, "force_limit": "big"}, "force_limit in rig.yaml must be a finite number"),
    ({**FAST, "force_limit": float("nan")}, "force_limit in rig.yaml must be a finite number"),
    ({"rate": 100.0, "force_limit": 1.0, "position_min": 1.0, "position_max": -1.0},
     "position_min in rig.yaml (1) must be below position_max (-1)"),
    ({"rate": 100.0, "force_limit": 1.0, "position_min": 1.0}, "position_max in rig.yaml is missing"),
    ({**FAST, "position_min": -1.0, "position_max": 1.0}, "give either stroke or position_min"),
    ({**FAST, "strok": 5.0}, "unknown rig key 'strok' in rig.yaml; did you mean stroke?"),
    ({**FAST, "interface": "ethercat"}, "interface in rig.yaml must be one of msd, ros2_control"),
    ({**FAST, "decision_period": 0.0015}, "decision_period in rig.yaml: 0.0015 s is not a whole"),
    ({**FAST, "decision_period": 0.0001}, "decision_period in rig.yaml: 0.0001 s is not a whole"),
    ({**FAST, "actuator_delay_samples": 1.5}, "actuator_delay_samples in rig.yaml must be a whole"),
    ({**FAST, "actuator_delay_samples": 1, "actuator_delay": 0.001}, "in samples or in seconds"),
    ({**FAST, "position_unit": " "}, "position_unit in rig.yaml must not be empty"),
    ({**FAST, "controller_joints": "a,b"}, "controller_joints in rig.yaml must be a list"),
    ({**FAST, "hold_damping": 10.0}, "hold_damping in rig.yaml belongs to a hold loop: give hold_stiffness"),
    ({**FAST, "hold_position": 0.0}, "hold_position in rig.yaml belongs to a hold loop"),
    ({**FAST, "hold_stiffness": 0.0}, "hold_stiffness in rig.yaml must be > 0"),
    ({**FAST, "hold_stiffness": 100.0, "hold_damping": -1.0}, "hold_damping in rig.yaml must be >= 0"),
    ({**FAST, "hold_stiffness": 100.0, "hold_position": 0.2}, "hold_position in rig.yaml (0.2) must be"),
])
def test_bad_key_is_one_line_naming_key_and_file(params: dict[str, object], named: str) -> None:
    with pytest.raises(ConfigError) as caught:
        parse_description(params, "rig.yaml")
    message = str(caught.value)
    assert named in message and "\n" not in message


def test_a_stated_hold_loop_is_read_and_stated_in_the_facts() -> None:
    """A stage's description states the loop its drive holds it under; a bare rig's facts are unchanged."""
    from msd_bench.core.rigs.hold import HoldLoop

    assert parse_description(FAST).hold() is None and "hold_loop" not in parse_description(FAST).facts()
    rig = parse_description({**FAST, "hold_stiffness": 3500.0, "hold_damping": 120.0, "hold_position": 0.01})
    assert rig.hold() == HoldLoop(3500.0, 120.0, 0.01)
    assert rig.facts()["hold_loop"] == {"stiffness": 3500.0, "damping": 120.0, "position": 0.01}
    assert parse_description({**FAST, "hold_stiffness": 3500.0}).hold() == HoldLoop(3500.0, 0.0, 0.0)


def test_model_at_another_rate_is_refused_in_one_line() -> None:
    rig = parse_description(FAST)
    fast = plant_model(replace(PlantParams(), dt=0.001))
    rig.check_model(fast, "rig.yaml")
    with pytest.raises(InvalidInputError) as caught:
        rig.check_model(plant_model(PlantParams()), "rig.yaml")
    message = str(caught.value)
    assert "identified at dt 0.01 s (100 Hz) but the rig of rig.yaml runs at dt 0.001 s" in message
    assert "\n" not in message


def test_decision_samples_counts_whole_samples_only() -> None:
    assert decision_samples(0.01, 100.0, "p", "") == 1
    assert decision_samples(0.02, 250.0, "p", "") == 5
    with pytest.raises(ConfigError, match=r"2\.5 samples"):
        decision_samples(0.01, 250.0, "decision_period", "")


@pytest.mark.parametrize(("text", "named"), [
    ("rate: 100\n", "expected '/**: ros__parameters:'"),
    ("/**:\n  params: {}\n", "has no 'ros__parameters' mapping"),
    ("/a:\n  ros__parameters: {}\n/b:\n  ros__parameters: {}\n", "several node sections"),
    ("/**: [unclosed\n", "not valid YAML"),
    ("/**:\n  ros__parameters:\n    rate: 100.0\n    stroke: 5.0\n", "force_limit in"),
    ("", "expected '/**: ros__parameters:'"),
])
def test_bad_file_is_one_line_naming_the_file(tmp_path: Path, text: str, named: str) -> None:
    path = tmp_path / "rig.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as caught:
        read_rig(path)
    message = str(caught.value)
    assert named in message and str(path) in message and "\n" not in message


def test_missing_file_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot read it"):
        read_rig(tmp_path / "absent.yaml")


def test_single_node_section_is_accepted(tmp_path: Path) -> None:
    path = tmp_path / "rig.yaml"
    path.write_text("/plant:\n  ros__parameters:\n    rate: 1000.0\n    stroke: 0.25\n"
                    "    force_limit: 350.0\n")
    assert read_rig(path) == RigDescription(rate=1000.0, position_min=-0.125, position_max=0.125,
                                            force_limit=350.0)


def test_measured_parameters_are_what_was_seen_or_one_line() -> None:
    from msd_bench.core.rigs.description import measured_parameters

    stamps = [k * 1_000_000 for k in range(50)]  # 1 kHz
    efforts = [0.0, 300.0, 349.9, 350.1, 350.0, 350.0, 350.0]  # the last five settled at the limit
    got = measured_parameters(stamps, [0.0, 0.01, -0.03, 0.02], efforts)
    assert got == {"rate": 1000.0, "stroke": 0.06, "force_limit": 350.0}
    parse_description(got)  # a description as it stands
    for args, key in (((stamps[:2], [0.1], [10.0]), "rate"), ((stamps, [0.0, 0.0], [10.0]), "stroke"),
                      ((stamps, [0.1], []), "force_limit")):
        with pytest.raises(ConfigError, match=f"^{key}: ") as err:
            measured_parameters(*args)
        assert "\n" not in str(err.value)
