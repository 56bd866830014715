"""bench.py's command line and its run: options → :class:`BenchConfig` → stages → Table 1.

``launch_scripts/bench.py`` only calls :func:`main`; everything it does lives
here, beside the stages, so the run can be driven from tests and benchmarks.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import sys
from pathlib import Path
from typing import Any

from msd_bench.app.options import add_run_arguments, run_config_from_args
from msd_bench.core.errors import MsdBenchError
from msd_bench.graph.bench import (
    STAGES,
    BenchConfig,
    stage_agents,
    stage_identify,
    stage_names,
    stage_record,
    start_plant,
    timed,
    write_run_facts,
)
from msd_bench.graph.domains import claim_domain
from msd_bench.graph.launch import process_group, stop
from msd_bench.io.bag_records import roles_from_dir
from msd_bench.io.paths import writable_dir
from msd_bench.progress import StageProgress

REPO = Path(__file__).resolve().parents[2]
BENCH_DEFAULTS: dict[str, Any] = {"seeds": 3, "dyna_episodes": 5, "val_samples": 2_000}
"""bench.py's defaults where they differ from the paper's budgets (every stage is a process)."""


def parse(argv: list[str]) -> argparse.Namespace:
    """Command-line options."""
    p = argparse.ArgumentParser(prog="bench.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    add_run_arguments(p, **BENCH_DEFAULTS)
    p.add_argument("--out", type=Path, help="run directory (default bags/<run-id>)")
    p.add_argument("--bags", type=Path, help="identify from these experiment bags instead of recording")
    p.add_argument("--stages", default=",".join(STAGES), help=f"subset of {','.join(STAGES)}")
    p.add_argument("--realtime", action="store_true", help="run the plant at true 100 Hz (slow)")
    p.add_argument("--via-ros", action="store_true",
                   help="train over surrogate nodes in lock-step instead of in-process (slow)")
    p.add_argument("--domain-id", type=int, help="ROS_DOMAIN_ID of the run (default: a random one)")
    return p.parse_args(argv)


def config(args: argparse.Namespace) -> BenchConfig:
    """The run's configuration from the options."""
    # relative paths mean the caller's directory (children run in the repository)
    run_dir = (args.out or REPO / "bags" / dt.datetime.now().strftime("%Y%m%d-%H%M%S")).absolute()
    stages = stage_names([s.strip() for s in args.stages.split(",")])
    return BenchConfig(
        run_dir=Path(run_dir), run=run_config_from_args(args), realtime=args.realtime,
        via_ros=args.via_ros, bags=args.bags.absolute() if args.bags else None,
        stages=stages or tuple(args.stages.split(",")))


def say(line: str) -> None:
    """Progress line on stderr."""
    print(f"[bench] {line}", file=sys.stderr, flush=True)


def write_plant_model(cfg: BenchConfig) -> None:
    """The emulator's own model, for the on-plant reference agent (not identified)."""
    from msd_bench.core.model import plant_model
    from msd_bench.io import artifacts

    path = cfg.run_dir / "models" / "plant.json"
    if not path.exists():
        prov = artifacts.Provenance(parameters={"preset": cfg.run.preset, "note": "the emulator itself"})
        artifacts.save_model(plant_model(cfg.run.plant), path, prov)


def run_graph_stages(cfg: BenchConfig) -> None:
    """record → identify → agents, each through node processes, the plant started once.

    With a sensor (``--record-noise``/``--record-quant``) the plant records
    through it, then is restarted ideal for the agents (validated on the true
    plant, as in ``msd-bench paper``).
    """
    recording = "record" in cfg.stages and cfg.bags is None
    sensor = recording and cfg.run.sensor is not None
    with process_group() as procs:
        plant = None
        if "record" in cfg.stages or "agents" in cfg.stages:
            plant = timed(cfg, "plant_start", lambda: start_plant(procs, cfg, sensor))
        if recording:
            with StageProgress("record") as bar:
                timed(cfg, "record", lambda: stage_record(cfg, procs, lambda d, t, n: bar.update(n, d, t)))
        if "identify" in cfg.stages:
            say("identifying surrogates (identifier node)")
            fits = timed(cfg, "identify", lambda: stage_identify(cfg, procs))
            for name, f in fits.items():
                truth = "" if f.get("sim_fit_truth") is None else f" ({f['sim_fit_truth']:.1f} % vs truth)"
                say(f"  {name}: fit {f['sim_fit']:.1f} % simulation{truth}, "
                    f"{f['one_step_fit']:.2f} % one-step")
            write_plant_model(cfg)
        if "agents" in cfg.stages:
            if sensor and plant is not None:
                stop(plant)
                timed(cfg, "plant_restart", lambda: start_plant(procs, cfg, sensor=False))
            with StageProgress("agents") as bar:
                def agents_bar(done: int, total: int, name: str) -> None:
                    bar.update(name, done, total)

                timed(cfg, "agents", lambda: stage_agents(cfg, procs, say, agents_bar))


def run(cfg: BenchConfig) -> int:
    """All requested stages; prints Table 1 and where the report is."""
    writable_dir(cfg.run_dir, "--out")
    if cfg.bags is not None and "identify" in cfg.stages:
        roles_from_dir(cfg.bags)  # a killed or badly timed bag is one line now, not after the stage starts
    say(f"run directory {cfg.run_dir}  (ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']})")
    if any(s in cfg.stages for s in ("record", "identify", "agents")):
        run_graph_stages(cfg)
    facts = {"preset": cfg.run.preset, "seeds": len(cfg.seeds), "window": cfg.run.window,
             "mode": "ros-graph", "lockstep": not cfg.realtime, "stage_seconds": cfg.timings,
             "agents": list(cfg.run.agents)}
    if "report" in cfg.stages:
        from msd_bench.graph.bench_report import write_bench_report

        paths = timed(cfg, "report", lambda: write_bench_report(cfg, facts))
        print(paths["table"]["md"].read_text())
        print(paths["robustness"]["md"].read_text())
        say(f"report: {paths['table']['md'].parent}")
    write_run_facts(cfg, {"ros_domain_id": int(os.environ["ROS_DOMAIN_ID"])})
    say("stage seconds: " + ", ".join(f"{k} {v:.1f}" for k, v in cfg.timings.items()))
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point: one-line errors, exit 2 on a user mistake, 130 on Ctrl-C."""
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    try:
        args = parse(sys.argv[1:] if argv is None else argv)
        domain, _lock = claim_domain(args.domain_id)  # held until the process ends
        os.environ["ROS_DOMAIN_ID"] = str(domain)
        return run(config(args))
    except MsdBenchError as exc:
        print(f"bench: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("bench: interrupted; node processes stopped", file=sys.stderr)
        return 130
