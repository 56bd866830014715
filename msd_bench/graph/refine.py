"""``bench.py --refine R``: each refinable agent kind refined on the plant node, in real time.

Why in graph: a try is a run on the node, so it is a job of the agent process (the kind's design on
a model artifact, that one learning seed, validated on the node behind the supervisor, the run
written as a bag), as the agents stage's runs are. Nothing of the method is new here: the loop and
the choice are :func:`msd_bench.core.rigs.refine.refine`, the refit is
:func:`msd_bench.app.rig_refine.refit` (the registered fitter on the open-loop records plus the tries,
the simulation-error fit driven by the force the node reported applied), and the open-loop records
are read as the identifier reads them (:func:`msd_bench.app.bag_identification.bag_records`).
``msd-bench rigs --refine`` runs the same loop in-process (docs/rigs.md §Refinement).

Per refinable kind (made on an identified model: the broad kinds, and the PLM through its blend's
refinement) and learning seed:

0. try the open-loop agent: the kind's design on ``models/<model>.json`` for that seed, on the node;
r. refit the model from the open-loop bags plus every try's bag so far, save it, make that seed's
   agent on it and try it (the agent job trains and runs it: a round's policy exists only once its
   try is on the node);
then keep the round whose try was best on the *measured* record (a run the supervisor aborted loses
to any that ran to its end, then the lower SSE), and validate it afresh: one more job on the kept
round's model and seed (a design is deterministic in its seed, so it is the kept policy), whose run
is the refined row. Everything goes under ``refine/<kind>/seed_<s>/`` (``round_<r>/``: the model and
the agent's output with the try's bag; ``fresh/``), the rounds into ``refine/refine.json``, the table
into ``report/refine.md``; run.json carries the summary.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Protocol

from msd_bench.app.agents import agent_kind
from msd_bench.app.config import RunConfig
from msd_bench.app.job import job_document
from msd_bench.core.errors import ConfigError, IdentificationError, MsdBenchError
from msd_bench.core.identification.data import Experiment
from msd_bench.core.rigs.refine import Refined, Try, refine
from msd_bench.graph import supervise
from msd_bench.graph.jobs import JobServer, last_line
from msd_bench.graph.launch import ProcessSet, stop
from msd_bench.io.storage.atomic import write_text_atomic
from msd_msgs_py.interface import PlantInterface

DIR = "refine"
"""The stage's directory under the run directory."""
RESULT = "refine.json"
"""The stage's record, under :data:`DIR`."""
REPORT = "refine.md"
"""The stage's table, under ``report/``."""
MAX_ROUNDS = 10
"""The most rounds a run may ask for (as ``msd-bench rigs --refine``)."""
SUPERVISOR_WAIT_S = 10.0
"""How long after a try's job ends its run event may take to come from the supervisor process."""

Say = Callable[[str], None]
JobArgs = Callable[[str, dict[str, Any]], list[str]]
"""An agent job's name and document → the agent process's arguments (remapped through the supervisor)."""


class RefineError(MsdBenchError):
    """A refinement job failed where the stage cannot go on (the open-loop try or the fresh run)."""


class BenchConfig(Protocol):
    """What this stage reads of ``graph/bench.py: BenchConfig`` (bench.py imports this module)."""

    @property
    def run(self) -> RunConfig: ...
    @property
    def run_dir(self) -> Path: ...
    @property
    def namespace(self) -> str: ...
    @property
    def refine(self) -> int: ...
    @property
    def refine_weight(self) -> int: ...
    @property
    def seeds(self) -> list[int]: ...
    @property
    def supervision(self) -> supervise.Supervision: ...
    @property
    def interface(self) -> PlantInterface: ...
    @property
    def plant_ns(self) -> str | None: ...
    @property
    def realtime(self) -> bool: ...
    @property
    def bags(self) -> Path | None: ...
    @property
    def rig_file(self) -> Path | None: ...


