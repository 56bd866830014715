"""Experiments from bags of any plant interface: our joint picked by name, the force it really got.

On the ``msd`` face with commanded effort a bag row is already an
identification sample (:func:`msd_bench.io.bags.reader.read_experiment`). Any other
face needs two things more (docs/ros2-control.md §Force):

* ``joint_states`` may carry several joints in any order: ours is picked by
  name (:meth:`PlantInterface.pick`);
* when the state's effort is *measured* (a ros2_control rig reports what its
  actuator does: delayed, lagged, noisy), the input is rebuilt from the
  recorded command topic by log time (:func:`msd_bench.core.rigs.actuation.held_commands`);
  the actuator that maps those commands onto the measured effort is fitted
  (:func:`~msd_bench.core.rigs.actuation.effort_agreement`, which also checks that the
  commands drove this joint at all), and by default (``force_input="applied"``)
  the commands are passed through it: the applied force, as the msd face reports
  it, without the effort sensor's noise. ``force_input="held"`` keeps the held
  commands, so the models absorb the actuator.

Every read says which input it used (:class:`ForceSource`), so the identifier
can report it; a measured effort without the command topic in the bag is an
error, not a silent switch to the lagged effort.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from msd_bench.core.errors import InterfaceError, MsdBenchError
from msd_bench.core.identification.data import Experiment
from msd_bench.core.rigs.actuation import EffortAgreement, actuator_force, effort_agreement, held_commands
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_meta import shown
from msd_bench.io.bags.bag_open import open_bag
from msd_bench.io.bags.bag_timing import READ, TimingPolicy, check_timing
from msd_bench.io.bags.bag_writer import typestore
from msd_bench.io.bags.reader import BagSamples, _params, _topic_list, decode_joint_state, read_experiment
from msd_msgs_py.contract import PLANT_NAMESPACE
from msd_msgs_py.interface import MSD_INTERFACE, PlantInterface

FORCE_INPUTS = ("applied", "held")
"""How a measured-effort bag's input is rebuilt: the commands through the fitted actuator, or held."""

MIN_AGREEMENT = 50.0
"""Lowest fit (%) of the measured effort to the rebuilt command that still counts as the same force:
below it the commands did not drive this joint (wrong joint order, another controller) or the
log times are unusable, and identifying from them would fit noise."""


@dataclass(frozen=True)
class ForceSource:
    """Which force an experiment's input ``u`` is, and why it can be trusted."""

    bag: str
    """The bag read."""
    source: str
    """``effort`` (the state's effort field, held over the next sample), ``held`` (the commands
    rebuilt by log time, held over each sample) or ``applied`` (those commands through the actuator
    fitted to the measured effort)."""
    topic: str
    """The topic ``u`` came from."""
    commands: int = 0
    """Commands read (``command`` only)."""
    ignored: int = 0
    """Commands the rig would have refused: non-finite, or the wrong length for the controller."""
    agreement: EffortAgreement | None = None
    """Measured effort against the rebuilt command (``command`` with a measured effort only)."""

    def line(self) -> str:
        """One line for the identifier's log."""
        if self.source == "effort":
            return f"{self.bag}: input = effort of {self.topic} (held over the next sample)"
        how = "held by log time" if self.source == "held" else "by log time through the fitted actuator"
        text = f"{self.bag}: input = commands on {self.topic}, {how} ({self.commands} commands"
        text += f", {self.ignored} refused)" if self.ignored else ")"
        return text + (f"; {self.agreement.line()}" if self.agreement else "")

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form (``inputs.json``)."""
        out = asdict(self)
        out["agreement"] = None if self.agreement is None else asdict(self.agreement)
        return out


def read_interface_experiment(
    path: str | Path,
    iface: PlantInterface = MSD_INTERFACE,
    namespace: str = PLANT_NAMESPACE,
    *,
    timing: TimingPolicy | None = None,
    force_limit: float = 10.0,
    watchdog_s: float = 0.5,
    min_agreement: float = MIN_AGREEMENT,
    force_input: str = "applied",
    samples: BagSamples | None = None,
    played: slice | None = None,
) -> tuple[Experiment, dict[str, Any], ForceSource]:
    """Input and position of our joint from ``<namespace>/joint_states`` (+ commands), in stamp order.

    ``force_limit`` and ``watchdog_s`` are the rig's saturation and watchdog,
    replayed on the rebuilt commands. A measured effort that agrees with them
    by less than ``min_agreement`` % is an error naming both figures. ``force_input``
    (:data:`FORCE_INPUTS`) says how a measured-effort bag's input is rebuilt. ``samples``, what
    :func:`~msd_bench.io.bags.reader.read_samples` already read from this bag under ``namespace``, spares
    the msd face with commanded effort a second read (any other face reads the bag itself).
    ``played`` keeps only those rows (in stamp order): a real-time recording's played samples
    (:mod:`msd_bench.io.bags.played`), so a measured effort is fitted to the commands over them alone.
    """
    path = Path(path)
    state_topic = iface.state.resolve(namespace)
    if iface.contract_rows:
        if samples is not None and samples.path == path and samples.namespace == namespace:
            exp, params = samples.experiment(timing)
        else:
            exp, params = read_experiment(path, namespace, timing=timing)
        if played is not None:
            exp = exp.segment(played.start, played.stop)
        return exp, params, ForceSource(str(path), "effort", state_topic)
    command_topic = iface.command.resolve(namespace)
    with open_bag(path) as reader:
        rows = _state_rows(path, reader, iface, state_topic)
        commands = None if iface.effort_is_commanded else _command_rows(path, reader, iface, command_topic)
        params = _params(path, reader)
    check_timing(path, rows.stamps, READ if timing is None else timing)
    rows = rows.ordered()
    if played is not None:
        rows = _States(rows.stamps[played], rows.log_ns[played], rows.x[played], rows.effort[played])
    if commands is None:
        u, source = rows.effort, ForceSource(str(path), "effort", state_topic)
    else:
        u, source = _rebuilt(path, rows, commands, command_topic, force_limit, watchdog_s, min_agreement,
                             force_input)
    try:
        return Experiment(u=u, y=rows.x, name=str(path)), params, source
    except MsdBenchError as exc:
        raise BagError(f"bag {path}: topic {state_topic}: {exc}") from None


@dataclass(frozen=True)
class _States:
    """Our joint's samples in one bag: header stamps and log times (ns), position and effort."""

    stamps: np.ndarray
    log_ns: np.ndarray
    x: np.ndarray
    effort: np.ndarray

    def ordered(self) -> _States:
        """The samples in stamp order (a bag stores them in log-time order)."""
        o = np.argsort(self.stamps, kind="stable")
        return _States(self.stamps[o], self.log_ns[o], self.x[o], self.effort[o])


