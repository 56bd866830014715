"""``msd-bench paper``: the paper's method in-process, over many seeds, as Table 1.

No ROS: records are simulated, models identified, agents trained on their
surrogate and validated on the true plant, all in this process. Writes
``table1.json`` / ``table1.csv`` / ``table1.md`` (schema in the README), the
models, the Q-tables and the figures under ``--out``.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

from msd_bench.app.options import add_run_arguments, run_config_from_args
from msd_bench.core.errors import ConfigError

if TYPE_CHECKING:
    from msd_bench.app.config import RunConfig

# The pipeline pulls in torch and python-control (seconds): it is imported when a run
# starts, so `--help` and option errors answer at once.


def register(sub: Any) -> None:
    """Add the ``paper`` subcommand."""
    p = sub.add_parser("paper", help="run the paper's method in-process and print Table 1",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_run_arguments(p)
    p.add_argument("--out", type=Path, required=True, help="output directory (created)")
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    p.set_defaults(func=run)


def check_out(out: Path, marker: str = "table1.json") -> None:
    """Refuse an --out that is a file, holds a report (``marker``) already, or cannot be created."""
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out {out} is a file, not a directory")
    if (out / marker).exists():
        raise ConfigError(f"{out} already holds a {marker}; choose another --out")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"cannot create --out {out}: {exc.strerror}") from None


def run_facts(cfg: RunConfig, seconds: float, mode: str) -> dict[str, Any]:
    """What table1.json's ``run`` object records about the run."""

    return {**asdict(cfg), "plant": asdict(cfg.plant), "mode": mode, "seconds": round(seconds, 2),
            "success_sse_percent": 5.0}


def run(args: argparse.Namespace) -> int:
    """Run, write, print the table."""
    cfg = run_config_from_args(args)
    out = Path(args.out)
    check_out(out)
    from msd_bench.app.output import write_all
    from msd_bench.app.pipeline import run_paper  # torch and control: seconds to import
    from msd_bench.progress import StageProgress

    t0 = time.perf_counter()
    with StageProgress("paper") as bar:
        result = run_paper(cfg, bar.update)
    facts = run_facts(cfg, time.perf_counter() - t0, "in-process")
    written = write_all(out, result, facts, with_figures=not args.no_figures)
    print(written["report"]["md"].read_text())
    if "robustness" in written:
        print(written["robustness"]["md"].read_text())
    print(f"report: {out.resolve()}  ({facts['seconds']:.0f} s)", file=sys.stderr)
    return 0