def check(rounds: int, weight: int, plant_ns: str | None, agents: Sequence[str],
          stages: Sequence[str]) -> None:
    """``--refine``'s options, one line each when wrong."""
    from msd_bench.app.rig_refine import refinable

    if not 0 <= rounds <= MAX_ROUNDS:
        raise ConfigError(f"--refine must be in 0..{MAX_ROUNDS}, got {rounds}")
    if not 1 <= weight <= MAX_ROUNDS:
        raise ConfigError(f"--refine-weight must be in 1..{MAX_ROUNDS}, got {weight}")
    if not rounds:
        return
    if plant_ns is None:
        raise ConfigError("--refine tries the agents on a plant node in real time: give --plant-ns")
    if "agents" not in stages:
        raise ConfigError("--refine runs after the agents stage: keep 'agents' in --stages")
    if not any(refinable(k) for k in agents):
        raise ConfigError(f"--refine refits the identified model an agent was made on; none of the run's "
                          f"kinds ({', '.join(agents) or 'none'}) is made on one")


def kinds(cfg: BenchConfig, unmade: Sequence[str]) -> list[str]:
    """The run's kinds refined: made on an identified model, and one the identifier wrote."""
    from msd_bench.app.rig_refine import refinable

    return [k for k in cfg.run.agents if refinable(k) and k not in unmade]


class _Node:
    """The node as the stage uses it: agent jobs on one served process, the supervisor's run events."""

    def __init__(self, cfg: BenchConfig, procs: ProcessSet, job_args: JobArgs) -> None:
        self.cfg = cfg
        self.job_args = job_args
        self.guard = supervise.SupervisorProcess(procs, cfg) if cfg.supervision.validation else None
        self.server = JobServer(procs, "agent.py", "agent")
        if self.guard is not None:
            self.guard.ready()
        self.server.ready()

    def runs(self) -> list[dict[str, Any]]:
        """The supervisor's run events so far ([] without it)."""
        return [] if self.guard is None else list(supervise.stage_record(self.guard.proc.lines)["runs"])

    def run(self, name: str, placement: dict[str, Any]) -> dict[str, Any]:
        """One agent job (train on the placement's model, run on the node); its result and, behind the
        supervisor, the run event it caused (None when the supervisor reported none in time)."""
        before = len(self.runs())
        args = self.job_args(name, job_document("agent", self.cfg.run, placement))
        job = self.server.submit(args, name=name)
        status = job.wait(3600.0)
        if status != 0:
            raise RefineError(f"{name} failed (exit {status}): {last_line(job.lines) or 'no output'}")
        from msd_bench.graph.run_files import read_result

        result = read_result(Path(placement["out_dir"]) / "result.json")
        event = None
        deadline = time.monotonic() + SUPERVISOR_WAIT_S
        while self.guard is not None and time.monotonic() < deadline:
            runs = self.runs()
            if len(runs) > before:
                event = runs[before]
                break
            time.sleep(0.05)
        return {"row": result.per_seed[0], "supervisor": event}

    def close(self) -> dict[str, Any] | None:
        """End the agent process and the supervisor; the supervisor's totals (None without it)."""
        self.server.close()
        if self.guard is None:
            return None
        stop(self.guard.proc)
        return supervise.stage_record(self.guard.proc.lines)


def stage_refine(cfg: BenchConfig, procs: ProcessSet, say: Say, placement: Callable[[str], dict[str, Any]],
                 job_args: JobArgs, unmade: Sequence[str]) -> dict[str, Any]:
    """Every refinable kind refined per learning seed (module docstring); the stage's record, written.

    ``placement(kind)`` is the agents stage's placement of the kind (the drive it was told, the node),
    ``job_args`` turns a job into the agent process's arguments (remapped through the supervisor)."""
    from msd_bench.app.bag_identification import bag_records

    node = _Node(cfg, procs, job_args)
    out: dict[str, Any] = {}
    try:
        for kind in kinds(cfg, unmade):
            surrogate = agent_kind(kind).surrogate
            records = bag_records(_identifier_config(cfg, surrogate))[2]
            base = placement(kind)
            out[kind] = [_one_seed(cfg, node, base, kind, seed, records, say) for seed in cfg.seeds]
    finally:
        totals = node.close()
    doc = {"schema": "msd-bench/bench-refine", "schema_version": 1, "rounds": cfg.refine,
           "refine_weight": cfg.refine_weight, "seeds": list(cfg.seeds), "judged_on": "measured position",
           "supervised": cfg.supervision.validation, "kinds": out,
           "summary": {k: summary(rows) for k, rows in out.items()},
           "supervisor_totals": None if totals is None else totals.get("totals")}
    text = json.dumps(doc, indent=1, default=str) + "\n"
    write_text_atomic(cfg.run_dir / DIR / RESULT, text, root=cfg.run_dir)
    write_text_atomic(cfg.run_dir / "report" / REPORT, table(doc), root=cfg.run_dir)
    return doc


