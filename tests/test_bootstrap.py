"""``python launch_scripts/bench.py`` as typed: any interpreter, re-exec into the venv or one line.

The "foreign" interpreter is this venv's base Python started with ``-S``: no
site-packages at all, so it certainly lacks the project's dependencies (the
re-exec drops interpreter flags, so the venv's Python runs normally).
"""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from msd_bench import _bootstrap

REPO = Path(__file__).resolve().parents[1]
BARE = [getattr(sys, "_base_executable", sys.executable), "-S"]
SCRIPTS = sorted(p.name for p in (REPO / "launch_scripts").glob("[a-z]*.py"))


def pristine_env(**extra: str) -> dict[str, str]:
    """A login-shell-like environment: no venv, no LD_LIBRARY_PATH, no bootstrap guards."""
    env = {"PATH": "/usr/bin:/bin", "HOME": os.environ.get("HOME", "/tmp"), "LANG": "C.UTF-8"}
    env.update(extra)
    return env


def run(
    argv: list[str], cwd: Path, env: dict[str, str], timeout: float = 120.0
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout,
                          check=False)


def bare_copy(tmp_path: Path) -> Path:
    """The entry points and the bootstrap without any venv beside them."""
    repo = tmp_path / "repo"
    shutil.copytree(REPO / "launch_scripts", repo / "launch_scripts",
                    ignore=shutil.ignore_patterns("__pycache__"))
    (repo / "msd_bench").mkdir()
    for name in ("__init__.py", "__main__.py", "_bootstrap.py", "_version.py", "cli.py"):
        shutil.copy(REPO / "msd_bench" / name, repo / "msd_bench" / name)
    return repo


def fake_python(path: Path, body: str = "exit 0") -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"#!/bin/sh\n{body}\n")
    path.chmod(path.stat().st_mode | stat.S_IXUSR)


needs_venv = pytest.mark.skipif(
    _bootstrap.venv_python() is None, reason="no project venv built beside the repository (make setup)"
)


@needs_venv
def test_bench_help_with_a_bare_interpreter_reexecs_into_the_venv():
    done = run([*BARE, "launch_scripts/bench.py", "--help"], REPO, pristine_env())
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("usage: bench.py") and "--seeds" in done.stdout
    assert "Traceback" not in done.stderr


@needs_venv
@pytest.mark.ros
def test_ros_launch_script_loads_rclpy_after_the_reexec():
    # rclpy's libraries need the LD_LIBRARY_PATH the venv's ros-wheels bootstrap sets:
    # reaching the parameter check proves the whole chain bare python -> venv -> rclpy.
    domain = os.environ["MSD_TEST_DOMAIN_ID"]
    env = pristine_env(ROS_DOMAIN_ID=domain, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    done = run([*BARE, "launch_scripts/plant.py", "--ros-args", "-p", "duplicate_check:=-1.0"], REPO, env)
    assert done.returncode == 2, done.stdout + done.stderr
    assert "Traceback" not in done.stderr and "duplicate_check" in done.stderr


@pytest.mark.parametrize("script", SCRIPTS)
def test_launch_script_without_an_environment_prints_one_line(tmp_path, script):
    repo = bare_copy(tmp_path)
    done = run([*BARE, f"launch_scripts/{script}", "--help"], repo, pristine_env(), timeout=30)
    assert done.returncode == 2 and done.stdout == ""
    lines = done.stderr.splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith(f"{script}: ") and "make setup" in lines[0] and "numba" in lines[0]


@pytest.mark.parametrize("module", ["msd_bench", "msd_bench.cli"])
def test_cli_module_without_an_environment_prints_one_line(tmp_path, module):
    repo = bare_copy(tmp_path)
    done = run([*BARE, "-m", module, "paper"], repo, pristine_env(), timeout=30)
    assert done.returncode == 2 and done.stdout == ""
    assert len(done.stderr.splitlines()) == 1 and done.stderr.startswith("msd-bench: "), done.stderr


def test_a_venv_that_still_lacks_the_deps_is_not_reexecuted_twice(tmp_path):
    repo = bare_copy(tmp_path)
    fake_python(repo / ".venv" / "bin" / "python", f'exec {BARE[0]} -S "$@"')  # a broken venv
    done = run([*BARE, "launch_scripts/bench.py"], repo, pristine_env(), timeout=30)
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1, done.stderr
    assert "lacks" in done.stderr and "make setup" in done.stderr


def test_the_venv_the_last_setup_recorded_comes_before_dot_venv(tmp_path):
    fake_python(tmp_path / ".venv" / "bin" / "python")
    assert _bootstrap.venv_python(str(tmp_path)) == str(tmp_path / ".venv" / "bin" / "python")
    (tmp_path / ".msd-env").write_text(".venv-jazzy\n")
    # recorded but not built: still .venv
    assert _bootstrap.venv_python(str(tmp_path)) == str(tmp_path / ".venv" / "bin" / "python")
    fake_python(tmp_path / ".venv-jazzy" / "bin" / "python")
    assert _bootstrap.venv_python(str(tmp_path)) == str(tmp_path / ".venv-jazzy" / "bin" / "python")


def test_no_venv_at_all_is_none(tmp_path):
    (tmp_path / ".msd-env").write_text(".venv-jazzy\n")
    assert _bootstrap.venv_python(str(tmp_path)) is None


def test_reexec_drops_interpreter_flags_and_keeps_arguments(monkeypatch):
    monkeypatch.setattr(sys, "argv", ["launch_scripts/bench.py", "--seeds", "2"])
    argv = _bootstrap.reexec_argv("/v/bin/python", None)
    assert argv == ["/v/bin/python", str(Path("launch_scripts/bench.py").resolve()), "--seeds", "2"]
    as_module = _bootstrap.reexec_argv("/v/bin/python", "msd_bench")
    assert as_module == ["/v/bin/python", "-m", "msd_bench", "--seeds", "2"]
