"""No reader of user files swallows everything: every except names what its library raises.

Why a test: ``except Exception`` in a reader turns a bug of ours (a TypeError,
an AttributeError) into "your file is corrupt", and a bare ``except:`` or
``except BaseException`` even eats Ctrl-C. The readers must catch what the
library they call actually raises, so a new failure mode shows up as a
traceback in the tests instead of a misleading one-line error.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from tests.syntax import parse_source

ROOT = Path(__file__).resolve().parents[1] / "msd_bench"

READERS = [
    *sorted((ROOT / "io").rglob("*.py")),
    ROOT / "core" / "physics" / "model.py",
    ROOT / "core" / "identification" / "model_kinds.py",
    ROOT / "graph" / "bench_report.py",
    ROOT / "graph" / "run_files.py",
    ROOT / "gym" / "backends.py",
]
"""Every module under msd_bench/io and the readers hardened elsewhere (model loading, the report's
run-directory files, the gym's model backend)."""

BROAD = {"Exception", "BaseException"}


def _reraises(handler: ast.ExceptHandler) -> bool:
    """A handler that cleans up and ends in a bare ``raise`` swallows nothing (a temporary file's
    removal on any failure, Ctrl-C included)."""
    last = handler.body[-1]
    return isinstance(last, ast.Raise) and last.exc is None


def broad_handlers(source: str) -> list[tuple[int, str]]:
    """``(line, what)`` of each bare ``except:`` and each handler naming Exception or BaseException
    (alone or in a tuple), unless it ends by re-raising what it caught."""
    found = []
    for node in ast.walk(parse_source(source)):
        if not isinstance(node, ast.ExceptHandler) or _reraises(node):
            continue
        if node.type is None:
            found.append((node.lineno, "bare except:"))
            continue
        names = node.type.elts if isinstance(node.type, ast.Tuple) else [node.type]
        for name in names:
            label = name.id if isinstance(name, ast.Name) else getattr(name, "attr", "")
            if label in BROAD:
                found.append((node.lineno, f"except {label}"))
    return found


@pytest.mark.parametrize("path", READERS, ids=lambda p: str(p.relative_to(ROOT)))
def test_reader_has_no_broad_except(path: Path) -> None:
    assert path.is_file(), f"{path} is listed as a reader but does not exist"
    assert broad_handlers(path.read_text()) == []


@pytest.mark.parametrize("source, expected", [
    ("try:\n    pass\nexcept:\n    pass\n", [(3, "bare except:")]),
    ("try:\n    pass\nexcept Exception:\n    pass\n", [(3, "except Exception")]),
    ("try:\n    pass\nexcept BaseException:\n    cleanup()\n    raise\n", []),
    ("try:\n    pass\nexcept BaseException as e:\n    raise ValueError() from e\n",
     [(3, "except BaseException")]),
    ("try:\n    pass\nexcept (OSError, BaseException) as e:\n    pass\n", [(3, "except BaseException")]),
    ("try:\n    pass\nexcept builtins.Exception:\n    pass\n", [(3, "except Exception")]),
    ("try:\n    pass\nexcept (OSError, ValueError):\n    pass\n", []),
])
def test_the_check_sees_every_broad_form(source: str, expected: list[tuple[int, str]]) -> None:
    assert broad_handlers(source) == expected