def _identifier_config(cfg: BenchConfig, surrogate: str) -> Any:
    """The identifier's configuration of this run for one model kind (its bags, rate, limits, seed)."""
    from msd_bench.app.bag_identification import IdentifierConfig

    bags = cfg.bags if cfg.bags is not None else cfg.run_dir / "excitation"
    params = job_document("identifier", cfg.run, {"bags_dir": str(bags), "namespace": cfg.namespace,
                                                  "out_dir": str(cfg.run_dir / DIR)},
                          seed=cfg.run.id_first_seed)["params"]
    return IdentifierConfig(**{**params, "models": (surrogate,)})


def _one_seed(cfg: BenchConfig, node: _Node, base: dict[str, Any], kind: str, seed: int, records: Any,
              say: Say) -> dict[str, Any]:
    """One learning seed of ``kind``: the rounds on the node, the choice, the fresh run."""
    from msd_bench.app.bag_identification import closed_loop_record
    from msd_bench.app.rig_refine import refit
    from msd_bench.io.storage import artifacts

    surrogate = agent_kind(kind).surrogate
    home = cfg.run_dir / DIR / kind / f"seed_{seed}"
    tried: dict[str, dict[str, Any]] = {}

    def on_node(model_path: Path, where: Path) -> Path:
        place = {**{k: v for k, v in base.items() if k != "scenarios"}, "seeds": [seed],
                 "out_dir": str(where), "model_path": str(model_path)}
        tried[str(where)] = node.run(f"refine-{kind}-s{seed}-{where.name}", place)
        return where

    def try_(where: Path, r: int) -> Try:
        got = tried[str(where)]
        bag = where / "validation" / f"seed_{seed}"
        record = closed_loop_record(bag, cfg.namespace, cfg.run.plant.dt, f"closed-loop try {r}, seed {seed}")
        event = got["supervisor"] or {}
        say(f"  {kind} seed {seed} round {r}: SSE {got['row']['sse']:.2f} % on the measured position"
            + (f", aborted ({event['aborted']})" if event.get("aborted") else ""))
        return Try(record, float(got["row"]["sse"]), bool(event.get("aborted")), len(record.u),
                   report={"success_measured": bool(got["row"]["success"]), "supervisor": got["supervisor"]})

    rounds: list[Path] = []

    def refit_(tries: Sequence[Experiment]) -> tuple[Path, dict[str, Any]]:
        model, facts = refit(records, tries, cfg.refine_weight, surrogate, cfg.run)
        where = home / f"round_{len(rounds) + 1}"
        prov = artifacts.Provenance(parameters={"refit_of": surrogate, "closed_loop_records": len(tries),
                                                "weight": cfg.refine_weight})
        path = artifacts.save_model(model, where / f"{surrogate}.json", prov, root=cfg.run_dir)
        rounds.append(path)
        return path, facts

    def retrain(path: Path) -> Path:
        try:
            return on_node(path, path.parent)
        except RefineError as exc:  # a design that fails on the refitted model ends the loop, as in-process
            raise ConfigError(str(exc)) from None

    first = on_node(cfg.run_dir / "models" / f"{surrogate}.json", home / "round_0")
    got: Refined[Path] = refine(first, cfg.refine, try_, refit_, retrain, (ConfigError, IdentificationError))
    model = got.policy / f"{surrogate}.json" if got.chosen else cfg.run_dir / "models" / f"{surrogate}.json"
    fresh = on_node(model, home / "fresh")
    row = tried[str(fresh)]
    say(f"  {kind} seed {seed}: kept round {got.chosen}; fresh run SSE {row['row']['sse']:.2f} %")
    runs = [*got.try_runs, (cfg.run.validation_steps, 0)]
    return {"seed": seed, "chosen_round": got.chosen,
            "rounds": [{"round": d.index, "failed": d.failed, "fit": d.fit,
                        **({"sse_measured": d.tried.sse_measured, "aborted": d.tried.aborted,
                            "samples": d.tried.samples, **d.tried.report} if d.tried is not None else {})}
                       for d in got.rounds],
            "fresh": {"sse_measured": float(row["row"]["sse"]),
                      "success_measured": bool(row["row"]["success"]), "supervisor": row["supervisor"]},
            "real_samples": {"records": len(records.broad_train.experiments[0].u)
                             + len(records.broad_val.experiments[0].u),
                             "runs": sum(n for n, _ in runs),
                             "note": "the node's rests are not logged in the real-time path: not counted"}}


