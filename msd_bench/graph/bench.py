"""The main job on the emulated bench: every stage runs through real node processes.

Stages (``--stages`` picks a subset; each reads what the previous wrote under
the run directory, so a run can be resumed or re-reported):

``record``   plant (lock-step or real-time) + recorder + excitation processes
             write one bag per experiment under ``excitation/``;
``identify`` the identifier process fits GLM / PLM / NLARX from those bags
             into ``models/`` (or from ``--bags DIR``);
``agents``   one agent process per agent kind trains (in-process on the model
             artifact by default, over a surrogate node with ``--via-ros``, or
             Dyna-Q against the plant node) and validates every seed on the
             plant topics, writing ``agents/<kind>/`` (Q-tables, bags, result);
``report``   Table 1 (Markdown, CSV, JSON) and the figures under ``report/``.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from msd_bench.core.agents import AGENT_KINDS, SURROGATES, check_agents
from msd_bench.core.errors import ConfigError, MsdBenchError
from msd_bench.graph.record import paper_plan, record_experiments
from msd_bench.launch import NodeProcess, ProcessSet
from msd_msgs_py.contract import PLANT_NAMESPACE

STAGES = ("record", "identify", "agents", "report")


class StageError(MsdBenchError):
    """A stage's process failed; the message names it and quotes its last output line."""


@dataclass(frozen=True)
class BenchConfig:
    """One run of ``launch_scripts/bench.py``."""

    run_dir: Path
    """Everything of the run goes here (``bags/<run-id>`` by default)."""
    preset: str = "default"
    """Plant preset of the emulated plant."""
    seeds: tuple[int, ...] = (0, 1, 2)
    """Learning seeds per agent kind."""
    agents: tuple[str, ...] = tuple(AGENT_KINDS)
    """Agent kinds (Table 1 rows)."""
    episodes: int = 300
    """Training episodes (paper: 300)."""
    dyna_episodes: int = 5
    """Dyna-Q episodes; every step is a real interaction with the plant node (paper: 300)."""
    samples: int = 12_000
    """Samples per identification record (paper: 12,000)."""
    val_samples: int = 2_000
    """Samples per validation record."""
    plan_seed: int = 1
    """Seed of the excitation plan."""
    nlarx_scale: float = 1.0
    """NLARX training iterations multiplier (< 1 only for smoke runs)."""
    realtime: bool = False
    """Run the plant at true 100 Hz instead of lock-step."""
    via_ros: bool = False
    """Train agents over surrogate nodes' topics instead of in-process."""
    bags: Path | None = None
    """Identify from these existing experiment bags instead of recording."""
    stages: tuple[str, ...] = STAGES
    """Stages to run."""
    validation_steps: int = 3000
    """Closed-loop validation length on the plant (paper: 3,000)."""
    timings: dict[str, float] = field(default_factory=dict, compare=False)
    """Seconds per stage, filled in as the run goes."""

    def __post_init__(self) -> None:
        unknown = [s for s in self.stages if s not in STAGES]
        if unknown:
            raise ConfigError(f"unknown stage {unknown[0]!r}; choose from {', '.join(STAGES)}")
        check_agents(self.agents)
        if not self.seeds:
            raise ConfigError("need at least one seed")

    @property
    def excitation_dir(self) -> Path:
        """Where the experiment bags are (recorded here, or given with --bags)."""
        return self.bags if self.bags is not None else self.run_dir / "excitation"

    @property
    def window(self) -> int:
        """Terminal SSE window: the last 500 samples (or the whole run if shorter)."""
        return min(500, self.validation_steps)

    def surrogates(self) -> list[str]:
        """Surrogates the requested agents need."""
        need = {AGENT_KINDS[a].surrogate for a in self.agents}
        return [s for s in SURROGATES if s in need]


Say = Callable[[str], None]


def plant_args(cfg: BenchConfig) -> list[str]:
    """ROS arguments of the emulated plant process."""
    return ["-p", f"preset:={cfg.preset}", "-p", f"lockstep:={str(not cfg.realtime).lower()}"]


def start_plant(procs: ProcessSet, cfg: BenchConfig) -> NodeProcess:
    """Start the plant and wait until it says it is ready."""
    proc = procs.start("plant.py", plant_args(cfg), name="plant")
    proc.wait_for_line(r"ready \(", timeout=60.0)
    return proc


def stage_record(cfg: BenchConfig, procs: ProcessSet, bar: Callable[[int, int, str], None]) -> list[Path]:
    """Record the paper's experiments through the recorder and excitation processes."""
    plan = paper_plan(cfg.plan_seed, cfg.samples, cfg.val_samples)
    return record_experiments(plan, cfg.excitation_dir, procs, PLANT_NAMESPACE, not cfg.realtime, bar)


