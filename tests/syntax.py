"""``ast.parse`` for the tests that scan the product's source (layers, switches, loops ...).

Why not ``ast.parse`` alone: CPython 3.11 keeps the AST constructor's recursion depth in one
per-interpreter counter, so a parse on another thread of the same process (a library's daemon
thread left by an earlier test of the same pytest-xdist worker) can make a correct parse raise
``SystemError: AST constructor recursion depth mismatch``; seen once under load, failing
tests/test_layers.py with no fault in the code it scans. That error is retried a few times, then
the source is parsed in a fresh interpreter, where no other thread exists; any other error
(a real syntax error) is raised at once.
"""

from __future__ import annotations

import ast
import pickle
import subprocess
import sys
import time

RETRIES = 5
"""Parses retried in this process before a fresh interpreter parses the source."""
_CHILD = ("import ast, pickle, sys; "
          "sys.stdout.buffer.write(pickle.dumps(ast.parse(sys.stdin.read(), sys.argv[1])))")


def parse_source(source: str, filename: str = "<unknown>") -> ast.Module:
    """The syntax tree of ``source``, as :func:`ast.parse` gives it."""
    for _ in range(RETRIES):
        try:
            return ast.parse(source, filename)
        except SystemError as err:
            if "recursion depth mismatch" not in str(err):
                raise
            time.sleep(0.2)
    out = subprocess.run([sys.executable, "-c", _CHILD, filename], input=source.encode(),
                         capture_output=True, check=True)
    tree = pickle.loads(out.stdout)
    assert isinstance(tree, ast.Module)
    return tree