def summary(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """A kind's seeds: per round the tries, their successes on the measured position, supervisor aborts
    and overridden commands, and how often it was kept; then the fresh runs' successes."""
    most = max((len(r["rounds"]) for r in rows), default=0)
    per_round = []
    for i in range(most):
        tried = [r["rounds"][i] for r in rows if len(r["rounds"]) > i and "samples" in r["rounds"][i]]
        per_round.append({
            "round": i, "tries": len(tried),
            "failed": sum(1 for r in rows if len(r["rounds"]) > i and r["rounds"][i]["failed"]),
            "successes_measured": sum(bool(t["success_measured"]) for t in tried),
            "aborts": sum(bool(t["aborted"]) for t in tried),
            "overridden": sum(int((t.get("supervisor") or {}).get("overridden", 0)) for t in tried),
            "kept": sum(1 for r in rows if r["chosen_round"] == i)})
    return {"seeds": len(rows), "rounds": per_round,
            "fresh_successes_measured": sum(bool(r["fresh"]["success_measured"]) for r in rows)}


def table(doc: dict[str, Any]) -> str:
    """``report/refine.md``: per kind and round what the tries did, then the fresh runs."""
    lines = ["# Refinement on the node (`--refine`)", "",
             f"Up to {doc['rounds']} round(s), each closed-loop record weighted {doc['refine_weight']}; "
             f"every try and the fresh run {'behind the supervisor' if doc['supervised'] else 'unsupervised'}"
             "; "
             "success judged on the measured position (all a node reports).", "",
             "| kind | round | tries | successes (measured) | aborts | overridden commands | kept |",
             "|---|---|---|---|---|---|---|"]
    for kind, s in doc["summary"].items():
        for r in s["rounds"]:
            lines.append(f"| {kind} | {r['round']} | {r['tries']} | {r['successes_measured']} | "
                         f"{r['aborts']} | {r['overridden']} | {r['kept']} |")
    lines += ["", "| kind | seed | kept round | fresh run SSE (%) | success (measured) |",
              "|---|---|---|---|---|"]
    for kind, rows in doc["kinds"].items():
        for r in rows:
            lines.append(f"| {kind} | {r['seed']} | {r['chosen_round']} | {r['fresh']['sse_measured']:.2f} | "
                         f"{'yes' if r['fresh']['success_measured'] else 'no'} |")
    failed = [f"{kind} seed {r['seed']} round {d['round']}: {d['failed']}"
              for kind, rows in doc["kinds"].items() for r in rows for d in r["rounds"] if d["failed"]]
    if failed:
        lines += ["", "Rounds that made no policy: " + "; ".join(failed) + "."]
    return "\n".join(lines) + "\n"


__all__ = ["DIR", "MAX_ROUNDS", "RefineError", "check", "kinds", "stage_refine", "summary", "table"]
