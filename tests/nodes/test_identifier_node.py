"""The identifier: from bags (ours or a rig's) to the same models the in-process pipeline fits."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest

from msd_bench.app.bag_identification import IdentifierConfig, identify_from_bags
from msd_bench.app.pipeline import identify_surrogates
from msd_bench.core.errors import ConfigError
from msd_bench.core.identification.excitation import MultilevelConfig, PrbsConfig, multilevel, prbs
from msd_bench.core.identification.plm import PLM_BIASES
from msd_bench.core.identification.records import Records
from msd_bench.core.physics.plant import PlantParams, simulate
from msd_bench.io.bags.reader import BagError, write_experiment
from msd_bench.io.storage import artifacts
from msd_bench.nodes.identifier_node import IdentifierNode
from tests.nodes.conftest import spin_until

P = PlantParams()
N, NV, SETTLE = 3000, 1000, 300


def _bag(path: Path, u: np.ndarray, params: dict) -> tuple[np.ndarray, np.ndarray]:
    x, v, ua = simulate(u, P)
    write_experiment(path, np.arange(u.size) * 10_000_000, ua, x, v, params=params)
    return ua, x


@pytest.fixture(scope="module")
def bag_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("excitation")
    for i, b in enumerate(PLM_BIASES):
        cfg = PrbsConfig(bias=b, n_samples=N, settle=SETTLE)
        _bag(d / f"bias_{i}", prbs(cfg, 10 + i),
             {"role": "train", "signal": "prbs", "bias": b, "prbs": asdict(cfg)})
    _bag(d / "broad", multilevel(MultilevelConfig(n_samples=N), 3),
         {"role": "train", "signal": "multilevel", "bias": None})
    _bag(d / "val_broad", multilevel(MultilevelConfig(n_samples=NV), 4),
         {"role": "validation", "signal": "multilevel", "bias": None})
    return d


def _in_process_reference(bag_dir: Path) -> Records:
    from msd_bench.core.identification.data import IOData
    from msd_bench.io.bags.reader import read_experiment

    def load(name: str, settle: int = 0) -> IOData:
        e, _ = read_experiment(bag_dir / name)
        return IOData.single(e.u[settle:], e.y[settle:])

    bias = {b: load(f"bias_{i}", SETTLE) for i, b in enumerate(PLM_BIASES)}
    return Records(bias, {}, load("broad"), load("val_broad"))


def test_models_from_our_bags_equal_the_in_process_fit(bag_dir, tmp_path):
    cfg = IdentifierConfig(bags_dir=str(bag_dir), models=("glm", "plm"), out_dir=str(tmp_path))
    heard: list[tuple[str, bool, bool]] = []  # (model, its file is there, fits.json is there) when heard

    def saved(name, path):
        heard.append((name, path == tmp_path / f"{name}.json" and path.is_file(),
                      (tmp_path / "fits.json").exists()))

    report = identify_from_bags(cfg, on_saved=saved)
    assert heard == [("glm", True, False), ("plm", True, False)]  # each model as soon as it is fitted
    models, fits = identify_surrogates(_in_process_reference(bag_dir), ["glm", "plm"], 0, P)
    for name in ("glm", "plm"):
        saved = artifacts.load_model(tmp_path / f"{name}.json")
        assert np.array_equal(saved.params, models[name].params)
        assert report[name]["sim_fit"] == fits[name].sim_fit
    doc = json.loads((tmp_path / "plm.json").read_text())
    hashes = {s["path"]: s["sha256"] for s in doc["provenance"]["sources"]}
    assert hashes[str(bag_dir / "broad")] == artifacts.sha256_path(bag_dir / "broad")
    assert doc["info"]["n_samples"] == 5 * N


def test_rig_bags_described_by_parameters(bag_dir, tmp_path):
    cfg = IdentifierConfig(broad_bag=str(bag_dir / "broad"), validation_bag=str(bag_dir / "val_broad"),
                           models=("glm",), out_dir=str(tmp_path))
    assert set(identify_from_bags(cfg)) == {"glm"}
    bad = IdentifierConfig(broad_bag=str(bag_dir / "broad"), validation_bag=str(bag_dir / "val_broad"),
                           models=("plm",), bias_bags=("ten=/x",), out_dir=str(tmp_path / "b"))
    with pytest.raises(BagError, match="BIAS=PATH"):
        identify_from_bags(bad)


def test_missing_bias_bag_names_what_is_missing(bag_dir, tmp_path):
    cfg = IdentifierConfig(broad_bag=str(bag_dir / "broad"), validation_bag=str(bag_dir / "val_broad"),
                           bias_bags=(f"-10={bag_dir / 'bias_0'}",), models=("plm",), out_dir=str(tmp_path))
    with pytest.raises(BagError, match=r"missing \[-5.0, 0.0, 5.0, 10.0\]"):
        identify_from_bags(cfg)


def test_config_errors_are_one_line(tmp_path):
    with pytest.raises(ConfigError, match="out_dir is required"):
        IdentifierConfig(bags_dir="x")
    with pytest.raises(ConfigError, match="give bags_dir"):
        IdentifierConfig(out_dir=str(tmp_path))
    with pytest.raises(ConfigError, match=r"unknown model kind .arx.; choose from glm, plm"):
        IdentifierConfig(bags_dir="x", out_dir=str(tmp_path), models=("arx",))


@pytest.mark.ros
def test_node_runs_once_and_finishes(ctx, executor, bag_dir, tmp_path):
    cfg = IdentifierConfig(bags_dir=str(bag_dir), models=("glm",), out_dir=str(tmp_path))
    node = IdentifierNode(cfg, context=ctx)
    executor.add_node(node)
    assert spin_until(executor, node.done.done, timeout=60.0)
    assert node.done.result() == 0 and (tmp_path / "fits.json").is_file()


@pytest.mark.ros
def test_node_from_a_job_file_announces_its_models_as_events(ctx, executor, bag_dir, tmp_path, capfd):
    """``-p job:=<file>`` (as bench.py hands it): the node fits what the file says and reports each
    model, and the end, as structured events on stdout."""
    from rclpy.parameter import Parameter

    from msd_bench.app.config import RunConfig
    from msd_bench.app.job import job_document
    from msd_bench.app.serve_protocol import parse_event

    place = {"bags_dir": str(bag_dir), "out_dir": str(tmp_path / "models")}
    doc = job_document("identifier", RunConfig(agents=("glm",)), place, seed=3)
    job = tmp_path / "identifier.json"
    job.write_text(json.dumps(doc))
    node = IdentifierNode(context=ctx, parameter_overrides=[Parameter("job", value=str(job))])
    assert (node.config.models, node.config.seed) == (("glm",), 3)
    executor.add_node(node)
    assert spin_until(executor, node.done.done, timeout=60.0) and node.done.result() == 0
    events = [e for e in (parse_event(ln, "identifier") for ln in capfd.readouterr().out.splitlines()) if e]
    assert [e["event"] for e in events] == ["model_saved", "identified"]
    assert events[0]["model"] == "glm" and Path(events[0]["path"]) == tmp_path / "models" / "glm.json"


def test_a_kind_that_fails_leaves_the_others_written_and_named(bag_dir, tmp_path, monkeypatch):
    """Issue 32: the kinds before and after a failing one are fitted and written, fits.json names the
    failure, and only then does the identifier fail (its exit status says so)."""
    from dataclasses import replace

    from msd_bench.core.errors import IdentificationError
    from msd_bench.core.identification.model_kinds import MODEL_KINDS

    def boom(req):
        raise IdentificationError("model produced a non-finite position")

    monkeypatch.setitem(MODEL_KINDS, "greybox", replace(MODEL_KINDS["greybox"], fit=boom))
    failed: list[str] = []
    cfg = IdentifierConfig(bags_dir=str(bag_dir), models=("glm", "greybox", "plm"), out_dir=str(tmp_path))
    with pytest.raises(IdentificationError, match=r"^fitting greybox on .*model produced a non-finite "
                                                  r"position \(the other kinds are written under"):
        identify_from_bags(cfg, on_failed=lambda name, why: failed.append(name))
    assert failed == ["greybox"]
    fits = json.loads((tmp_path / "fits.json").read_text())
    assert sorted(fits) == ["failed", "glm", "plm"]
    assert fits["failed"] == {"greybox": "model produced a non-finite position"}
    assert (tmp_path / "glm.json").is_file() and (tmp_path / "plm.json").is_file()
    assert (tmp_path / "inputs.json").is_file()


def test_dt_omitted_is_the_bags_median_stamp_interval(tmp_path, capsys):
    """Issue 32: a rig's bags at 610.35 Hz (1.6384 ms) identified without dt, by the console command
    with the node's roles: the model steps, and its file says it steps, at the bags' rate."""
    from msd_bench.cli import main

    ts_ns = 1_638_400
    for name, seed in (("broad", 3), ("val", 4)):
        u = multilevel(MultilevelConfig(n_samples=N if name == "broad" else NV), seed)
        x, v, ua = simulate(u, P)
        write_experiment(tmp_path / name, np.arange(u.size) * ts_ns, ua, x, v, params={})
    out = tmp_path / "models"
    bags = ["--broad-bag", str(tmp_path / "broad"), "--validation-bag", str(tmp_path / "val")]
    assert main(["identify", *bags, "--models", "glm", "--out", str(out)]) == 0
    assert json.loads((out / "glm.json").read_text())["dt"] == ts_ns / 1e9
    assert artifacts.load_model(out / "glm.json").dt == ts_ns / 1e9
    assert "glm: written to" in capsys.readouterr().out
    assert main(["identify", *bags, "--models", "glm", "--dt", "0.01", "--out", str(tmp_path / "m2")]) == 2
    assert "recorded at 610.4 Hz, expected 100 Hz" in capsys.readouterr().err  # a given dt is checked
