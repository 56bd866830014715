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

from msd_bench.core.agents import AGENT_KINDS, check_agents
from msd_bench.core.errors import ConfigError

if TYPE_CHECKING:
    from msd_bench.core.pipeline import PaperConfig

# The pipeline pulls in torch and python-control (seconds): it is imported when a run
# starts, so `--help` and option errors answer at once.
AGENT_KIND_NAMES = tuple(AGENT_KINDS)


def register(sub: Any) -> None:
    """Add the ``paper`` subcommand."""
    p = sub.add_parser("paper", help="run the paper's method in-process and print Table 1",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_run_arguments(p)
    p.add_argument("--out", type=Path, required=True, help="output directory (created)")
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    p.set_defaults(func=run)


def add_run_arguments(p: argparse.ArgumentParser) -> None:
    """Options shared with bench.py: budgets, seeds, agent kinds, preset."""
    p.add_argument("--seeds", type=int, default=20, help="learning seeds per agent kind (20)")
    p.add_argument("--first-seed", type=int, default=0, help="first learning seed (0)")
    p.add_argument("--id-seeds", type=int, default=1,
                   help="identification seeds: re-record and re-identify each (1)")
    p.add_argument("--preset", default="default", help="plant preset: default or mild")
    p.add_argument("--agents", default=",".join(AGENT_KIND_NAMES),
                   help=f"comma-separated agent kinds (default: all): {', '.join(AGENT_KIND_NAMES)}")
    p.add_argument("--episodes", type=int, default=300, help="training episodes (300)")
    p.add_argument("--steps", type=int, default=3000, help="steps per training episode (3000)")
    p.add_argument("--dyna-episodes", type=int, default=300, help="Dyna-Q episodes (300)")
    p.add_argument("--samples", type=int, default=12_000, help="samples per identification record (12000)")
    p.add_argument("--val-samples", type=int, default=4_000, help="samples per validation record (4000)")
    p.add_argument("--nlarx-scale", type=float, default=1.0,
                   help="scale NLARX training iterations (smoke runs: 0.05)")


def config_from_args(args: argparse.Namespace) -> PaperConfig:
    """A validated :class:`PaperConfig` from parsed options (one-line ConfigError otherwise)."""
    agents = tuple(a.strip() for a in str(args.agents).split(",") if a.strip())
    check_agents(agents)  # before the (slow) pipeline import, so a typo answers at once
    from msd_bench.core.pipeline import PaperConfig

    return PaperConfig(
        preset=args.preset, seeds=args.seeds, first_seed=args.first_seed, id_seeds=args.id_seeds,
        agents=agents, episodes=args.episodes, steps=args.steps, dyna_episodes=args.dyna_episodes,
        samples=args.samples, val_samples=args.val_samples, nlarx_scale=args.nlarx_scale,
    )


def _check_out(out: Path) -> None:
    """Refuse an --out that is a file, holds a report already, or cannot be created."""
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out {out} is a file, not a directory")
    if (out / "table1.json").exists():
        raise ConfigError(f"{out} already holds a table1.json; choose another --out")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"cannot create --out {out}: {exc.strerror}") from None


def run_facts(cfg: PaperConfig, seconds: float, mode: str) -> dict[str, Any]:
    """What table1.json's ``run`` object records about the run."""

    return {**asdict(cfg), "plant": asdict(cfg.plant), "mode": mode, "seconds": round(seconds, 2),
            "success_sse_percent": 5.0}


def run(args: argparse.Namespace) -> int:
    """Run, write, print the table."""
    cfg = config_from_args(args)
    out = Path(args.out)
    _check_out(out)
    from msd_bench.core.pipeline import run_paper  # torch and control: seconds to import
    from msd_bench.io.run_output import write_all
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
