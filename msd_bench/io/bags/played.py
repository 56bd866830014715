"""Where a real-time recording's played samples are: found from the commands the excitation sent.

A real-time recorder runs from before the first command to after the last, so
its bag holds more than the experiment: first whatever the plant still did
when the recorder started (the previous experiment's last command until the
watchdog, 20-30 samples), then the rest (zero force until still, up to
thousands of samples), then the played signal, then a tail. The first non-zero
effort is therefore no marker of the experiment's start.

What the excitation knows is what it sent: after the rest's zero commands it
sends exactly the ``N`` commands of its signal on the command topic, which the
recorder stores beside ``joint_states`` (on every face, in real time). So:

* the last ``N`` recorded commands must be the signal rebuilt from the bag's
  parameters, saturated at the run's force limit (exactly: the values travel
  as float64), or the cut is refused;
* the first played sample is the first ``joint_states`` row logged after the
  first played command, and the cut runs to the row that holds the last one
  (the plant holds the newest command over each step: the rule of
  :func:`~msd_bench.core.rigs.actuation.held_commands`, which the ros2_control
  reader already uses). The cut holds ``N`` samples, more when the
  excitation's timer fell behind: on a loaded machine its 600 commands were
  held over up to 736 samples, and what the node applied over them is the
  record (the effort, or the commands held at each sample) whatever the
  planned timing was;
* the recorded effort over the cut must follow the commands held there: the
  actuator fitted between them (:func:`~msd_bench.core.rigs.actuation.effort_agreement`)
  must explain it by :data:`MIN_AGREEMENT` % or more, which a cut off by more
  than a few samples fails.

Anything else is refused with one line naming the bag, never guessed.

A bag without the command topic (recorded before the msd face recorded it) is
cut where its effort best matches the played signal over the whole signal
(least squares over every offset), and refused when that match is poor or a
distant offset matches about as well.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.rigs.actuation import EffortAgreement, effort_agreement, held_commands
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_interface import MIN_AGREEMENT, _command_rows
from msd_bench.io.bags.bag_meta import shown
from msd_bench.io.bags.bag_open import READ_ERRORS, open_bag
from msd_bench.io.bags.bag_writer import leading_stamp
from msd_msgs_py.interface import PlantInterface

MIN_EFFORT_FIT = 50.0
"""Least fit (%) of the recorded effort to the played signal for a cut found from the effort alone
(a bag without commands): as the ros2_control reader's agreement threshold."""

ALIKE = 1.1
"""A cut from the effort is ambiguous when an offset more than :data:`NEAR` samples from the best
leaves at most this many times the best one's squared error (a signal that looks the same shifted)."""

NEAR = 3
"""Offsets this close to the best one are the same cut, seen through an actuator's delay and lag."""


@dataclass(frozen=True)
class PlayedCut:
    """The played samples of one real-time bag: rows ``[start, stop)`` in stamp order."""

    start: int
    """First played sample."""
    stop: int
    """One past the last played sample (``start`` + the signal's length, or more: module docstring)."""
    found_by: str
    """``commands`` (the recorded command topic) or ``effort`` (a bag without it)."""
    match: float
    """How well the recorded effort follows the cut, %: the fitted actuator's fit to the commands
    held there (``commands``, NaN until :func:`confirm_by_effort`), or the effort's fit to the
    played signal (``effort``)."""
    topic: str = ""
    """The command topic the cut was found from (``commands``)."""
    held: np.ndarray | None = field(default=None, compare=False, repr=False)
    """The commands held at each sample of the cut (``commands``)."""
    agreement: EffortAgreement | None = field(default=None, compare=False)
    """The actuator fitted between the held commands and the effort (:func:`confirm_by_effort`): what
    the records show of the drive (delay, lag), which a design may be told."""

    @property
    def rows(self) -> slice:
        """The played rows, for slicing arrays in stamp order."""
        return slice(self.start, self.stop)


def played_signal(signal: np.ndarray, force_limit: float) -> np.ndarray:
    """What the plant applies of ``signal``: saturated at the run's force limit."""
    return np.clip(np.asarray(signal, dtype=np.float64), -force_limit, force_limit)


def locate_from_bag(path: Path, iface: PlantInterface, namespace: str, played: np.ndarray,
                    force_limit: float) -> PlayedCut | None:
    """The cut of a real-time bag from its recorded commands (one-line BagError if it is ambiguous).

    None when the bag needs no cut (no more rows than played: a lock-step bag) or holds no
    command (then :func:`locate_from_effort` is the fallback). Reads log times and stamps only
    (no message is decoded but the commands); :func:`confirm_by_effort` then checks the cut
    against the effort the caller read.
    """
    row_log, commands = _log_times(path, iface, namespace)
    if row_log.size <= played.size or commands is None:
        return None
    return locate_from_commands(path, iface.command.resolve(namespace), row_log, commands, played,
                                force_limit)


def _log_times(path: Path, iface: PlantInterface,
               namespace: str) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
    """Log times of the state rows (in stamp order) and (log ns, force) of the commands, if any."""
    try:
        return _read_log_times(path, iface, namespace)
    except READ_ERRORS as exc:
        raise BagError(f"bag {path}: unreadable while locating the played samples "
                       f"({shown(str(exc))})") from None


