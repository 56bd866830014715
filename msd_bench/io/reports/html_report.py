"""One self-contained ``index.html`` per run: every result of a report directory on one page.

Why: a run's report is Markdown, CSV, JSON and a dozen PNGs in a directory,
and nothing shows them together. The page is built from the files the run
wrote (``table1.json``, ``robustness.json``, ``efficiency.json``,
``rigs.json``, the PNGs, ``run.json`` / ``manifest.json`` and the model
artifacts' provenance), never from the run's memory, so ``bench.py --stages
report`` and a resumed ``paper`` run rebuild the same page.

The page may be opened anywhere and sent to anyone, and the run files may come
from elsewhere. So: figures are embedded as ``data:`` URIs, the page makes no
network request (a Content-Security-Policy forbids any that slipped in), it
holds no script, and every text taken from a run file is HTML-escaped. Table 1
is rendered from the JSON's own keys, so columns other commands add (risk
columns, baseline and deep-RL rows) appear without a change here. Markup lives
in :mod:`msd_bench.io.reports.html_parts`; this module gathers the run's files.
"""

from __future__ import annotations

import base64
import dataclasses
import functools
import os
import stat
import subprocess
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from msd_bench.core.errors import MsdBenchError
from msd_bench.io.reports import html_parts as part
from msd_bench.io.storage.atomic import write_text_atomic
from msd_bench.io.storage.safe_read import read_json_bounded

INDEX = "index.html"
"""The page's file name in the report directory."""

MAX_FIGURE_BYTES = 8 << 20
"""Largest PNG embedded (8 MiB): the run's figures are under 200 KiB; a bigger one is named, not inlined."""

MAX_MODEL_FILES = 256
"""Model artifacts read for provenance: a run writes at most a few dozen."""

_PNG = b"\x89PNG\r\n\x1a\n"


class ReportError(MsdBenchError):
    """A file the run report is built from cannot be read or does not have the expected shape."""


def write_index(report_dir: Path, *, root: Path, title: str, run_dir: Path | None = None,
                config: Any = None) -> Path:
    """Write ``report_dir/index.html`` atomically (no write leaves ``root``) from the run's files.

    ``run_dir`` is where ``run.json``, ``manifest.json``, ``models/`` and
    ``tasks/`` are looked for (default ``report_dir``); ``config`` is the run's
    configuration when no file holds it yet (bench.py writes ``run.json`` after
    its report): a mapping or a dataclass.
    """
    report_dir = Path(report_dir)
    page = render(report_dir, title, report_dir if run_dir is None else Path(run_dir), config)
    return write_text_atomic(report_dir / INDEX, page, root=root)


def render(report_dir: Path, title: str, run_dir: Path, config: Any = None) -> str:
    """The page's HTML from the files under ``report_dir`` and ``run_dir``."""
    sections = [
        _table1(report_dir / "table1.json"),
        _robustness(report_dir / "robustness.json"),
        _efficiency(report_dir / "efficiency.json"),
        _rigs(report_dir / "rigs.json"),
        part.figures([(name, _data_uri(path)) for name, path in figure_files(report_dir)]),
        _configuration(report_dir, run_dir, config),
        _provenance(report_dir, run_dir),
    ]
    return part.page(title, [s for s in sections if s])


def _doc(path: Path, schema: str | None = None) -> dict[str, Any] | None:
    """The JSON object at ``path`` (None when absent); a wrong schema or shape is one line."""
    if not path.is_file():
        return None
    doc = read_json_bounded(path, ReportError)
    if not isinstance(doc, dict):
        raise ReportError(f"{path}: not a JSON object")
    if schema is not None and doc.get("schema", schema) != schema:
        raise ReportError(f"{path}: schema {doc.get('schema')!r}, expected {schema!r}")
    return doc


def _objects(doc: Mapping[str, Any], key: str, path: Path) -> list[dict[str, Any]]:
    """``doc[key]`` as a list of objects, or one line naming the field."""
    items = doc.get(key, [])
    if not isinstance(items, list) or not all(isinstance(i, dict) for i in items):
        raise ReportError(f"{path}: {key!r} is not a list of objects")
    return items


