"""Identification from bags: the identifier's configuration and its one job, without ROS.

The identifier node (:mod:`msd_bench.nodes.identifier_node`) and ``msd-bench identify
--bags`` both run :func:`identify_from_bags`; it lives here, below the nodes, so the
command and the tests call it without rclpy and the node stays a thin adapter.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from msd_bench.app.identification import IdentifyJob, failure_lines, identify_and_write, written
from msd_bench.app.job import shared
from msd_bench.core.errors import ConfigError, IdentificationError
from msd_bench.core.identification.data import Experiment
from msd_bench.core.identification.model_kinds import (
    MODEL_KINDS,
    check_models,
    model_kind,
    needs_bias_records,
)
from msd_bench.core.identification.records import Records
from msd_bench.core.rigs.hold import HoldLoop
from msd_bench.io.bags.bag_interface import FORCE_INPUTS, ForceSource
from msd_bench.io.bags.bag_records import (
    BagRole,
    bag_dirs,
    explicit_roles,
    load_records,
    record_name,
    roles_from_dir,
    stamp_interval,
)
from msd_bench.io.bags.bag_timing import IDENTIFY
from msd_bench.io.bags.drive_file import broad_drive, write_drive
from msd_bench.io.bags.reader import read_experiment
from msd_bench.io.storage import artifacts
from msd_bench.io.storage.atomic import write_text_atomic
from msd_bench.io.storage.paths import writable_dir
from msd_msgs_py.contract import PLANT_NAMESPACE
from msd_msgs_py.interface import MSD_INTERFACE, PlantInterface

FROM_STAMPS = 0.0
"""The identifier's ``dt`` meaning "the median interval between the bags' stamps"."""


@dataclass(frozen=True)
class IdentifierConfig:
    """Which bags to read, which models to fit, where to write them."""

    bags_dir: str = ""
    """Directory of self-describing experiment bags (our recorder's); or use the explicit lists."""
    bias_bags: tuple[str, ...] = ()
    """A rig's PRBS bags as ``BIAS=PATH`` (e.g. ``-10=/data/b_m10``), one per bias of the PLM."""
    broad_bag: str = ""
    """A rig's broad-range (multilevel) training bag, for GLM and NLARX."""
    validation_bag: str = ""
    """A rig's broad-range validation bag (fits are reported on it)."""
    settle_samples: int = field(default=0, metadata={"range": (0, 1_000_000)})
    """Leading samples dropped from each of a rig's bias bags (ours store their own)."""
    models: tuple[str, ...] = tuple(MODEL_KINDS)
    """Surrogates to fit: any registered model kind (glm, plm, nlarx-paper, nlarx-improved, greybox)."""
    seed: int = field(default=0, metadata={"range": (0, 2**31 - 1)})
    """Seed of the NLARX training (same bags + same seed = same model)."""
    stroke: float = field(default=shared("stroke"), metadata={"range": (1e-3, 1e3)})
    """Stroke L of the rig, m: model outputs are projected on [-L/2, L/2]."""
    force: float = field(default=shared("force"), metadata={"range": (1e-3, 1e4)})
    """Actuator limit F of the rig, N (the grey-box model saturates its input there)."""
    nlarx_scale: float = field(default=shared("nlarx_scale"), metadata={"range": (1e-3, 10.0)})
    """Multiplies the NLARX training iterations (< 1 only for smoke runs)."""
    namespace: str = PLANT_NAMESPACE
    """Namespace the bags' topics live under."""
    dt: float = field(default=FROM_STAMPS, metadata={"range": (0.0, 10.0)})
    """The run's sample time, s: every bag's stamps must tick at it (checked, never resampled);
    :data:`FROM_STAMPS` (the default, so a rig's bags need not state it): the median interval
    between the bags' stamps. A bench run's job always gives the run's ``dt``."""
    force_input: str = "applied"
    """Bags whose effort is measured (ros2_control): identify from the commands passed through the
    actuator fitted to the effort (``applied``, the force the msd face reports) or from the commands
    held over each sample (``held``: the models absorb the actuator). docs/ros2-control.md §Force."""
    hold_stiffness: float = field(default=0.0, metadata={"range": (0.0, 1e9)})
    """The rig's stated hold loop (docs/rig-families.md §stage), N/m; 0 with ``hold_damping`` 0: none.
    With a loop the bags' input is the force applied beyond the loop's, recomputed from the same
    measured positions (:func:`~msd_bench.core.rigs.hold.beyond_loop`): the *held* system is identified,
    as ``msd-bench rigs`` identifies it from the records it plays."""
    hold_damping: float = field(default=0.0, metadata={"range": (0.0, 1e9)})
    """The hold loop's damping, N·s/m."""
    hold_position: float = field(default=0.0, metadata={"range": (-1e6, 1e6)})
    """The position the hold loop holds, m."""
    out_dir: str = ""
    """Where ``<model>.json`` and ``fits.json`` are written (required)."""

    def hold(self) -> HoldLoop | None:
        """The stated hold loop, None when both gains are 0."""
        return HoldLoop.from_gains(self.hold_stiffness, self.hold_damping, self.hold_position)

    def __post_init__(self) -> None:
        if not self.out_dir:
            raise ConfigError("out_dir is required")
        if not self.bags_dir and not self.broad_bag:
            raise ConfigError("give bags_dir (our bags) or broad_bag/validation_bag/bias_bags (a rig's)")
        check_models(self.models)
        self.hold()  # a negative gain is one line before any bag is read
        if self.force_input not in FORCE_INPUTS:
            raise ConfigError(f"force_input must be one of {', '.join(FORCE_INPUTS)}, "
                              f"got {self.force_input!r}")


