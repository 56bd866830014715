"""The run report's page (io/reports/html_report.py): escaped, self-contained, generic over Table 1's
columns."""

from __future__ import annotations

import json
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import pytest

from msd_bench.io.reports.html_report import INDEX, ReportError, render, write_index
from msd_bench.io.storage.paths import OutputError

EVIL = "<script>alert(1)</script>"
PNG = b"\x89PNG\r\n\x1a\n" + b"\0" * 32
"""The signature is what the page checks; the browser tier decodes real figures."""


def _agent(**extra: Any) -> dict[str, Any]:
    return {"kind": "glm", "label": "GLM (paper agent)", "n": 4, "n_success": 3, "ci95": [0.3, 0.95],
            "summary": {"sse": {"n": 4, "mean": 1.5, "sd": 0.5, "median": 1.2}},
            "per_seed": [{"seed": 0, "id_seed": 0}, {"seed": 1, "id_seed": 0}], **extra}


def _run(tmp_path: Path, agents: list[dict[str, Any]] | None = None, scenarios: list[str] | None = None,
         run: dict[str, Any] | None = None) -> Path:
    """A report directory with table1.json, robustness.json, two figures, run.json and one model."""
    agents = agents if agents is not None else [_agent()]
    scenarios = scenarios or ["nominal", "noise=0.005"]
    (tmp_path / "figures").mkdir(parents=True, exist_ok=True)
    (tmp_path / "table1.json").write_text(json.dumps(
        {"schema": "msd-bench/table1", "schema_version": 1, "run": run or {"preset": "default"},
         "agents": agents}))
    cells = {s: {"n": 4, "n_success": i * 2, "median_sse": 3.0} for i, s in enumerate(scenarios)}
    (tmp_path / "robustness.json").write_text(json.dumps(
        {"schema": "msd-bench/robustness", "schema_version": 2, "scenarios": scenarios,
         "agents": [{"kind": a["kind"], "label": a["label"], "cells": cells} for a in agents]}))
    (tmp_path / "figures" / "fit_glm.png").write_bytes(PNG)
    (tmp_path / "efficiency.png").write_bytes(PNG)
    (tmp_path / "models").mkdir(exist_ok=True)
    (tmp_path / "models" / "glm.json").write_text(json.dumps(
        {"provenance": {"sources": [{"path": f"bags/{EVIL}", "sha256": "ab" * 32}], "seed": 0}}))
    return tmp_path


class _Tags(HTMLParser):
    """Every start tag with its attributes, and the text."""

    def __init__(self) -> None:
        super().__init__()
        self.tags: list[tuple[str, dict[str, str | None]]] = []
        self.text: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append((tag, dict(attrs)))

    def handle_data(self, data: str) -> None:
        self.text.append(data)


def _parse(page: str) -> _Tags:
    p = _Tags()
    p.feed(page)
    return p


def test_text_from_run_files_stays_text(tmp_path: Path) -> None:
    """A kind label, a scenario id, a bag name and a run fact holding markup are shown, never parsed."""
    root = _run(tmp_path, [_agent(label=EVIL, kind=EVIL)], scenarios=["nominal", EVIL],
                run={"note": EVIL, f"key{EVIL}": 1})
    page = write_index(root, root=root, title=EVIL).read_text()
    assert "<script" not in page.lower()
    parsed = _parse(page)
    assert all(tag != "script" for tag, _ in parsed.tags)
    text = "".join(parsed.text)
    assert text.count(EVIL) >= 6  # title twice, label in both tables, kind, scenario, bag, run facts


def test_the_page_is_self_contained(tmp_path: Path) -> None:
    """No src or href leaves the page: figures are data: URIs, and a policy forbids any other load."""
    root = _run(tmp_path, run={"url": "https://example.com/x.png", "preset": "default"})
    parsed = _parse(write_index(root, root=root, title="t").read_text())
    links = [v for _, attrs in parsed.tags for k, v in attrs.items()
             if k in ("src", "href") and v is not None]
    assert links and all(v.startswith("data:image/png;base64,") for v in links)
    csp = [a["content"] for t, a in parsed.tags
           if t == "meta" and a.get("http-equiv") == "Content-Security-Policy"]
    assert csp and "default-src 'none'" in (csp[0] or "")


def test_every_column_of_table1_is_rendered(tmp_path: Path) -> None:
    """A column another command adds (a risk number, a nested risk object) shows up unchanged."""
    root = _run(tmp_path, [_agent(risk_cvar_percent=12.5, risk={"violations": 2, "worst_sse": 40.0}),
                           _agent(kind="lqr", label="GLM + LQR (baseline)")])
    heads = [t for t in _parse(render(root, "t", root).split("<h2>Robustness")[0]).text]
    for column in ("risk_cvar_percent", "risk · violations", "risk · worst_sse", "summary · sse", "ci95"):
        assert column in heads
    assert "GLM + LQR (baseline)" in heads
    assert "per_seed" not in heads


