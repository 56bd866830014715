"""``msd-bench rigs --rig FILE`` (issue 37 item 1): the population around a described rig, each rig its
default-family twin carried into the described rig's units (stroke, force limit, sample time).

A description in power-of-two units (0.625 m, 0.625 N, 25 Hz: length x0.125, mass x8, time x4 against
the default plant) makes every conversion exact, so a scale-free method gives each rig its twin's runs
to the last digits (as tests/app/test_scale_free.py shows for a family); the default description
carries nothing (the identity), and a rig deciding less often than it samples is one line.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from msd_bench.app.config import RunConfig
from msd_bench.app.rigs import RigsConfig, rig_task
from msd_bench.cli import build_parser
from msd_bench.cli import main as cli_main
from msd_bench.commands.rigs import rigs_config
from msd_bench.core.rigs.units import RigUnits, units_between

CONFIG = Path(__file__).resolve().parents[2] / "config" / "rigs"
EXACT = RigUnits(length=0.125, mass=8.0, time=4.0)
RUN = RunConfig(agents=("greybox+robust",), seeds=1, episodes=20, samples=1000, val_samples=400,
                validation_steps=600, window=300)
"""A small budget: the equality asserted does not depend on it."""


def _describe(tmp_path: Path, decision_period: float = 0.04) -> Path:
    path = tmp_path / "small.yaml"
    path.write_text("/**:\n  ros__parameters:\n    rate: 25.0\n    stroke: 0.625\n    force_limit: 0.625\n"
                    f"    decision_period: {decision_period}\n")
    return path


def test_the_described_units_are_exact_and_the_default_is_the_identity(tmp_path: Path) -> None:
    assert units_between(0.625, 0.625, 0.04) == EXACT
    assert units_between(5.0, 10.0, 0.01).is_identity
    parse = build_parser().parse_args
    small = rigs_config(parse(["rigs", "--rig", str(_describe(tmp_path)), "--out", str(tmp_path)]))
    assert small.units == EXACT
    units = rigs_config(parse(["rigs", "--rig", str(CONFIG / "default.yaml"), "--out", str(tmp_path)])).units
    assert units is not None and units.is_identity


def test_a_rig_in_the_described_units_gives_its_twins_runs() -> None:
    twin = rig_task(RigsConfig(RUN, rigs=1, scenarios=()), 1000)
    rig = rig_task(RigsConfig(RUN, rigs=1, scenarios=(), units=EXACT), 1000)
    assert rig["parameters"]["time_unit"] == 4.0 and "time_unit" not in twin["parameters"]
    rows = [(o["kind"], o["seed"]) for o in twin["outcomes"]]
    assert [(o["kind"], o["seed"]) for o in rig["outcomes"]] == rows
    for a, b in zip(twin["outcomes"], rig["outcomes"], strict=True):
        assert b["success"] == a["success"] and b["sse"] == pytest.approx(a["sse"], rel=1e-9), a["kind"]


@pytest.mark.parametrize(("make", "message"), [
    (lambda tmp: _describe(tmp, decision_period=0.08), "decision_period is 2 samples; rigs runs every"),
    (lambda tmp: tmp / "missing.yaml", "missing.yaml"),
])
def test_a_rig_it_cannot_run_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                         make: object, message: str) -> None:
    path = make(tmp_path)  # type: ignore[operator]
    assert cli_main(["rigs", "--rig", str(path), "--rigs", "1", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err and not (tmp_path / "x").exists()