def _table1(path: Path) -> str:
    doc = _doc(path, "msd-bench/table1")
    if doc is None:
        return ""
    return part.section("Table 1", part.object_table(_objects(doc, "agents", path), part.TABLE1_SKIP),
                        f"From {path.name}: one row per agent kind, every column the file has.")


def _robustness(path: Path) -> str:
    doc = _doc(path, "msd-bench/robustness")
    if doc is None:
        return ""
    agents = _objects(doc, "agents", path)
    scenarios = doc.get("scenarios", [])
    if not isinstance(scenarios, list) or not all(isinstance(a.get("cells", {}), dict) for a in agents):
        raise ReportError(f"{path}: 'scenarios' is not a list or an agent's 'cells' is not an object")
    rows = [(str(a.get("label", a.get("kind", "?"))), a.get("cells", {})) for a in agents]
    return part.section("Robustness", part.heat_map([str(s) for s in scenarios], rows),
                        "The trained tables held fixed, validated under each scenario; a cell's colour "
                        "is its success share (red 0 %, green 100 %).")


def _efficiency(path: Path) -> str:
    doc = _doc(path, "msd-bench/efficiency")
    if doc is None:
        return ""
    rows = []
    for method in _objects(doc, "methods", path):
        points = method.get("points", [])
        if not isinstance(points, list) or not all(isinstance(p, dict) for p in points):
            raise ReportError(f"{path}: a method's 'points' is not a list of objects")
        rows.append({"method": method.get("label", method.get("name", "?")),
                     **{f"{p.get('real_samples', '?')} samples": part.share_text(p) for p in points}})
    return part.section("Data efficiency", part.object_table(rows),
                        "Closed-loop successes/n at each number of real-plant samples, per route.")


def _rigs(path: Path) -> str:
    doc = _doc(path, "msd-bench/rigs")
    if doc is None:
        return ""
    return part.section("Rigs", part.object_table(_objects(doc, "kinds", path))
                        + part.object_table(_objects(doc, "worst", path)),
                        f"Per agent kind over the {doc.get('rig_set', '?')} rigs, then the worst rigs.")


def figure_files(report_dir: Path) -> list[tuple[str, Path]]:
    """Every PNG of the report (``*.png`` and ``figures/*.png``), by name relative to it; symlinks skipped
    (a received run's link must not carry a file from outside into a page that is sent on)."""
    found = []
    for folder in (report_dir, report_dir / "figures"):
        if folder.is_dir() and not folder.is_symlink():
            found += [p for p in sorted(folder.glob("*.png")) if not p.is_symlink() and p.is_file()]
    return [(p.relative_to(report_dir).as_posix(), p) for p in found]


def _data_uri(path: Path) -> str | None:
    """The PNG at ``path`` as a ``data:`` URI (None when too big or not a PNG), read without following
    a symlink."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
    except OSError as exc:
        raise ReportError(f"{path}: cannot read ({exc.strerror or exc})") from None
    with os.fdopen(fd, "rb") as fh:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return None
        data = fh.read(MAX_FIGURE_BYTES + 1)
    if len(data) > MAX_FIGURE_BYTES or not data.startswith(_PNG):
        return None
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def _configuration(report_dir: Path, run_dir: Path, config: Any) -> str:
    """What the run was asked to do: its configuration (file or given) and Table 1's run facts."""
    parts = []
    table = _doc(report_dir / "table1.json")
    if table is not None and isinstance(table.get("run"), dict):
        parts.append(part.subsection("Run facts (table1.json)", part.value(table["run"])))
    if dataclasses.is_dataclass(config) and not isinstance(config, type):
        config = dataclasses.asdict(config)
    for name, doc in (("run.json", _doc(run_dir / "run.json")), ("configuration", config)):
        if isinstance(doc, Mapping):
            parts.append(part.subsection(name, part.value(doc)))
            break
    manifest = _doc(run_dir / "manifest.json", "msd-bench/run")
    if manifest is not None:
        parts.append(part.subsection("manifest.json", part.value(
            {k: manifest.get(k) for k in ("command", "config", "config_sha256", "created_utc")})))
    return part.section("Configuration", "".join(parts)) if parts else ""


