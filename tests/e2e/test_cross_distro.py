"""Kilted and Jazzy on one wire: a plant in one distribution's venv, a probe in the other's.

The realistic deployment is a Jazzy rig PC and a Kilted bench PC (or the
reverse). Both directions: the plant process runs ``launch_scripts/plant.py``
(real time, 100 Hz) with one venv's python, ``tests/e2e/cross_probe.py`` runs
with the other's, pushes a force and counts the ``joint_states`` rows whose
effort is that force — the force the plant applied. Needs ``.venv`` (Kilted)
and ``.venv-jazzy`` (Jazzy) beside the repository; ``.ci/run`` builds both.

The two interpreters are not ``sys.executable`` on purpose. Each child gets an
environment without the parent's ``LD_LIBRARY_PATH`` and without
ros-wheels-bootstrapper's guard, so its own venv puts its own ROS libraries on
the library path (inheriting the parent's would load Kilted's into Jazzy).
"""

from __future__ import annotations

import json
import os
import subprocess
import threading
import time
from pathlib import Path

import pytest

from msd_bench.graph import launch

pytestmark = pytest.mark.e2e

REPO = Path(__file__).resolve().parents[2]
VENVS = {"kilted": REPO / ".venv", "jazzy": REPO / ".venv-jazzy"}
RCLPY_MAJOR = {"kilted": "9", "jazzy": "7"}
FORCE_N = 2.5
ROWS = 150  # 1.5 s of applied force at 100 Hz


def _missing() -> list[str]:
    return [f"{name} ({path.name})" for name, path in VENVS.items() if not (path / "bin" / "python").exists()]


def child_env() -> dict[str, str]:
    """This test's environment for a process of another venv (see the module docstring)."""
    env = launch.ros_env(int(os.environ["MSD_TEST_DOMAIN_ID"]))
    for name in ("LD_LIBRARY_PATH", "_ROS_WHEELS_BOOTSTRAP_COMPLETE", "MSD_BENCH_REEXEC", "VIRTUAL_ENV"):
        env.pop(name, None)
    return env


def start_plant(distro: str) -> launch.NodeProcess:
    """``launch_scripts/plant.py`` in real time under /msd, run by ``distro``'s python."""
    argv = [str(VENVS[distro] / "bin" / "python"), str(launch.SCRIPTS / "plant.py"),
            "--ros-args", "-p", "duplicate_check:=0.5"]
    popen = subprocess.Popen(argv, cwd=REPO, env=child_env(), text=True, stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, start_new_session=True)
    proc = launch.NodeProcess(f"plant-{distro}", popen)
    proc.reader = threading.Thread(target=_collect, args=(proc,), daemon=True)
    proc.reader.start()
    return proc


def _collect(proc: launch.NodeProcess) -> None:
    assert proc.popen.stdout is not None
    for line in proc.popen.stdout:
        proc.lines.append(line.rstrip("\n"))


def run_probe(distro: str) -> tuple[dict[str, float | str], float]:
    """The probe's JSON result and its wall time, run by ``distro``'s python."""
    argv = [str(VENVS[distro] / "bin" / "python"), str(Path(__file__).with_name("cross_probe.py")),
            str(FORCE_N), str(ROWS), "60"]
    t0 = time.monotonic()
    done = subprocess.run(argv, cwd=REPO, env=child_env(), capture_output=True, text=True, timeout=120,
                          check=False)
    assert done.returncode == 0, done.stdout + done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1]), time.monotonic() - t0


@pytest.mark.skipif(bool(_missing()), reason="needs both distributions' venvs (make setup && make setup "
                    f"DISTRO=jazzy); missing: {', '.join(_missing())}")
@pytest.mark.parametrize(("plant_distro", "probe_distro"), [("kilted", "jazzy"), ("jazzy", "kilted")])
def test_plant_and_probe_of_two_distributions_exchange_telemetry_and_commands(plant_distro, probe_distro):
    plant = start_plant(plant_distro)
    try:
        plant.wait_for_line("ready", timeout=60.0)
        result, seconds = run_probe(probe_distro)
    finally:
        status = launch.stop(plant)
    print(f"{plant_distro} plant -> {probe_distro} probe: {result} (probe process {seconds:.1f} s)")
    assert str(result["rclpy"]).split(".")[0] == RCLPY_MAJOR[probe_distro]
    assert result["pushed_rows"] >= ROWS and result["rows"] >= result["pushed_rows"]
    assert float(result["last_x"]) > 0.0  # pushed by +2.5 N, the mass moved
    assert status == 0, plant.output()
    summary = next(ln for ln in plant.lines if "shutdown: steps=" in ln)
    assert "rejected=0" in summary and "saturated=0" in summary
    assert f"rclpy {RCLPY_MAJOR[plant_distro]}." in _rclpy_of(plant_distro)


def _rclpy_of(distro: str) -> str:
    """``rclpy <version>`` as installed in ``distro``'s venv (read from its metadata, not imported)."""
    dist = next((VENVS[distro] / "lib").glob("python3*/site-packages/ros_rclpy-*.dist-info"))
    return f"rclpy {dist.name.split('-')[1]}"
