"""Identification records from bags: ours (self-describing) or a rig's (described by the caller).

Our recorder stores each experiment's parameters in its bag (role, signal,
bias, settle length), so a directory of bags is enough to rebuild the paper's
records. A bag recorded elsewhere (``ros2 bag record`` on a real rig) carries
none of that: the caller names each bag's role and bias and the settle length.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from msd_bench.core.errors import ConfigError
from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.identification.excitation import (
    PrbsConfig,
    SignalConfig,
    config_from_params,
    finite_or_nan,
    signal_from_params,
)
from msd_bench.core.identification.operating_points import plm_biases
from msd_bench.core.identification.records import Records
from msd_bench.core.rigs.hold import HoldLoop, beyond_loop
from msd_bench.core.rigs.scales import DEFAULT_FORCE_LIMIT, Scales
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_interface import ForceSource, read_interface_experiment
from msd_bench.io.bags.bag_recover import RECOVERED_SUFFIX
from msd_bench.io.bags.bag_timing import DEFAULT_DT, IDENTIFY, READ, TimingPolicy
from msd_bench.io.bags.played import confirm_by_effort, locate_from_bag, locate_from_effort, played_signal
from msd_bench.io.bags.reader import BagSamples, missing_metadata, read_samples
from msd_msgs_py.interface import MSD_INTERFACE, PlantInterface


def align_to_played(exp: Experiment, params: Mapping[str, Any], force_limit: float = 10.0,
                    path: str | Path = "") -> Experiment:
    """Cut a real-time recording without its commands to the samples the excitation played.

    The played signal is rebuilt from the bag's parameters and saturated at the
    run's ``force_limit``; the cut is where the recorded effort best matches all
    of it (:func:`msd_bench.io.bags.played.locate_from_effort`; an ambiguous match is a
    BagError naming ``path``). A bag that holds its commands is cut from them
    instead, before it is read (:func:`load_records`). Lock-step bags (exactly the
    played samples) and bags without parameters are returned unchanged.
    """
    signal = signal_from_params(dict(params))
    if signal is None or len(exp) <= signal.size:
        return exp
    cut = locate_from_effort(Path(path or exp.name), exp.u, played_signal(signal, force_limit))
    return exp if cut is None else exp.segment(cut.start, cut.stop)


def _played(role: BagRole, force_limit: float) -> np.ndarray | None:
    """The saturated signal a bag of ours played, if it may need a cut (None: lock-step or foreign)."""
    if role.params is None:
        return None
    signal = signal_from_params(dict(role.params))
    if signal is None or (role.samples is not None and len(role.samples.rows) <= signal.size):
        return None  # exactly the played samples (lock-step), known without reading the bag again
    return played_signal(signal, force_limit)


@dataclass(frozen=True)
class BagRole:
    """What one bag is for."""

    path: Path
    """The rosbag2 bag directory."""
    role: str
    """``train`` or ``validation``."""
    bias: float | None
    """Operating-point force of a PRBS experiment, N; None for the broad record."""
    settle: int
    """Leading samples to drop (the settling segment before the PRBS)."""
    params: Mapping[str, Any] | None = None
    """The experiment parameters stored in the bag (None for a rig's bag)."""
    samples: BagSamples | None = field(default=None, compare=False, repr=False)
    """What :func:`roles_from_dir` read from the bag to find its role: :func:`load_records` identifies
    from it instead of reading the bag a second time (None: read it then)."""


def roles_from_dir(bags_dir: Path, namespace: str = "/msd", dt: float = DEFAULT_DT) -> list[BagRole]:
    """Roles of every bag under ``bags_dir`` that carries our experiment parameters (stamps every ``dt``)."""
    bags_dir = Path(bags_dir)
    if not bags_dir.is_dir():
        raise BagError(f"{bags_dir}: no such bag directory")
    roles = []
    for bag in bag_dirs(bags_dir):
        samples = read_samples(bag, namespace)
        _, params = samples.experiment(replace(READ, dt=dt))
        if "role" in params:
            roles.append(_role_of(bag, params, samples))
    if not roles:
        raise BagError(f"{bags_dir}: no experiment bag with msd-bench parameters found")
    return roles


def stamp_interval(paths: Sequence[Path], namespace: str = "/msd") -> float:
    """The sample time, s, of bags at ``paths`` when a run does not state it: each bag's median
    interval between consecutive stamps, which must agree (bags at two rates are one line naming
    both, never a pooled median no bag has); each bag's stamps are then checked against it as usual."""
    rates: list[tuple[Path, float]] = []
    for p in paths:
        steps = np.diff(np.sort(read_samples(p, namespace).rows.stamps))
        if steps.size == 0 or not np.median(steps) > 0:
            raise BagError(f"{p}: too few distinct stamps to tell the sample time; give dt")
        rates.append((p, float(np.median(steps)) / 1e9))  # divided: 1638400 ns is 0.0016384 s as typed
    if not rates:
        raise BagError("no bag to tell the sample time from; give dt")
    first, dt = rates[0]
    for p, other in rates[1:]:
        if abs(other - dt) > 1e-6 * dt:
            raise BagError(f"bags at two rates: {first} at {1 / dt:.4g} Hz, {p} at {1 / other:.4g} Hz "
                           "(samples are never resampled: record both at one rate, or give dt)")
    return dt


def bag_dirs(bags_dir: Path) -> list[Path]:
    """The bag directories directly under ``bags_dir``, in name order.

    A directory holding an ``.mcap`` but no ``metadata.yaml`` is a killed
    recording: it is an error with the ``bag recover`` hint (skipping it would
    later surface as a confusing "no broad-range bag"), unless its recovered
    twin ``<name>.recovered`` is there, which is then used instead.
    """
    found = []
    for sub in sorted(p for p in bags_dir.iterdir() if p.is_dir()):
        if (sub / "metadata.yaml").exists():
            found.append(sub)
        elif any(sub.glob("*.mcap")):
            twin = sub.with_name(sub.name + RECOVERED_SUFFIX)
            if not (twin / "metadata.yaml").exists():
                raise missing_metadata(sub)
    return found


def _role_of(path: Path, params: Mapping[str, Any], samples: BagSamples) -> BagRole:
    """The bag's role from its stored parameters, every field checked first (:func:`check_params`)."""
    found = check_params(path, params)
    settle = found[0].settle if found is not None and isinstance(found[0], PrbsConfig) else 0
    bias = params.get("bias")
    return BagRole(path, str(params["role"]), None if bias is None else float(bias), settle, params, samples)


def check_params(path: Path, params: Mapping[str, Any]) -> tuple[SignalConfig, int] | None:
    """The signal config and seed of a bag's parameters, or a one-line BagError naming bag and field.

    Why before anything else: these parameters come from a file, and they size
    the signal rebuilt from them (:func:`align_to_played`); the bounds are the
    excitation's own (:func:`msd_bench.core.identification.excitation.config_from_params`).
    """
    role, bias = params.get("role"), params.get("bias")
    if "role" in params and not isinstance(role, str):
        raise BagError(f"bag {path}: parameter role must be a string, got {role!r:.60}")
    if bias is not None and not math.isfinite(finite_or_nan(bias)):
        raise BagError(f"bag {path}: parameter bias must be a finite number or null, got {bias!r:.60}")
    try:
        return config_from_params(params)
    except ConfigError as exc:
        raise BagError(f"bag {path}: parameter {exc}") from None


def explicit_roles(bias_bags: Sequence[str], broad_bag: str, val_bag: str, settle: int) -> list[BagRole]:
    """Roles given by hand, e.g. ``bias_bags=["-10=/data/b1", ...]`` for a rig's bags."""
    roles = []
    for item in bias_bags:
        bias, sep, path = item.partition("=")
        try:
            value = float(bias)
        except ValueError:
            value = float("nan")
        if not sep or not path or value != value:
            raise BagError(f"bias bag {item!r} must look like BIAS=PATH, e.g. -10=/data/bias_m10")
        roles.append(BagRole(Path(path), "train", value, settle))
    if broad_bag:
        roles.append(BagRole(Path(broad_bag), "train", None, 0))
    if val_bag:
        roles.append(BagRole(Path(val_bag), "validation", None, 0))
    return roles


def load_records(roles: Sequence[BagRole], need_plm: bool, namespace: str = "/msd",
                 dt: float = DEFAULT_DT, iface: PlantInterface = MSD_INTERFACE, force_limit: float = 10.0,
                 sources: list[ForceSource] | None = None, force_input: str = "applied",
                 hold: HoldLoop | None = None) -> Records:
    """Read every bag once and assemble the paper's records (one-line BagError if incomplete).

    The sample period comes from each bag's header stamps and must be the run's
    ``dt``: a bag at another rate is an error naming both periods, and bunched or
    missing samples are an error too (:func:`msd_bench.io.bags.bag_timing.check_timing`)
    — never resampled silently. A real-time bag is cut to the played samples
    (:mod:`msd_bench.io.bags.played`: from its recorded commands, else from its effort by
    :func:`align_to_played`; an ambiguous cut is an error naming the bag); its first
    sample need not be at rest at 0 (the fits estimate each record's initial state).
    A record whose force or position is constant after the cut is an error naming
    the bag and the record, before any fit.

    ``iface`` says how the bags' plant showed itself and ``force_input`` how a measured effort's
    input is rebuilt (docs/ros2-control.md §Force); the input each bag gave is appended to
    ``sources`` when given. With the rig's stated ``hold`` loop, each record's input is the force
    applied beyond the loop's (:func:`~msd_bench.core.rigs.hold.beyond_loop`, from the bag's effort and
    measured positions): the records of the *held* system, as ``msd-bench rigs`` plays them.
    """
    data: dict[tuple[str, float | None], IOData] = {}
    timing = replace(IDENTIFY, dt=dt)
    for r in roles:
        exp, src = _played_experiment(r, iface, namespace, timing, force_limit, force_input, hold)
        if sources is not None:
            sources.append(src)
        if r.settle >= len(exp) - 3:
            raise BagError(f"{r.path}: {len(exp)} samples, fewer than the {r.settle} settle samples to drop")
        trimmed = exp.segment(r.settle)  # keeps the truth of an emulator's sensor bag, if any
        _check_excitation(r, trimmed)
        data[(r.role, r.bias)] = IOData((trimmed,), dt, {"bag": str(r.path)})
    for role in ("train", "validation"):
        if (role, None) not in data:
            raise BagError(f"no broad-range {role} bag given (the multilevel record)")
    biases = plm_biases(Scales(force=force_limit / DEFAULT_FORCE_LIMIT))  # the plan's, on this rig
    bias_train = {b: data[("train", b)] for b in biases if ("train", b) in data}
    if need_plm and len(bias_train) != len(biases):
        missing = [b for b in biases if b not in bias_train]
        raise BagError(f"PLM needs training bags at biases {list(biases)}; missing {missing}")
    bias_val = {b: data[("validation", b)] for b in biases if ("validation", b) in data}
    return Records(bias_train, bias_val, data[("train", None)], data[("validation", None)])


def _played_experiment(r: BagRole, iface: PlantInterface, namespace: str, timing: TimingPolicy,
                       force_limit: float, force_input: str,
                       hold: HoldLoop | None = None) -> tuple[Experiment, ForceSource]:
    """One bag's experiment over its played samples, and the force it gave as input (beyond the
    ``hold`` loop's when there is one: the played signal, which the cut is confirmed against)."""
    played = _played(r, force_limit)
    cut = None if played is None else locate_from_bag(r.path, iface, namespace, played, force_limit)
    exp, _, src = read_interface_experiment(r.path, iface, namespace, timing=timing, force_limit=force_limit,
                                            force_input=force_input, samples=r.samples,
                                            played=None if cut is None else cut.rows)
    if hold is not None:
        exp = replace(exp, u=beyond_loop(exp.u, exp.y, hold, timing.dt))
    if cut is not None and iface.effort_is_commanded:  # a measured effort was checked when rebuilt
        confirmed = confirm_by_effort(r.path, cut, exp.u, timing.dt)
        src = replace(src, agreement=confirmed.agreement)  # the drive the bag shows, on either face
    if r.params is not None and cut is None:
        exp = align_to_played(exp, r.params, force_limit, r.path)  # no commands in the bag: by its effort
    return exp, src


def record_name(role: BagRole) -> str:
    """How errors name a record: its role and bias, e.g. ``train record at bias -5 N``."""
    return f"{role.role} record " + ("(broad range)" if role.bias is None else f"at bias {role.bias:g} N")


def _check_excitation(role: BagRole, exp: Experiment) -> None:
    """A record the fits cannot use (constant force or position) is refused here, naming its bag.

    Why here: the fits would refuse it too, but without knowing which bag it came from.
    """
    for what, values in (("force", exp.u), ("position", exp.y)):
        if values.size and float(np.ptp(values)) == 0.0:
            raise BagError(f"bag {role.path} ({record_name(role)}): no excitation: the {what} is constant "
                           f"at {values[0]:g} over its {values.size} samples")