def _provenance(report_dir: Path, run_dir: Path) -> str:
    """Where the numbers come from: the code's commit, the seeds, the bags and files with their SHA-256."""
    facts: dict[str, Any] = {"msd-bench commit (at report time)": code_commit() or "unknown (not a checkout)"}
    manifest = _doc(run_dir / "manifest.json", "msd-bench/run")
    if manifest is not None:
        facts["msd-bench version"] = manifest.get("msd_bench_version")
    facts.update(_seeds(report_dir / "table1.json"))
    body = part.value(facts)
    bags = _bag_hashes(run_dir / "models")
    if bags:
        body += part.subsection("Bags identified from (SHA-256)", part.object_table(bags))
    files = _task_files(run_dir / "tasks")
    if files:
        body += part.details(f"Files the run recorded ({len(files)}, SHA-256)", part.object_table(files))
    return part.section("Provenance", body)


def _seeds(path: Path) -> dict[str, Any]:
    """The learning and identification seeds Table 1's rows were run with."""
    doc = _doc(path)
    if doc is None:
        return {}
    seeds: set[str] = set()
    id_seeds: set[str] = set()
    for agent in _objects(doc, "agents", path):
        per_seed = agent.get("per_seed", [])
        for s in per_seed if isinstance(per_seed, list) else []:
            if isinstance(s, dict):
                seeds.add(str(s.get("seed")))
                id_seeds.add(str(s.get("id_seed")))
    return {"learning seeds": ", ".join(sorted(seeds, key=_natural)),
            "identification seeds": ", ".join(sorted(id_seeds, key=_natural))}


def _natural(text: str) -> tuple[int, str]:
    return (int(text), "") if text.isdigit() else (1 << 62, text)


def _model_files(models: Path) -> Iterator[Path]:
    """The model artifacts under ``models/`` (a paper run nests them per identification seed)."""
    if not models.is_dir() or models.is_symlink():
        return iter(())
    found = sorted(p for p in models.rglob("*.json") if not p.is_symlink() and p.is_file())
    return iter(found[:MAX_MODEL_FILES])


def _bag_hashes(models: Path) -> list[dict[str, Any]]:
    """Each bag the models were identified from, once, with its SHA-256 (from their provenance)."""
    seen: dict[str, dict[str, Any]] = {}
    for path in _model_files(models):
        doc = _doc(path)
        prov = doc.get("provenance") if doc is not None else None
        sources = prov.get("sources", []) if isinstance(prov, dict) else []
        for src in sources if isinstance(sources, list) else []:
            if isinstance(src, dict) and "path" in src:
                seen.setdefault(str(src["path"]), {"bag": src["path"], "sha256": src.get("sha256"),
                                                   "first model": path.relative_to(models).as_posix()})
    return list(seen.values())


def _task_files(tasks: Path) -> list[dict[str, Any]]:
    """The files each finished task recorded (a run directory's ``tasks/*.json``), with size and hash."""
    if not tasks.is_dir() or tasks.is_symlink():
        return []
    rows: list[dict[str, Any]] = []
    for path in sorted(tasks.glob("*.json")):
        if path.is_symlink():
            continue
        doc = _doc(path) or {}
        for entry in _objects(doc, "files", path):
            rows.append({"task": doc.get("task", path.stem), "file": entry.get("path"),
                         "bytes": entry.get("bytes"), "sha256": entry.get("sha256")})
    return rows


@functools.cache
def code_commit() -> str | None:
    """The checkout's commit (``+dirty`` with uncommitted changes), None outside a git checkout; asked
    once per process (two git calls), since a sweep may write several pages."""
    repo = Path(__file__).resolve().parents[2]
    if not (repo / ".git").exists():
        return None
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=repo, capture_output=True, text=True,
                              timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=repo,
                               capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return head + ("+dirty" if dirty else "")
