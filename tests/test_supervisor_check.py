"""scripts/supervisor_check.py: a bad options file or an existing --out is one line and exit 2,
before any work, and the existing file is left as it was."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "supervisor_check.py"


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=120,
                          check=False)


def test_a_bad_options_file_is_one_line(tmp_path: Path) -> None:
    for text, needle in [('{"speed": 1}', "unknown option 'speed'"), ("[1]", "must be a JSON object"),
                         ('{"envelope": 3}', "inside the stroke"), ("{", "not valid JSON")]:
        opts = tmp_path / "opts.json"
        opts.write_text(text)
        r = run("--options", str(opts))
        assert r.returncode == 2, r.stderr
        assert r.stderr.count("\n") == 1 and needle in r.stderr and "Traceback" not in r.stderr
        assert r.stdout == ""


def test_an_existing_out_is_refused_and_kept(tmp_path: Path) -> None:
    out = tmp_path / "out.json"
    out.write_text("theirs")
    r = run("--out", str(out))
    assert r.returncode == 2 and "exists; not overwriting it" in r.stderr and r.stderr.count("\n") == 1
    assert out.read_text() == "theirs"


def test_the_subcommands_refuse_bad_arguments_in_one_line_before_any_work(tmp_path: Path) -> None:
    out = tmp_path / "out.json"
    out.write_text("theirs")
    for args, needle in [(("population", "--rigs", "0"), "--rigs must be >= 1"),
                         (("good-kinds", "--kinds", "glm+nope"), "glm+nope"),
                         (("population", "--out", str(out)), "exists; not overwriting it")]:
        r = run(*args)
        assert r.returncode == 2, r.stderr
        assert r.stderr.count("\n") == 1 and needle in r.stderr and "Traceback" not in r.stderr
        assert r.stdout == ""
    assert out.read_text() == "theirs"
