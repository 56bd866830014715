"""Fault rows "nothing a user owns is lost": every output option probed first, nothing foreign removed.

Each reproduction of issue 20 runs as a user would (a real process where the
fault is at the command line) and checks the one-line error or the correct
result, and that a sentinel outside the target keeps its content and mtime.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from msd_bench.app.config import RunConfig
from msd_bench.cli import main as cli_main
from msd_bench.commands.bag import main as bag_main
from msd_bench.graph.bench import BenchConfig
from msd_bench.graph.bench_report import load_results
from msd_bench.graph.main import main as bench_main
from msd_bench.io.bags.reader import BagRecorder, write_experiment
from msd_bench.io.reports.report import table_markdown
from msd_bench.io.storage.run_dir import MANIFEST, is_complete

REPO = Path(__file__).resolve().parents[2]
BUDGET = ["--seeds", "1", "--id-seeds", "1", "--episodes", "2", "--steps", "100", "--val-samples", "300",
          "--validation-steps", "100"]
TINY = [*BUDGET, "--samples", "300", "--agents", "glm", "--no-figures"]
"""A paper run of a fraction of a second once imported: enough to write every task."""


def _run(*argv: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, *argv], cwd=cwd, capture_output=True, text=True, timeout=120,
                          env=dict(os.environ))


def _one_line_error(proc: subprocess.CompletedProcess[str], *needles: str) -> str:
    return _check_error(proc.returncode, proc.stderr, *needles)


def _check_error(status: int, stderr: str, *needles: str) -> str:
    """Exit 2 and exactly one ``error:`` line holding ``needles``; no traceback (bench.py's status
    lines before it may stand)."""
    lines = [ln for ln in stderr.strip().splitlines() if ln.strip()]
    errors = [ln for ln in lines if "error:" in ln]
    assert status == 2, stderr[-2000:]
    assert "Traceback" not in stderr and len(errors) == 1 and errors[0] == lines[-1], stderr
    for n in needles:
        assert n in errors[0], errors[0]
    return errors[0]


def _cli(capsys: pytest.CaptureFixture[str], main: Callable[[list[str]], int], *argv: str) -> str:
    """Run an entry point in-process (as its process would, minus the interpreter start); its error."""
    capsys.readouterr()
    status = main(list(argv))
    return _check_error(status, capsys.readouterr().err)


def _in(cwd: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(cwd)


def _state(root: Path) -> dict[str, tuple[str, int]]:
    """Content hash and mtime of every file under ``root``: what "untouched" means."""
    return {p.relative_to(root).as_posix(): (hashlib.sha256(p.read_bytes()).hexdigest(), p.stat().st_mtime_ns)
            for p in sorted(root.rglob("*")) if p.is_file()}


def _sentinel(path: Path, text: str = "my thesis\n") -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    os.utime(path, ns=(1_000_000_000, 1_000_000_000))
    return path


def _bag(path: Path) -> Path:
    n = 200
    return write_experiment(path, np.arange(n) * 10_000_000, np.zeros(n), np.zeros(n), np.zeros(n),
                            params={"seed": 1})


# --- bag recover --output / --overwrite ---------------------------------------------------------

def test_recover_onto_its_own_bag_is_refused(tmp_path: Path) -> None:
    """The issue's reproduction, as a process: before, ``victim/`` was gone and a traceback followed."""
    _bag(tmp_path / "victim")
    before = _state(tmp_path)
    proc = _run("-m", "msd_bench.commands.bag", "bag", "recover", "victim", "--output", "victim",
                "--overwrite", cwd=tmp_path)
    _one_line_error(proc, "output victim is the recording being recovered")
    assert _state(tmp_path) == before