def identify_from_bags(cfg: IdentifierConfig, iface: PlantInterface = MSD_INTERFACE,
                       sources: list[ForceSource] | None = None,
                       on_saved: Callable[[str, Path], None] | None = None,
                       on_failed: Callable[[str, str], None] | None = None) -> dict[str, Any]:
    """Read, fit, write; return the fit reports (shared by the node and the tests).

    ``iface`` is the face the bags were recorded through; which force each bag gave as
    input (its effort, or the commands rebuilt by log time) goes to ``inputs.json`` and,
    when given, to ``sources`` (docs/ros2-control.md §Force). Each model is written
    as soon as it is fitted, then ``on_saved`` hears of it; ``fits.json`` and
    ``inputs.json`` follow the last. A kind that cannot be fitted fails alone (``on_failed``
    hears of it, ``fits.json`` names it): an IdentificationError naming every failed kind
    is raised only once the others are written (:mod:`msd_bench.app.identification`).
    """
    sources = [] if sources is None else sources
    out = writable_dir(cfg.out_dir, "out_dir")  # before the fit: a read-only disk fails at once
    cfg, roles, records = bag_records(cfg, iface, sources)
    written(lambda: write_drive(out, broad_drive(roles, sources)), out)  # before any model: see drive_file
    parameters = {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(cfg).items()}
    parameters["interface"] = iface.as_dict()
    parameters["inputs"] = [s.as_dict() for s in sources]
    prov = artifacts.Provenance(tuple(artifacts.source(r.path) for r in roles), parameters, cfg.seed)
    job = IdentifyJob(cfg.models, cfg.seed, cfg.stroke, cfg.force, cfg.dt, cfg.nlarx_scale)
    done = identify_and_write(records, job, out, prov, on_saved, on_failed)
    written(lambda: _write_inputs(out, iface, sources), out)
    if done.failed:  # after every other kind and fits.json are written: the exit status says it
        raise IdentificationError("; ".join(failure_lines(done.failed, lambda n: _records_of(n, roles)))
                                  + f" (the other kinds are written under {out})")
    return done.fits


def bag_records(cfg: IdentifierConfig, iface: PlantInterface = MSD_INTERFACE,
                sources: list[ForceSource] | None = None) -> tuple[IdentifierConfig, list[BagRole], Records]:
    """The records of ``cfg``'s bags, as the identifier reads them (played cut, timing checked), with
    the configuration (its ``dt`` found from the stamps if not given) and each bag's role: what
    :func:`identify_from_bags` fits, and what ``bench.py --refine`` joins its closed-loop tries to."""
    explicit = [] if cfg.bags_dir else explicit_roles(cfg.bias_bags, cfg.broad_bag, cfg.validation_bag,
                                                      cfg.settle_samples)
    if cfg.dt == FROM_STAMPS:  # the median stamp interval, then checked on every bag as if given
        paths = bag_dirs(Path(cfg.bags_dir)) if cfg.bags_dir else [r.path for r in explicit]
        cfg = replace(cfg, dt=stamp_interval(paths, cfg.namespace))
    roles = roles_from_dir(Path(cfg.bags_dir), cfg.namespace, cfg.dt) if cfg.bags_dir else explicit
    records = load_records(roles, needs_bias_records(cfg.models), cfg.namespace, cfg.dt, iface=iface,
                           force_limit=cfg.force, sources=sources, force_input=cfg.force_input,
                           hold=cfg.hold())
    return cfg, list(roles), records


def closed_loop_record(path: Path, namespace: str, dt: float, name: str) -> Experiment:
    """A closed-loop run's bag as a record a refit can join: the force the node reported applied (its
    ``joint_states`` effort) and the position it measured, stamps checked as an identification
    record's (an agent writes its validation runs so: ``nodes/agent_node.py``)."""
    exp, _ = read_experiment(path, namespace, timing=replace(IDENTIFY, dt=dt))
    return Experiment(exp.u, exp.y, name=name)


def _records_of(model: str, roles: Sequence[BagRole]) -> str:
    """The records (and their bags) a model kind is fitted on and scored against, for its errors."""
    trains = "bias" if model_kind(model).records == "bias" else "broad"
    used = [r for r in roles if (r.role == "validation" and r.bias is None)
            or (r.role == "train" and (r.bias is None) == (trains == "broad"))]
    return "; ".join(f"{record_name(r)} from bag {r.path}" for r in used)


def _write_inputs(out: Path, iface: PlantInterface, sources: list[ForceSource]) -> Path:
    """``inputs.json``: the face the bags were recorded through and each bag's input."""
    inputs = {"interface": iface.as_dict(), "bags": [s.as_dict() for s in sources]}
    return write_text_atomic(out / "inputs.json", json.dumps(artifacts.jsonable(inputs), indent=1) + "\n",
                             root=out)


__all__ = ["FROM_STAMPS", "IdentifierConfig", "bag_records", "closed_loop_record", "identify_from_bags"]
