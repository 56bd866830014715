"""Run the launch scripts and the CLI as typed, with whatever ``python`` the user has.

Users type ``python launch_scripts/bench.py``, and ``python`` is rarely the
project's venv: without this module that ends in ``ModuleNotFoundError``. So
before anything else is imported, an entry point calls :func:`ensure_environment`.
If the running interpreter can find the project's dependencies, nothing happens.
Otherwise the process re-executes itself with the project's environment — the
venv the last ``make setup`` recorded in ``.msd-env``, else ``.venv`` — and when
there is none it prints one line saying how to build it and exits with status 2.

Standard library only, and syntax any Python 3 parses: it runs *before* we know
the interpreter is the right one. ``msd_bench/__init__.py`` must stay import-free
for the same reason (``tests/test_bootstrap.py`` checks both).
"""

from __future__ import annotations

import importlib.util
import os
import sys

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RECORD = ".msd-env"
"""File at the repository root naming the venv (relative path) the last ``make setup`` built."""
DEFAULT_VENV = ".venv"
REQUIRED = ("numpy", "scipy", "numba", "torch", "yaml", "mcap", "rosbags", "control", "rclpy")
"""Top-level modules whose absence means "not the project's environment" (found, not imported)."""
GUARD = "MSD_BENCH_REEXEC"
"""Set in the re-executed process: a second miss means a broken venv, not another re-exec."""
ROS_WHEELS_GUARD = "_ROS_WHEELS_BOOTSTRAP_COMPLETE"
"""ros-wheels-bootstrapper's own guard; cleared so the target venv sets its LD_LIBRARY_PATH."""
EXIT_NO_ENV = 2


def missing_modules() -> list[str]:
    """The required modules this interpreter cannot find (without importing any)."""
    return [name for name in REQUIRED if importlib.util.find_spec(name) is None]


def recorded_venvs(repo: str = REPO) -> list[str]:
    """Candidate venv directories, the one ``make setup`` recorded first, then ``.venv``."""
    names = []
    try:
        with open(os.path.join(repo, RECORD), encoding="utf-8") as f:
            names.append(f.read().strip())
    except OSError:
        pass
    names.append(DEFAULT_VENV)
    seen: list[str] = []
    for name in names:
        path = os.path.join(repo, name)
        if name and path not in seen:
            seen.append(path)
    return seen


def venv_python(repo: str = REPO) -> str | None:
    """The interpreter of the project's environment, or None if none is built."""
    for venv in recorded_venvs(repo):
        python = os.path.join(venv, "bin", "python")
        if os.access(python, os.X_OK):
            return python
    return None


def reexec_argv(python: str, module: str | None) -> list[str]:
    """The command line that runs this entry point again under ``python``.

    Interpreter flags (``-I``, ``-S``, ``-E``) are dropped: they would hide the
    venv's site-packages from the new process.
    """
    if module is not None:
        return [python, "-m", module, *sys.argv[1:]]
    return [python, os.path.abspath(sys.argv[0]), *sys.argv[1:]]


def _say(prog: str, message: str) -> None:
    print(f"{prog}: {message}", file=sys.stderr)


def ensure_environment(module: str | None = None) -> None:
    """Continue if the dependencies are here; else re-exec into the project's venv or exit with one line.

    ``module`` names the entry point when it was started with ``python -m``.
    """
    missing = missing_modules()
    if not missing:
        return
    prog = "msd-bench" if module else os.path.basename(sys.argv[0])
    setup = f"run `make setup` in {REPO} (ROS 2 Jazzy: `make setup DISTRO=jazzy`; see docs/distributions.md)"
    python = venv_python()
    if os.environ.get(GUARD):
        _say(prog, f"the project's environment ({sys.executable}) lacks {', '.join(missing)}: {setup}")
        sys.exit(EXIT_NO_ENV)
    if python is None:
        _say(prog, f"this python lacks {', '.join(missing)} and no project venv is built: {setup}")
        sys.exit(EXIT_NO_ENV)
    env = dict(os.environ)
    env[GUARD] = "1"
    env.pop(ROS_WHEELS_GUARD, None)
    sys.stdout.flush()
    sys.stderr.flush()
    try:
        os.execve(python, reexec_argv(python, module), env)
    except OSError as exc:
        _say(prog, f"cannot start {python} ({exc.strerror}): {setup}")
        sys.exit(EXIT_NO_ENV)