def _state_rows(path: Path, reader: Any, iface: PlantInterface, topic: str) -> _States:
    """Our joint's samples from every JointState of ``topic``, in bag order."""
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns:
        raise BagError(f"bag {path} has no topic {topic} (has: {_topic_list(reader)})")
    wrong = [c.msgtype for c in conns if c.msgtype != iface.state.ros_type]
    if wrong:
        raise BagError(f"bag {path}: topic {topic} has type {shown(wrong[0])}, "
                       f"expected {iface.state.ros_type}")
    store = typestore()
    stamps, logs, xs, efforts = [], [], [], []
    for _, log_ns, raw in reader.messages(connections=conns):
        msg = decode_joint_state(store, raw)
        try:
            s = iface.pick(msg.name, msg.position, msg.velocity, msg.effort)
        except InterfaceError as exc:
            raise BagError(f"bag {path}: topic {topic}: {exc}") from None
        stamps.append(msg.stamp_ns)
        logs.append(int(log_ns))
        xs.append(s.position)
        efforts.append(s.effort)
    if not stamps:
        raise BagError(f"bag {path}: topic {topic} has no messages")
    return _States(np.asarray(stamps, dtype=np.int64), np.asarray(logs, dtype=np.int64),
                   np.asarray(xs, dtype=np.float64), np.asarray(efforts, dtype=np.float64))


_Commands = tuple[np.ndarray, np.ndarray, int]
"""(log ns, our joint's force or NaN where refused, refused count) of a command topic."""


def _command_rows(path: Path, reader: Any, iface: PlantInterface, topic: str) -> _Commands:
    """(log ns, our joint's force or NaN if refused) of every command, and how many were refused."""
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns:
        raise BagError(
            f"bag {path} has no command topic {topic} (has: {_topic_list(reader)}): the state's effort is "
            f"measured, so the applied force must be rebuilt from the commands; record {topic} too, "
            f"or pass --effort commanded to identify from the measured effort")
    wrong = [c.msgtype for c in conns if c.msgtype != iface.command.ros_type]
    if wrong:
        raise BagError(f"bag {path}: topic {topic} has type {shown(wrong[0])}, "
                       f"expected {iface.command.ros_type}")
    store = typestore()
    times, forces = [], []
    for _, log_ns, raw in reader.messages(connections=conns):
        msg: Any = store.deserialize_cdr(raw, iface.command.ros_type)
        data = msg.data
        values = [float(data)] if np.ndim(data) == 0 else [float(v) for v in data]
        force = iface.command_force(values)
        times.append(int(log_ns))
        forces.append(np.nan if force is None else force)
    f = np.asarray(forces, dtype=np.float64)
    return np.asarray(times, dtype=np.int64), f, int(np.count_nonzero(~np.isfinite(f)))


def _rebuilt(path: Path, rows: _States, commands: _Commands, topic: str,
             force_limit: float, watchdog_s: float, min_agreement: float,
             force_input: str) -> tuple[np.ndarray, ForceSource]:
    """The force per sample from the commands (held, or through the fitted actuator), checked."""
    if force_input not in FORCE_INPUTS:
        raise BagError(f"force input must be one of {', '.join(FORCE_INPUTS)}, got {force_input!r}")
    cmd_ns, cmd_f, refused = commands
    u = held_commands(rows.log_ns, cmd_ns, cmd_f, force_limit=force_limit, watchdog_s=watchdog_s)
    effort = rows.effort
    dt = float(np.median(np.diff(rows.stamps))) / 1e9 if rows.stamps.size > 1 else 0.01
    agreement = None
    if np.isfinite(effort).any():
        try:
            agreement = effort_agreement(u, effort, dt)
        except MsdBenchError as exc:
            raise BagError(f"bag {path}: cannot check the rebuilt force against the measured "
                           f"effort: {exc}") from None
        if agreement.fit_percent < min_agreement:
            raise BagError(
                f"bag {path}: the commands on {topic} do not explain the measured effort (fit "
                f"{agreement.fit_percent:.1f} % < {min_agreement:.0f} %): check --controller-joints order, "
                f"--controller and --joint")
    if force_input == "held":
        return u, ForceSource(str(path), "held", topic, int(cmd_ns.size), refused, agreement)
    if agreement is None:
        raise BagError(f"bag {path}: joint_states carries no effort to fit the actuator to; "
                       f"identify from the held commands (force_input held) instead")
    applied = actuator_force(u, agreement.delay_samples, agreement.time_constant_s, dt)
    return applied, ForceSource(str(path), "applied", topic, int(cmd_ns.size), refused, agreement)