def _read_log_times(path: Path, iface: PlantInterface,
                    namespace: str) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
    state, command = iface.state.resolve(namespace), iface.command.resolve(namespace)
    with open_bag(path) as reader:
        conns = [c for c in reader.connections if c.topic == state]
        stamps, logs = [], []
        for _, log_ns, raw in reader.messages(connections=conns):
            stamps.append(leading_stamp(iface.state.ros_type, raw) or 0)
            logs.append(int(log_ns))
        commands = None
        if any(c.topic == command for c in reader.connections):
            cmd_ns, cmd_f, _ = _command_rows(path, reader, iface, command)
            commands = (cmd_ns, cmd_f) if cmd_ns.size else None  # a topic with no message: none
    order = np.argsort(np.asarray(stamps, dtype=np.int64), kind="stable")
    return np.asarray(logs, dtype=np.int64)[order], commands


def locate_from_commands(path: Path, topic: str, row_log: np.ndarray,
                         commands: tuple[np.ndarray, np.ndarray], played: np.ndarray,
                         force_limit: float) -> PlayedCut:
    """The cut from the commands: the last ``played.size`` of them are the signal (module docstring)."""
    n = played.size
    order = np.argsort(commands[0], kind="stable")
    cmd_ns, cmd_force = commands[0][order], commands[1][order]
    if cmd_ns.size < n:
        raise BagError(f"bag {path}: {cmd_ns.size} commands on {topic}, fewer than the {n} the excitation "
                       f"played: cannot tell where the played samples start")
    sent = np.clip(cmd_force[-n:], -force_limit, force_limit)
    wrong = np.flatnonzero(~(sent == played))
    if wrong.size:
        k = int(wrong[0])
        raise BagError(f"bag {path}: the last {n} commands on {topic} are not the played signal (command "
                       f"{k} of them is {sent[k]:g} N, the signal's {played[k]:g} N): the cut is ambiguous")
    first, last = (np.flatnonzero(row_log > cmd_ns[i]) for i in (-n, -1))
    if last.size == 0:
        raise BagError(f"bag {path}: the recording ends before the last played command on {topic} acted")
    start, held_over = int(first[0]), int(last[0]) + 1 - int(first[0])
    stop = start + max(n, held_over)  # a timer that fell behind held the signal over more samples
    if stop > row_log.size:
        raise BagError(f"bag {path}: the recording holds {row_log.size - start} samples from the first "
                       f"played command on, fewer than the {stop - start} played")
    held = held_commands(row_log[start:stop], cmd_ns, cmd_force, force_limit=force_limit, watchdog_s=0.0)
    return PlayedCut(start, stop, "commands", float("nan"), topic, held)


def confirm_by_effort(path: Path, cut: PlayedCut, effort: np.ndarray, dt: float) -> PlayedCut:
    """The cut, once the effort over it follows the commands held there (else a one-line BagError).

    ``effort`` is the recorded effort over the cut. The fit is the actuator's that maps the held
    commands onto it (:func:`~msd_bench.core.rigs.actuation.effort_agreement`): a cut off by more than
    a few samples leaves the effort unexplained. A constant effort (no excitation) or none is left
    to the record's own check.
    """
    effort = np.asarray(effort, dtype=np.float64)
    if cut.held is None or not np.isfinite(effort).any() or float(np.ptp(effort)) == 0.0:
        return cut
    try:
        agreement = effort_agreement(cut.held, effort, dt)
    except InvalidInputError as exc:
        raise BagError(f"bag {path}: cannot check the cut against the recorded effort: {exc}") from None
    if agreement.fit_percent < MIN_AGREEMENT:
        raise BagError(f"bag {path}: over the cut from the commands on {cut.topic} the recorded effort does "
                       f"not follow them (fit {agreement.fit_percent:.1f} % < {MIN_AGREEMENT:.0f} %): the "
                       f"played samples cannot be located")
    return replace(cut, match=float(agreement.fit_percent), agreement=agreement)


def locate_from_effort(path: Path, effort: np.ndarray, played: np.ndarray) -> PlayedCut | None:
    """The cut of a bag without commands: the offset where the effort best matches the signal.

    None when the bag needs no cut (no more samples than played). Least squares over
    every offset at once (a running sum of squares and one correlation), so a full-size
    bag costs milliseconds. The fit is against the rest's zero force (``1 - |e| / |played|``):
    a signal's step from rest to its bias is what places it, and its own variance may be tiny.
    """
    effort = np.asarray(effort, dtype=np.float64)
    n = played.size
    if effort.size <= n:
        return None
    squares = np.concatenate(([0.0], np.cumsum(effort**2)))
    sse = squares[n:] - squares[:-n] - 2.0 * np.correlate(effort, played, "valid") + float(played @ played)
    sse = np.maximum(sse, 0.0)
    size = float(np.linalg.norm(played))
    if size == 0.0:
        raise BagError(f"bag {path}: the played signal is zero throughout, so its samples cannot be located "
                       f"in a recording without its commands")
    best = int(np.argmin(sse))
    fit = 100.0 * (1.0 - np.sqrt(sse[best]) / size)
    if fit < MIN_EFFORT_FIT:
        raise BagError(f"bag {path}: the recorded effort matches the played signal by at most {fit:.1f} % "
                       f"(at least {MIN_EFFORT_FIT:.0f} % needed) and the bag has no commands: the played "
                       f"samples cannot be located")
    far = np.abs(np.arange(sse.size) - best) > NEAR
    if far.any() and float(sse[far].min()) <= ALIKE * float(sse[best]):
        other = int(np.flatnonzero(far)[np.argmin(sse[far])])
        raise BagError(f"bag {path}: the played signal matches the recorded effort from sample {best} and "
                       f"from sample {other} alike: the cut is ambiguous (record the command topic too)")
    return PlayedCut(best, best + n, "effort", float(fit))
