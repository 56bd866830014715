"""Command-line options of a run, shared by ``msd-bench paper`` and bench.py.

One definition, so the two entry points cannot drift; each may change a
default (bench.py runs fewer seeds because every stage is a process).
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

from msd_bench.app.agents import AGENT_KINDS, parse_agents
from msd_bench.app.config import RunConfig

if TYPE_CHECKING:
    from msd_bench.app.executor import ExecutorOptions


def add_run_arguments(p: argparse.ArgumentParser, **defaults: Any) -> None:
    """Budgets, seeds, agent kinds and preset; ``defaults`` overrides RunConfig's defaults."""
    base: dict[str, Any] = {name: f.default for name, f in RunConfig.__dataclass_fields__.items()}
    base.update(defaults)
    kinds = ", ".join(AGENT_KINDS)
    p.add_argument("--seeds", type=int, default=base["seeds"],
                   help=f"learning seeds per identification seed and agent kind ({base['seeds']})")
    p.add_argument("--first-seed", type=int, default=base["first_seed"], help="first learning seed (0)")
    p.add_argument("--id-seeds", type=int, default=base["id_seeds"],
                   help=f"identification seeds: re-record and re-identify each ({base['id_seeds']})")
    p.add_argument("--id-first-seed", type=int, default=base["id_first_seed"],
                   help="first identification seed (0)")
    p.add_argument("--preset", default=base["preset"], help="plant preset: default or mild")
    p.add_argument("--agents", default=",".join(str(a) for a in base["agents"]),
                   help=f"comma-separated agent kinds (default {','.join(base['agents'])}; 'matrix' = every "
                        f"surrogate under every design and the on-plant baselines): {kinds}")
    p.add_argument("--episodes", type=int, default=base["episodes"],
                   help=f"training episodes ({base['episodes']})")
    p.add_argument("--steps", type=int, default=base["steps"], help=f"steps per episode ({base['steps']})")
    p.add_argument("--dyna-episodes", type=int, default=base["dyna_episodes"],
                   help=f"Dyna-Q episodes (paper: 300; default {base['dyna_episodes']})")
    p.add_argument("--samples", type=int, default=base["samples"],
                   help=f"samples per identification record ({base['samples']})")
    p.add_argument("--val-samples", type=int, default=base["val_samples"],
                   help=f"samples per validation record ({base['val_samples']})")
    p.add_argument("--validation-steps", type=int, default=base["validation_steps"],
                   help=f"closed-loop validation steps (paper: 3000; {base['validation_steps']})")
    p.add_argument("--record-noise", type=float, default=base["record_noise"], metavar="SIGMA",
                   help="Gaussian sensor noise on the identification records' position, m (0)")
    p.add_argument("--record-quant", type=float, default=base["record_quant"], metavar="Q",
                   help="sensor quantisation of the identification records, m (0)")
    p.add_argument("--shaping", choices=("away", "toward"), default=base["shaping"],
                   help="reading of the paper's shaping penalty for the paper agent "
                        f"(docs/decisions.md; default {base['shaping']})")
    p.add_argument("--scenario", action="append", default=[], metavar="ID",
                   help="evaluate also this scenario, e.g. noise=0.005,delay=1,setpoint=-1.2 (repeatable)")
    p.add_argument("--nlarx-scale", type=float, default=base["nlarx_scale"],
                   help="scale NLARX training iterations (smoke runs: 0.05)")


def add_supervisor_argument(p: argparse.ArgumentParser) -> None:
    """``--supervisor on|off`` for the in-process commands (paper, rigs, efficiency); bench.py's
    validation on a plant has its own switch, so it is not one of the run arguments."""
    p.add_argument("--supervisor", choices=("on", "off"), default="off",
                   help="validate every run behind the safety supervisor with its default limits "
                        "(docs/supervisor.md); risk columns then count its overrides (off)")


def add_executor_arguments(p: argparse.ArgumentParser) -> None:
    """Where a sweep's tasks run (:mod:`msd_bench.app.executor`): this machine's cores or a Ray cluster."""
    from msd_bench.app.executor import DEFAULT_RETRIES, EXECUTORS, MAX_RETRIES, MAX_WORKERS
    from msd_bench.app.ray_probe import PROBE_TIMEOUT_S

    p.add_argument("--executor", choices=tuple(EXECUTORS), default="local",
                   help="local: worker processes on this machine; ray: a Ray cluster (local unless "
                        "--ray-address) (local)")
    p.add_argument("--workers", type=int, default=0,
                   help=f"worker processes, each single-threaded (0 = one per core; at most {MAX_WORKERS})")
    p.add_argument("--ray-address", default=None, metavar="ADDR",
                   help="join this Ray cluster (auto, host:port, ray://host:port) instead of starting one; "
                        f"probed for at most {PROBE_TIMEOUT_S:g} s before --out is written")
    p.add_argument("--retries", type=int, default=DEFAULT_RETRIES,
                   help="restarts of a task whose worker died before the sweep fails "
                        f"(at most {MAX_RETRIES}) ({DEFAULT_RETRIES})")


def executor_from_args(args: argparse.Namespace) -> ExecutorOptions:
    """The validated executor options (one-line ConfigError otherwise)."""
    from msd_bench.app.executor import ExecutorOptions
    from msd_bench.app.ray_probe import probe_ray_address

    options = ExecutorOptions(kind=args.executor, workers=args.workers, ray_address=args.ray_address,
                              retries=args.retries)
    if options.ray_address is not None:  # before --out is touched: an unreachable cluster is one line
        probe_ray_address(options.ray_address)
    return options


def run_config_from_args(args: argparse.Namespace) -> RunConfig:
    """A validated :class:`RunConfig` from parsed options (one-line ConfigError otherwise)."""
    return RunConfig(
        preset=args.preset, seeds=args.seeds, first_seed=args.first_seed, id_seeds=args.id_seeds,
        id_first_seed=args.id_first_seed, agents=parse_agents(str(args.agents)), episodes=args.episodes,
        steps=args.steps, dyna_episodes=args.dyna_episodes, samples=args.samples,
        val_samples=args.val_samples, validation_steps=args.validation_steps,
        window=min(500, max(1, args.validation_steps)), nlarx_scale=args.nlarx_scale,
        scenarios=tuple(args.scenario), shaping=args.shaping, record_noise=args.record_noise,
        record_quant=args.record_quant, supervisor=getattr(args, "supervisor", "off") == "on",
    )