@pytest.mark.parametrize("output", [".", "victim/inside", "victim/victim.mcap"])
def test_recover_never_targets_a_parent_or_the_inside_of_its_bag(tmp_path: Path, output: str,
                                                                  monkeypatch: pytest.MonkeyPatch,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    _bag(tmp_path / "victim")
    _in(tmp_path, monkeypatch)
    before = _state(tmp_path)
    err = _cli(capsys, bag_main, "bag", "recover", "victim", "--output", output, "--overwrite")
    assert f"output {output} " in err
    assert _state(tmp_path) == before


def test_overwrite_refuses_a_bag_directory_holding_a_foreign_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    _bag(tmp_path / "src")
    target = _bag(tmp_path / "target")
    _sentinel(target / "thesis.tex")
    _in(tmp_path, monkeypatch)
    before = _state(tmp_path)
    err = _cli(capsys, bag_main, "bag", "recover", "src", "--output", "target", "--overwrite")
    assert "'thesis.tex'" in err and "not part of the bag" in err
    assert _state(tmp_path) == before


def test_overwrite_replaces_a_bag_of_ours(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _bag(tmp_path / "src")
    outside = _sentinel(tmp_path / "notes.txt")
    _in(tmp_path, monkeypatch)
    argv = ["bag", "recover", "src", "--output", "again"]
    assert bag_main(argv) == 0
    before = _state(tmp_path / "src")
    assert bag_main([*argv, "--overwrite"]) == 0
    assert sorted(p.name for p in (tmp_path / "again").iterdir()) == ["again.mcap", "metadata.yaml"]
    assert _state(tmp_path / "src") == before and outside.read_text() == "my thesis\n"


def test_overwrite_keeps_the_old_bag_when_nothing_can_be_recovered(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    _bag(tmp_path / "src")
    _in(tmp_path, monkeypatch)
    assert bag_main(["bag", "recover", "src", "--output", "out"]) == 0
    BagRecorder(tmp_path / "empty").open().close()
    with (tmp_path / "empty" / "empty.mcap").open("r+b") as fh:
        fh.truncate(80)  # killed before its first chunk
    (tmp_path / "empty" / "metadata.yaml").unlink()
    before = _state(tmp_path / "out")
    err = _cli(capsys, bag_main, "bag", "recover", "empty", "--output", "out", "--overwrite")
    assert "no complete chunk" in err
    assert _state(tmp_path / "out") == before


# --- paper / efficiency --out ---------------------------------------------------------------------

def test_paper_refuses_a_stale_out_before_any_work(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    stale = _sentinel(tmp_path / "out" / "models" / "id0" / "glm.json", '{"stale": true}\n')
    _in(tmp_path, monkeypatch)
    before = _state(tmp_path)
    err = _cli(capsys, cli_main, "paper", *TINY, "--out", "out")
    assert "--out out is not empty" in err and "'models'" in err
    assert _state(tmp_path) == before and stale.read_text() == '{"stale": true}\n'
    assert not list((tmp_path / "out").glob("table1.*"))


def test_efficiency_refuses_a_foreign_out_before_any_work(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    _sentinel(tmp_path / "out" / "thesis.tex")
    _in(tmp_path, monkeypatch)
    before = _state(tmp_path)
    err = _cli(capsys, cli_main, "efficiency", *BUDGET, "--out", "out")
    assert "'thesis.tex'" in err and "not a run of msd-bench efficiency" in err
    assert _state(tmp_path) == before


@pytest.fixture
def read_only_dir(tmp_path: Path) -> Iterator[Path]:
    """An existing, empty, read-only directory: a read-only tmpfs (root ignores mode bits)."""
    where = tmp_path / "ro"
    where.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k,ro", "tmpfs", str(where)],
                      capture_output=True).returncode != 0:
        where.chmod(0o555)  # a user who is not root is refused by the mode bits
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], capture_output=True, check=False)
        where.chmod(0o755)


def test_paper_on_a_read_only_out_is_one_line_before_any_work(read_only_dir: Path) -> None:
    """The issue's reproduction, as a process: before, 17 s of work, then an OSError traceback."""
    proc = _run("-m", "msd_bench.cli", "paper", *TINY, "--out", str(read_only_dir), cwd=read_only_dir.parent)
    err = _one_line_error(proc, f"--out {read_only_dir}: cannot write there (")
    assert "Read-only file system" in err or "Permission denied" in err
    assert proc.stdout == ""  # no table: nothing was computed


def test_efficiency_on_a_read_only_out_is_one_line(read_only_dir: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    err = _cli(capsys, cli_main, "efficiency", *BUDGET, "--out", str(read_only_dir))
    assert f"--out {read_only_dir}: cannot write there (" in err
    assert capsys.readouterr().out == ""


def _stop_after_first_task(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Ctrl-C in the driver as it is about to write its second task; returns the tasks written."""
    from msd_bench.io.storage.run_dir import RunDir

    real = RunDir.run_task
    written: list[str] = []

    def run_then_stop(self: RunDir, task: str, produce: Any) -> bool:
        if written:
            raise KeyboardInterrupt
        written.append(task)
        return real(self, task, produce)

    monkeypatch.setattr(RunDir, "run_task", run_then_stop)
    return written


def _mtimes(root: Path) -> dict[str, int]:
    return {str(p.relative_to(root)): p.stat().st_mtime_ns for p in root.rglob("*") if p.is_file()}


def test_paper_resumes_an_unfinished_run_without_redoing_its_tasks(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["paper", *TINY, "--id-seeds", "2"]
    assert cli_main([*args, "--out", str(tmp_path / "whole")]) == 0
    written = _stop_after_first_task(monkeypatch)
    assert cli_main([*args, "--out", str(tmp_path / "cut")]) == 130
    cut = tmp_path / "cut"
    assert not is_complete(cut) and not (cut / "table1.json").exists()
    (first,) = written  # either identification seed may finish first: two workers run them together
    other = "id1" if first == "id0" else "id0"
    before = {k: v for k, v in _mtimes(cut).items() if first in k and "tasks" not in k}
    assert first in ("id0", "id1") and any(k.startswith(f"policies/glm/{first}/") for k in before)
    monkeypatch.undo()
    capsys.readouterr()
    assert cli_main([*args, "--out", str(cut)]) == 0
    assert "resuming: 1 of 2 tasks already written, not recomputed" in capsys.readouterr().err
    assert {k: v for k, v in _mtimes(cut).items() if k in before} == before  # not recomputed
    assert is_complete(cut)
    whole, again = (json.loads((tmp_path / d / "table1.json").read_text()) for d in ("whole", "cut"))
    assert again["agents"] == whole["agents"]
    assert json.loads((cut / "robustness.json").read_text()) == json.loads(
        (tmp_path / "whole" / "robustness.json").read_text())
    for name in (f"policies/glm/{other}/qtables.npz", f"models/{other}/glm.json"):
        a, b = (tmp_path / "whole" / name), (cut / name)
        if name.endswith(".npz"):
            with np.load(a) as x, np.load(b) as y:
                assert all(np.array_equal(x[k], y[k]) for k in ("q", "first", "last"))
        else:
            assert json.loads(a.read_text())["params"] == json.loads(b.read_text())["params"]


EFFICIENCY = ["efficiency", "--seeds", "1", "--id-seeds", "1", "--agents", "glm+improved,plant",
              "--record-samples", "300", "--budgets", "1", "--steps", "100", "--validation-steps", "100",
              "--episodes", "2"]


def test_efficiency_resumes_without_recomputing_a_finished_point(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main([*EFFICIENCY, "--out", str(tmp_path / "whole")]) == 0
    assert "<h2>Data efficiency</h2>" in (tmp_path / "whole" / "index.html").read_text()
    written = _stop_after_first_task(monkeypatch)
    assert cli_main([*EFFICIENCY, "--out", str(tmp_path / "cut")]) == 130
    assert not is_complete(tmp_path / "cut") and not (tmp_path / "cut" / "efficiency.json").exists()
    first = tmp_path / "cut" / "points" / f"{written[0]}.json"
    mtime = first.stat().st_mtime_ns
    monkeypatch.undo()
    capsys.readouterr()
    assert cli_main([*EFFICIENCY, "--out", str(tmp_path / "cut")]) == 0
    assert "resuming: 1 of 2 tasks already written, not recomputed" in capsys.readouterr().err
    assert first.stat().st_mtime_ns == mtime
    assert is_complete(tmp_path / "cut")
    whole, cut = (json.loads((tmp_path / d / "efficiency.json").read_text()) for d in ("whole", "cut"))
    assert cut == whole


def test_a_paper_run_of_other_options_is_not_resumed(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / MANIFEST).write_text(json.dumps(
        {"schema": "msd-bench/run", "schema_version": 1, "command": "paper", "config_sha256": "0" * 64,
         "tasks": ["table1"]}))
    before = _state(tmp_path)
    err = _cli(capsys, cli_main, "paper", *TINY, "--out", str(tmp_path / "out"))
    assert "unfinished paper run of another configuration" in err
    assert _state(tmp_path) == before


# --- the report stage of a received run ------------------------------------------------------------

def _received_policy(root: Path) -> None:
    """The model and the trained-policy artifact an agent node leaves beside its result.json (the
    report loads both): the pinned GLM and a paper agent trained on it for a few steps."""
    from msd_bench import designs
    from msd_bench.designs import Settings
    from msd_bench.io.storage.artifacts import load_model

    (root / "models").mkdir(parents=True, exist_ok=True)
    pinned = Path(__file__).resolve().parents[1] / "data" / "pinned" / "glm.json"
    (root / "models" / "glm.json").write_bytes(pinned.read_bytes())
    policy = designs.make("glm", load_model(pinned), Settings(episodes=1, steps=20), [0])
    designs.save(policy, root / "agents" / "glm", {"test": "received run"}, root=root)


def _received_run(root: Path, training: str = "in-process") -> Path:
    rows = [{"seed": 0, "id_seed": 0, "mae": 0.1, "std": 0.1, "po": 1.0, "ts": 2.0, "ts5": 1.5, "sse": 1.0,
             "success": True}]
    doc = {"kind": "glm", "training": training, "real_interactions": 0, "per_seed": rows}
    (root / "agents" / "glm").mkdir(parents=True)
    (root / "agents" / "glm" / "result.json").write_text(json.dumps(doc))
    _received_policy(root)
    return root


def test_report_stage_refuses_a_symlinked_table(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """The issue's reproduction: before, the file outside was overwritten with Table 1."""
    outside = _sentinel(tmp_path / "elsewhere" / "important.md")
    run = _received_run(tmp_path / "run")
    (run / "report").mkdir()
    (run / "report" / "table1.md").symlink_to(outside)
    before = _state(tmp_path / "elsewhere")
    monkeypatch.setenv("ROS_DOMAIN_ID", os.environ.get("ROS_DOMAIN_ID", "0"))  # bench.py sets its own
    err = _cli(capsys, bench_main, "--stages", "report", "--agents", "glm", "--out", str(run))
    assert "table1.md: is a symlink" in err
    assert _state(tmp_path / "elsewhere") == before


@pytest.mark.parametrize("planted", ["symlinked report", "foreign file"])
def test_bench_out_is_probed_before_any_stage(tmp_path: Path, planted: str, monkeypatch: pytest.MonkeyPatch,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    _sentinel(tmp_path / "elsewhere" / "table1.md")
    run = _received_run(tmp_path / "run")
    if planted == "foreign file":
        _sentinel(run / "thesis.tex")
    else:
        (run / "report").symlink_to(tmp_path / "elsewhere")
    before = _state(tmp_path)
    monkeypatch.setenv("ROS_DOMAIN_ID", os.environ.get("ROS_DOMAIN_ID", "0"))  # bench.py sets its own
    err = _cli(capsys, bench_main, "--stages", "report", "--agents", "glm", "--out", str(run))
    assert ("report is a symlink" if planted != "foreign file" else "'thesis.tex'") in err
    assert _state(tmp_path) == before


def test_text_from_a_received_result_cannot_inject_lines(tmp_path: Path) -> None:
    run = _received_run(tmp_path / "run", training="ros\n| injected | row |\n\n- injected note | x")
    results = load_results(BenchConfig(run_dir=run, run=RunConfig(agents=("glm",))))
    md = table_markdown(results, {"preset": "default", "window": 500})
    assert not [ln for ln in md.splitlines() if "injected" in ln and not ln.startswith("- GLM")]
    note = next(ln for ln in md.splitlines() if "injected" in ln)
    assert note.startswith("- GLM (paper agent): trained ros | injected")


# --- check-rig --json ---------------------------------------------------------------------------------

@pytest.mark.parametrize("existing", ["directory", "foreign file"])
def test_check_rig_json_is_probed_before_any_ros_work(tmp_path: Path, existing: str,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "out.json"
    if existing == "directory":
        target.mkdir()
        _sentinel(target / "keep.txt")
    else:
        _sentinel(target)
    before = _state(tmp_path)
    err = _cli(capsys, cli_main, "check-rig", "/nowhere", "--json", str(target))
    assert f"--json {target} exists and is not a" in err
    assert _state(tmp_path) == before