def test_the_heat_map_colours_cells_by_success_share(tmp_path: Path) -> None:
    root = _run(tmp_path, scenarios=["nominal", "delay=1", "load=2"])  # shares 0, 1/2, 1
    heat = render(root, "t", root).split("<table class=\"heat\">")[1].split("</table>")[0]
    assert [f"hsl({h},70%,78%)" in heat for h in (0, 60, 120)] == [True, True, True]
    assert heat.count("<td") == 3


def test_provenance_names_bags_seeds_and_files(tmp_path: Path) -> None:
    root = _run(tmp_path)
    (root / "tasks").mkdir()
    (root / "tasks" / "table1.json").write_text(json.dumps(
        {"task": "table1", "files": [{"path": "table1.json", "bytes": 10, "sha256": "cd" * 32}]}))
    text = "".join(_parse(render(root, "t", root)).text)
    assert "ab" * 32 in text and "cd" * 32 in text
    assert "learning seeds" in text and "0, 1" in text


def test_figures_are_embedded_and_a_symlink_is_not(tmp_path: Path) -> None:
    """A received run's figure that links elsewhere is left out: its target must not travel in the page."""
    root = _run(tmp_path)
    outside = tmp_path.parent / "secret.png"
    outside.write_bytes(PNG + b"secret")
    (root / "figures" / "linked.png").symlink_to(outside)
    (root / "figures" / "fake.png").write_text("not a png")
    page = render(root, "t", root)
    imgs = [a for t, a in _parse(page).tags if t == "img"]
    assert sorted(a["alt"] or "" for a in imgs) == ["efficiency.png", "figures/fit_glm.png"]
    assert "figures/fake.png: not embedded" in page and "linked.png" not in page


@pytest.mark.parametrize(("name", "content", "says"), [
    ("table1.json", "{not json", "not valid JSON"),
    ("table1.json", json.dumps({"schema": "msd-bench/table1", "agents": {"a": 1}}), "'agents' is not a list"),
    ("table1.json", json.dumps({"schema": "other/thing", "agents": []}), "schema 'other/thing'"),
    ("robustness.json", json.dumps({"schema": "msd-bench/robustness", "scenarios": 3, "agents": []}),
     "'scenarios'"),
    ("run.json", "[1, 2]", "not a JSON object"),
])
def test_a_bad_run_file_is_one_line_naming_it(tmp_path: Path, name: str, content: str, says: str) -> None:
    root = _run(tmp_path)
    (root / name).write_text(content)
    with pytest.raises(ReportError) as err:
        write_index(root, root=root, title="t")
    assert name in str(err.value) and says in str(err.value) and "\n" not in str(err.value)
    assert not (root / INDEX).exists()


def test_a_symlinked_index_is_refused_not_written_through(tmp_path: Path) -> None:
    root = _run(tmp_path / "run")
    target = tmp_path / "elsewhere.html"
    target.write_text("theirs")
    (root / INDEX).symlink_to(target)
    with pytest.raises(OutputError):
        write_index(root, root=root, title="t")
    assert target.read_text() == "theirs"


def test_a_bench_config_dataclass_is_shown_when_no_run_json_exists(tmp_path: Path) -> None:
    from dataclasses import dataclass

    @dataclass(frozen=True)
    class Cfg:
        run_dir: Path
        seeds: tuple[int, ...]

    root = _run(tmp_path / "run")
    text = "".join(_parse(render(root, "t", root, Cfg(root, (0, 1, 2)))).text)
    assert "configuration" in text and str(root) in text


def test_efficiency_and_rigs_documents_get_their_tables(tmp_path: Path) -> None:
    points = [{"real_samples": 30000, "n": 4, "n_success": 1},
              {"real_samples": 90000, "n": 4, "n_success": 3}]
    (tmp_path / "efficiency.json").write_text(json.dumps({"schema": "msd-bench/efficiency", "methods": [
        {"name": "plant", "label": "Q-learning on the plant", "points": points}]}))
    kinds = [{"kind": "glm", "label": "GLM (paper agent)", "n": 2, "successes": 1, "wilson95": [0.1, 0.9]}]
    worst = [{"rig": 1000, "successes": 0}]
    (tmp_path / "rigs.json").write_text(json.dumps({"schema": "msd-bench/rigs", "rig_set": "held-out",
                                                    "kinds": kinds, "worst": worst}))
    text = "".join(_parse(render(tmp_path, "t", tmp_path)).text)
    assert "30000 samples" in text and "1/4" in text and "3/4" in text
    assert "held-out" in text and "GLM (paper agent)" in text and "1000" in text
