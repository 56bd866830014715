"""The main job: the paper on the emulated ROS 2 bench, every stage a real node process.

    python launch_scripts/bench.py                  # lock-step, 3 seeds, report under bags/<run-id>/
    python launch_scripts/bench.py --seeds 20 --realtime
    python launch_scripts/bench.py --bags bags/<old-run>/excitation --stages identify,agents,report
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from msd_bench.core.agents import AGENT_KINDS
from msd_bench.core.errors import MsdBenchError
from msd_bench.core.model import plant_model
from msd_bench.core.plant import preset
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
from msd_bench.graph.bench_report import write_bench_report
from msd_bench.graph.domains import claim_domain
from msd_bench.io import artifacts
from msd_bench.io.bag_records import roles_from_dir
from msd_bench.io.paths import writable_dir
from msd_bench.launch import process_group
from msd_bench.progress import StageProgress

REPO = Path(__file__).resolve().parents[1]


def parse(argv: list[str]) -> argparse.Namespace:
    """Command-line options."""
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seeds", type=int, default=3,
                   help="learning seeds per agent kind (3; `msd-bench paper` runs many seeds in-process)")
    p.add_argument("--first-seed", type=int, default=0, help="first learning seed (0)")
    p.add_argument("--out", type=Path, help="run directory (default bags/<run-id>)")
    p.add_argument("--bags", type=Path, help="identify from these experiment bags instead of recording")
    p.add_argument("--stages", default=",".join(STAGES), help=f"subset of {','.join(STAGES)}")
    p.add_argument("--realtime", action="store_true", help="run the plant at true 100 Hz (slow)")
    p.add_argument("--via-ros", action="store_true",
                   help="train over surrogate nodes in lock-step instead of in-process (slow)")
    p.add_argument("--preset", default="default", help="plant preset: default or mild")
    p.add_argument("--agents", default=",".join(AGENT_KINDS), help="comma-separated agent kinds")
    p.add_argument("--episodes", type=int, default=300, help="training episodes per agent (300)")
    p.add_argument("--dyna-episodes", type=int, default=5,
                   help="Dyna-Q episodes on the plant node (paper: 300; default 5 to keep the run short)")
    p.add_argument("--samples", type=int, default=12_000, help="samples per identification record")
    p.add_argument("--val-samples", type=int, default=2_000, help="samples per validation record (2000)")
    p.add_argument("--validation-steps", type=int, default=3000,
                   help="closed-loop validation steps on the plant (paper: 3000)")
    p.add_argument("--nlarx-scale", type=float, default=1.0, help="NLARX training iterations multiplier")
    p.add_argument("--domain-id", type=int, help="ROS_DOMAIN_ID of the run (default: a random one)")
    return p.parse_args(argv)


def config(args: argparse.Namespace) -> BenchConfig:
    """The run's configuration from the options."""
    preset(args.preset)
    # relative paths mean the caller's directory (children run in the repository)
    run_dir = (args.out or REPO / "bags" / dt.datetime.now().strftime("%Y%m%d-%H%M%S")).absolute()
    if args.seeds < 1:
        raise MsdBenchError(f"--seeds must be >= 1, got {args.seeds}")
    stages = stage_names([s.strip() for s in args.stages.split(",")])
    return BenchConfig(
        run_dir=Path(run_dir), preset=args.preset,
        seeds=tuple(range(args.first_seed, args.first_seed + args.seeds)),
        agents=tuple(a.strip() for a in args.agents.split(",") if a.strip()),
        episodes=args.episodes, dyna_episodes=args.dyna_episodes, samples=args.samples,
        val_samples=args.val_samples, nlarx_scale=args.nlarx_scale, realtime=args.realtime,
        via_ros=args.via_ros, bags=args.bags.absolute() if args.bags else None,
        stages=stages or tuple(args.stages.split(",")),
        validation_steps=args.validation_steps,
    )


def say(line: str) -> None:
    """Progress line on stderr."""
    print(f"[bench] {line}", file=sys.stderr, flush=True)


def write_plant_model(cfg: BenchConfig) -> None:
    """The emulator's own model, for the on-plant reference agent (not identified)."""
    path = cfg.run_dir / "models" / "plant.json"
    if not path.exists():
        prov = artifacts.Provenance(parameters={"preset": cfg.preset, "note": "the emulator itself"})
        artifacts.save_model(plant_model(preset(cfg.preset)), path, prov)


def run(cfg: BenchConfig) -> int:
    """All requested stages; prints Table 1 and where the report is."""
    writable_dir(cfg.run_dir, "--out")
    if cfg.bags is not None and "identify" in cfg.stages:
        roles_from_dir(cfg.bags)  # a killed or badly timed bag is one line now, not after the stage starts
    say(f"run directory {cfg.run_dir}  (ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']})")
    needs_graph = any(s in cfg.stages for s in ("record", "identify", "agents"))
    with process_group() as procs:
        if needs_graph and ("record" in cfg.stages or "agents" in cfg.stages):
            timed(cfg, "plant_start", lambda: start_plant(procs, cfg))
        if "record" in cfg.stages and cfg.bags is None:
            with StageProgress("record") as bar:
                timed(cfg, "record", lambda: stage_record(cfg, procs, lambda d, t, n: bar.update(n, d, t)))
        if "identify" in cfg.stages:
            say("identifying surrogates (identifier node)")
            fits = timed(cfg, "identify", lambda: stage_identify(cfg, procs))
            for name, f in fits.items():
                say(f"  {name}: fit {f['sim_fit']:.1f} % simulation, {f['one_step_fit']:.2f} % one-step")
            write_plant_model(cfg)
        if "agents" in cfg.stages:
            with StageProgress("agents") as bar:
                def agents_bar(done: int, total: int, name: str) -> None:
                    bar.update(name, done, total)

                timed(cfg, "agents", lambda: stage_agents(cfg, procs, say, agents_bar))
    facts = {"preset": cfg.preset, "seeds": len(cfg.seeds), "window": cfg.window, "mode": "ros-graph",
             "lockstep": not cfg.realtime, "stage_seconds": cfg.timings, "agents": list(cfg.agents)}
    if "report" in cfg.stages:
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


if __name__ == "__main__":
    sys.exit(main())
