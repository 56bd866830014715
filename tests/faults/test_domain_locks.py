"""An unusable domain-lock directory is one line naming it and TMPDIR, in-process and from bench.py."""

from __future__ import annotations

import os
import random
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from msd_bench.core.errors import ConfigError
from msd_bench.graph import domains
from tests.faults.test_storage import read_only_disk  # noqa: F401  (fixture: a read-only tmpfs)

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture
def temp_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """tempfile's directory (what TMPDIR selects) pointed at a fresh directory."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    return tmp_path


def _one_line(err: pytest.ExceptionInfo[ConfigError]) -> str:
    text = str(err.value)
    assert "\n" not in text
    return text


@pytest.mark.parametrize("requested", [None, 7])
def test_a_file_in_the_way_names_the_directory_and_tmpdir(temp_root: Path, requested: int | None) -> None:
    (temp_root / "msd-bench-domains").write_text("not a directory")
    with pytest.raises(ConfigError) as err:
        domains.claim_domain(requested)
    text = _one_line(err)
    assert f"domain-lock directory {temp_root / 'msd-bench-domains'}: cannot create it" in text
    assert "set TMPDIR" in text
    assert (temp_root / "msd-bench-domains").read_text() == "not a directory"  # nothing overwritten


def test_a_read_only_directory_names_it_and_tmpdir(read_only_disk: Path,  # noqa: F811
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(tempfile, "tempdir", str(read_only_disk))
    with pytest.raises(ConfigError) as err:
        domains.claim_domain(None)
    text = _one_line(err)
    assert str(read_only_disk / "msd-bench-domains") in text and "Read-only file system" in text
    assert "set TMPDIR" in text


def test_a_symlinked_lock_file_is_never_followed(temp_root: Path) -> None:
    """Another user's planted symlink: the requested domain is refused, a random pick skips it."""
    locks = temp_root / "msd-bench-domains"
    locks.mkdir()
    victim = temp_root / "victim"
    for domain in domains.AUTO_DOMAINS:
        if domain != 42:
            (locks / f"{domain}.lock").symlink_to(victim)
    with pytest.raises(ConfigError) as err:
        domains.claim_domain(7)
    assert "ROS domain 7: cannot open its lock file" in _one_line(err)
    domain, fh = domains.claim_domain(None, random.Random(1))
    fh.close()
    assert domain == 42 and not victim.exists()


def test_bench_py_with_an_unusable_lock_directory_exits_2_with_one_line(tmp_path: Path) -> None:
    (tmp_path / "msd-bench-domains").write_text("")
    env = {**os.environ, "TMPDIR": str(tmp_path)}
    proc = subprocess.run([sys.executable, "launch_scripts/bench.py", "--out", str(tmp_path / "out")],
                          cwd=REPO, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "domain-lock directory" in lines[0] and "TMPDIR" in lines[0], proc.stderr
    assert not (tmp_path / "out").exists()
