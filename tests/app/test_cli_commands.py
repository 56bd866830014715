"""The CLI's command table: every subcommand is found in the module the table names, and a run of one
command imports no other command's module (the reason the table exists)."""

from __future__ import annotations

import ast
import subprocess
import sys

import pytest

from msd_bench.cli import COMMANDS, build_parser


def _registered(parser) -> list[str]:  # type: ignore[no-untyped-def]
    sub = next(a for a in parser._actions if a.dest == "command")
    return list(sub.choices)


def test_the_full_parser_holds_exactly_the_table_s_commands_in_its_order():
    assert _registered(build_parser()) == list(COMMANDS)


@pytest.mark.parametrize("command", list(COMMANDS))
def test_each_command_s_module_registers_it(command):
    assert command in _registered(build_parser(command))


def test_a_command_run_imports_no_other_command_s_module(tmp_path):
    code = ("import sys; from msd_bench.cli import main; rc = main(['paper', '--seeds', '0', '--out', "
            f"{str(tmp_path / 'o')!r}]); "
            "print(sorted(m for m in sys.modules if m.startswith('msd_bench.commands.')))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert "seeds must be >= 1" in proc.stderr
    loaded = set(ast.literal_eval(proc.stdout.strip().splitlines()[-1]))
    assert "msd_bench.commands.paper" in loaded
    assert not {f"msd_bench.commands.{m}" for m in ("diagnose", "bag", "check_rig")} & loaded
