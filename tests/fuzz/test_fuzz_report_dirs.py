"""Fuzz: the run directory the report stage reads (``fits.json``, each ``result.json``, ``run.json``).

Property: whatever the files hold — random bytes, random JSON, the valid
documents truncated or with fields replaced by random JSON, deep nesting —
the report stage's readers (``load_results``, ``on_node_robustness``,
``write_run_facts``; each kind's trained-policy artifact is valid and fixed)
either accept them, and then Table 1 and the robustness
table are written from them without an error, or raise one MsdBenchError line
naming the file; never a traceback from ``json``, a ``KeyError`` or a
``TypeError`` deeper in the report.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from msd_bench.core.errors import MsdBenchError
from msd_bench.graph.bench import BenchConfig, write_run_facts
from msd_bench.graph.bench_report import load_results, on_node_robustness
from msd_bench.graph.main import config, parse
from msd_bench.io.reports.report import write_report, write_robustness
from tests.fuzz.json_values import JSON

AGENTS = ("glm", "plm+improved")
ROW = {"seed": 0, "id_seed": 0, "mae": 0.1, "std": 0.05, "po": 3.0, "ts": None, "ts5": 4.0, "sse": 0.4,
       "success": True}
CELL = {"n": 2, "n_success": 1, "ci95": [0.1, 0.9], "median_sse": 3.0, "median_mae": 0.1, "sse": [1.0, 5.0],
        "mae": [0.1, 0.1]}
RESULT = {"kind": "glm", "training": "in-process", "real_interactions": 0,
          "per_seed": [ROW, {**ROW, "seed": 1}], "on_node_scenarios": {"step-0.5": CELL}}
FIT = {"model": "glm", "sim_fit": 91.0, "one_step_fit": 99.9, "n_identification": 6000, "n_validation": 2000,
       "fit_seconds": 0.4, "sim_fit_raw_start": None, "sim_fit_truth": None, "initial_state": "estimate"}
FITS = {"glm": FIT, "plm": {**FIT, "model": "plm"}}
RUN = {"timings": {"record": 10.0, "identify": 3.5}, "ros_domain_id": 7}
FACTS = {"preset": "default", "seeds": 2, "window": 500}



@pytest.fixture(scope="module")
def run_dir() -> Iterator[Path]:
    """A run directory holding what the fuzzed files sit beside: each kind's model and trained-policy
    artifact (``policy.json``, ``qtables.npz``), which the report loads its rows' policies from."""
    from msd_bench import designs
    from msd_bench.core.physics.model import plant_model
    from msd_bench.core.physics.plant import PlantParams
    from msd_bench.io.storage import artifacts

    path = Path(tempfile.mkdtemp(prefix="fuzz_report_"))
    model = plant_model(PlantParams())
    for name in ("glm", "plm"):
        artifacts.save_model(model, path / "models" / f"{name}.json", artifacts.Provenance(), root=path)
    for kind in AGENTS:
        policy = designs.make(kind, model, designs.Settings(episodes=1, steps=20), [0, 1])
        designs.save(policy, path / "agents" / kind, {}, root=path)
    yield path
    shutil.rmtree(path)


def _cfg(run_dir: Path) -> BenchConfig:
    return config(parse(["--out", str(run_dir), "--stages", "report", "--agents", ",".join(AGENTS)]))


@st.composite
def document(draw: st.DrawFn, valid: Any) -> str | bytes:
    """One file's content: valid, truncated, a field replaced, random JSON, random bytes or deep."""
    text = json.dumps(valid)
    how = draw(st.sampled_from(["valid", "truncated", "field", "field", "nested field", "json", "bytes",
                                "deep"]))
    if how == "valid":
        return text
    if how == "truncated":
        return text[: draw(st.integers(0, len(text) - 1))]
    if how == "json":
        return json.dumps(draw(JSON))
    if how == "bytes":
        return draw(st.binary(max_size=200))
    if how == "deep":
        depth = draw(st.integers(1, 20000))
        return "[" * depth + "]" * depth
    doc = json.loads(text)
    target = doc
    if how == "nested field":  # one level down: a per-seed row, a fit entry, a cell
        inner = [v for v in doc.values() if isinstance(v, dict | list) and v]
        if inner:
            target = draw(st.sampled_from(inner))
            target = target[0] if isinstance(target, list) else target
    if isinstance(target, dict):
        keys = [*target, "unexpected"]
        key = draw(st.sampled_from(keys))
        if draw(st.booleans()) and key in target:
            del target[key]
        else:
            target[key] = draw(JSON)
    return json.dumps(doc)


def _write(path: Path, content: str | bytes | None) -> None:
    if content is None:
        path.unlink(missing_ok=True)
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)


def _report(cfg: BenchConfig) -> str:
    """The report stage's reads and the tables written from them; "ok" or "refused" (one line)."""
    try:
        results = load_results(cfg)
        write_report(cfg.run_dir / "report", results, FACTS)
        rob = on_node_robustness(cfg, results)
        write_robustness(cfg.run_dir / "report", rob, {r.kind: r.label for r in results})
        write_run_facts(cfg, {"ros_domain_id": 7})
        return "ok"
    except MsdBenchError as exc:
        assert "\n" not in str(exc) and str(cfg.run_dir) in str(exc), str(exc)
        return "refused"


@given(fits=st.one_of(st.none(), document(FITS)), glm=st.one_of(st.none(), document(RESULT)),
       plm=st.one_of(st.none(), document({**RESULT, "kind": "plm+improved"})), run=document(RUN))
def test_a_run_directory_is_reported_or_refused_in_one_line(run_dir: Path, fits: Any, glm: Any, plm: Any,
                                                            run: Any) -> None:
    _write(run_dir / "models" / "fits.json", fits)
    _write(run_dir / "agents" / "glm" / "result.json", glm)
    _write(run_dir / "agents" / "plm+improved" / "result.json", plm)
    _write(run_dir / "run.json", run)
    _report(_cfg(run_dir))


def test_the_valid_run_directory_is_reported(run_dir: Path) -> None:
    _write(run_dir / "models" / "fits.json", json.dumps(FITS))
    for kind in AGENTS:
        _write(run_dir / "agents" / kind / "result.json", json.dumps({**RESULT, "kind": kind}))
    _write(run_dir / "run.json", json.dumps(RUN))
    assert _report(_cfg(run_dir)) == "ok"
    assert (run_dir / "report" / "table1.md").is_file() or any((run_dir / "report").iterdir())