def stage_identify(cfg: BenchConfig, procs: ProcessSet) -> dict[str, Any]:
    """Fit the surrogates from the bags in the identifier process."""
    models = "[" + ",".join(cfg.surrogates()) + "]"
    args = ["-p", f"bags_dir:={cfg.excitation_dir}", "-p", f"out_dir:={cfg.run_dir / 'models'}",
            "-p", f"models:={models}", "-p", f"nlarx_scale:={float(cfg.nlarx_scale)!r}"]
    _run_to_end(procs.start("identifier.py", args, name="identifier"), timeout=600.0)
    return json.loads((cfg.run_dir / "models" / "fits.json").read_text())  # type: ignore[no-any-return]


def agent_args(cfg: BenchConfig, kind: str) -> list[str]:
    """ROS arguments of the agent process of one agent kind."""
    k = AGENT_KINDS[kind]
    seeds = "[" + ",".join(str(s) for s in cfg.seeds) + "]"
    args = ["-p", f"kind:={kind}", "-p", f"agent:={k.agent}", "-p", f"seeds:={seeds}",
            "-p", f"out_dir:={cfg.run_dir / 'agents' / kind}",
            "-p", f"lockstep:={str(not cfg.realtime).lower()}",
            "-p", f"validation_steps:={cfg.validation_steps}", "-p", f"window:={cfg.window}"]
    if k.dyna:
        return [*args, "-p", "dyna:=true", "-p", f"episodes:={cfg.dyna_episodes}"]
    if k.surrogate == "plant":  # on-plant Q-learning: the plant's own model, in-process
        return [*args, "-p", f"model_path:={cfg.run_dir / 'models' / 'plant.json'}",
                "-p", f"episodes:={cfg.episodes}"]
    args += ["-p", f"model_path:={cfg.run_dir / 'models' / (k.surrogate + '.json')}",
             "-p", f"episodes:={cfg.episodes}"]
    if cfg.via_ros:
        args += ["-p", "via_ros:=true", "-p", f"surrogate_ns:=/surrogate/{k.surrogate}"]
    return args


def stage_agents(cfg: BenchConfig, procs: ProcessSet, say: Say, bar: Callable[[int, int, str], None]) -> None:
    """One agent process per kind, one after another (they share the plant)."""
    if cfg.via_ros:
        for name in {AGENT_KINDS[a].surrogate for a in cfg.agents} - {"plant"}:
            p = procs.start("surrogate.py", ["-p", f"model_path:={cfg.run_dir / 'models' / (name + '.json')}",
                                              "-p", "lockstep:=true", "-r", f"__ns:=/surrogate/{name}"],
                            name=f"surrogate-{name}")
            p.wait_for_line(r"ready \(", timeout=60.0)
    for i, kind in enumerate(cfg.agents):
        bar(i, len(cfg.agents), kind)
        proc = procs.start("agent.py", agent_args(cfg, kind), name=f"agent-{kind}")
        _run_to_end(proc, timeout=3600.0)
        say(_last_line(proc, "agent done") or f"agent {kind} done")
    bar(len(cfg.agents), len(cfg.agents), "done")


def _run_to_end(proc: NodeProcess, timeout: float) -> None:
    status = proc.wait(timeout)
    if status != 0:
        raise StageError(f"{proc.name} failed (exit {status}): {_last_line(proc) or 'no output'}")


def _last_line(proc: NodeProcess, contains: str = "") -> str:
    lines = [ln for ln in proc.lines if contains in ln and ln.strip()]
    return lines[-1].strip() if lines else ""


def write_run_facts(cfg: BenchConfig, extra: dict[str, Any]) -> Path:
    """``run.json``: the configuration, the stage timings and anything else worth keeping."""
    path = cfg.run_dir / "run.json"
    previous = json.loads(path.read_text()) if path.is_file() else {}
    doc = {k: (str(v) if isinstance(v, Path) else v) for k, v in asdict(cfg).items()}
    doc["timings"] = {**previous.get("timings", {}), **cfg.timings}
    doc.update(extra)
    path.write_text(json.dumps(doc, indent=1, default=str) + "\n")
    return path


def stage_names(stages: Sequence[str]) -> tuple[str, ...]:
    """Stages in their fixed order."""
    return tuple(s for s in STAGES if s in stages)


def timed(cfg: BenchConfig, name: str, fn: Callable[[], Any]) -> Any:
    """Run a stage and remember its wall time."""
    t0 = time.perf_counter()
    try:
        return fn()
    finally:
        cfg.timings[name] = round(time.perf_counter() - t0, 2)
