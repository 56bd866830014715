"""Where a real-time recording's played samples are: found from the commands the excitation sent.

A real-time recorder runs from before the first command to after the last, so
its bag holds more than the experiment: first whatever the plant still did
when the recorder started (the previous experiment's last command until the
watchdog, 20-30 samples), then the rest (zero force until still, up to
thousands of samples), then the played signal, then a tail. The first non-zero
effort is therefore no marker of the experiment's start.

What the excitation knows is what it sent: after the rest's zero commands it
sends exactly the ``N`` commands of its signal on the command topic, which the
recorder stores beside ``joint_states`` (on every face, in real time). So the
first played command is the ``N``-th from the end of the recorded commands,
and the first played sample is the first ``joint_states`` row logged after it
(the plant holds the newest command over each step: :func:`held_commands`, the
rule the ros2_control reader already uses). The cut is then checked against
the played signal: over it, the commands held at each row must equal the
signal rebuilt from the bag's parameters (after saturation), at
:data:`MIN_CUT_MATCH` of the samples or more (a command that reaches the plant
within its publish jitter of a tick is held one sample late), and better than
at one sample earlier or later; anything else is refused with one line naming
the bag, never guessed.

A bag without the command topic (recorded before it was recorded, or on a face
that reports the commanded effort) is cut where its effort best matches the
played signal over the whole signal (least squares over every offset), and
refused when that match is poor or a distant offset matches about as well.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from msd_bench.core.actuation import held_commands
from msd_bench.io.bag_interface import _command_rows
from msd_bench.io.bag_writer import leading_stamp
from msd_bench.io.bags import _open_bag
from msd_bench.io.errors import BagError
from msd_msgs_py.interface import PlantInterface

MIN_CUT_MATCH = 0.9
"""Least share of the played samples whose held command must equal the signal over the cut. A
command logged within the plant's publish jitter of a tick may be held one sample later than the
log times say; 0.9 leaves room for that at every change of a fast PRBS, and none for a cut that is
off by more than a sample (which mismatches at every change of the signal and beyond)."""

MIN_EFFORT_FIT = 50.0
"""Least fit (%, normalised RMSE) of the recorded effort to the played signal for a cut found from
the effort alone (a bag without commands): as the ros2_control reader's agreement threshold."""

EFFORT_MARGIN = 5.0
"""A cut from the effort is ambiguous when an offset more than :data:`NEAR` samples away fits within
this many percentage points of the best one (a signal that looks the same shifted)."""

NEAR = 2
"""Offsets this close to the best one are the same cut, seen through an actuator's delay and lag."""


@dataclass(frozen=True)
class PlayedCut:
    """The played samples of one real-time bag: rows ``[start, stop)`` in stamp order."""

    start: int
    """First played sample."""
    stop: int
    """One past the last played sample (``start`` + the signal's length)."""
    found_by: str
    """``commands`` (the recorded command topic) or ``effort`` (a bag without it)."""
    match: float
    """How well the cut agrees with the played signal: the share of samples whose held command
    equals it (``commands``), or the effort's fit in % (``effort``)."""

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
    command topic (then :func:`locate_from_effort` is the fallback).
    """
    row_log, commands = _log_times(path, iface, namespace)
    if row_log.size <= played.size or commands is None:
        return None
    topic = iface.command.resolve(namespace)
    return locate_from_commands(path, topic, row_log, commands[0], commands[1], played, force_limit)


def _log_times(path: Path, iface: PlantInterface,
               namespace: str) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
    """Log times of the state rows (in stamp order) and (log ns, force) of the commands, if recorded."""
    state, command = iface.state.resolve(namespace), iface.command.resolve(namespace)
    with _open_bag(path) as reader:
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


def locate_from_commands(path: Path, topic: str, row_log: np.ndarray, cmd_ns: np.ndarray,
                         cmd_force: np.ndarray, played: np.ndarray, force_limit: float) -> PlayedCut:
    """The cut from the commands: the last ``played.size`` of them are the signal (module docstring)."""
    n = played.size
    order = np.argsort(cmd_ns, kind="stable")
    cmd_ns, cmd_force = cmd_ns[order], cmd_force[order]
    if cmd_ns.size < n:
        raise BagError(f"bag {path}: {cmd_ns.size} commands on {topic}, fewer than the {n} the excitation "
                       f"played: cannot tell where the played samples start")
    sent = np.clip(cmd_force[-n:], -force_limit, force_limit)
    wrong = np.flatnonzero(~np.isclose(sent, played, rtol=0.0, atol=1e-9))
    if wrong.size:
        k = int(wrong[0])
        raise BagError(f"bag {path}: the last {n} commands on {topic} are not the played signal (command "
                       f"{k} of them is {sent[k]:g} N, the signal's {played[k]:g} N): the cut is ambiguous")
    after = np.flatnonzero(row_log > cmd_ns[-n])
    if after.size == 0 or int(after[0]) + n > row_log.size:
        left = 0 if after.size == 0 else row_log.size - int(after[0])
        raise BagError(f"bag {path}: the recording holds {left} samples from the first played command "
                       f"on, fewer than the {n} played")
    held = held_commands(row_log, cmd_ns, cmd_force, force_limit=force_limit, watchdog_s=0.0)
    return _best_of(path, held, played, int(after[0]))


def _best_of(path: Path, held: np.ndarray, played: np.ndarray, start: int) -> PlayedCut:
    """The log-time cut, checked against its neighbours one sample either side."""
    n = played.size
    scores = {s: float(np.mean(np.isclose(held[s:s + n], played, rtol=0.0, atol=1e-9)))
              for s in (start - 1, start, start + 1) if s >= 0 and s + n <= held.size}
    best = max(scores, key=lambda s: (scores[s], -abs(s - start)))
    if scores[best] < MIN_CUT_MATCH:
        raise BagError(f"bag {path}: the recorded commands match the played signal at only "
                       f"{100 * scores[best]:.0f} % of the samples from sample {best} on (at least "
                       f"{100 * MIN_CUT_MATCH:.0f} % needed): the played samples cannot be located")
    ties = [s for s in scores if s != best and scores[s] == scores[best]]
    if ties:
        raise BagError(f"bag {path}: the played signal matches the recorded commands equally from "
                       f"sample {min(best, *ties)} and {max(best, *ties)}: the cut is ambiguous")
    return PlayedCut(best, best + n, "commands", scores[best])


def locate_from_effort(path: Path, effort: np.ndarray, played: np.ndarray) -> PlayedCut | None:
    """The cut of a bag without commands: the offset where the effort best matches the signal.

    None when the bag needs no cut (no more samples than played). Least squares over
    every offset at once (a running sum of squares and one correlation), so a full-size
    bag costs milliseconds.
    """
    effort = np.asarray(effort, dtype=np.float64)
    n = played.size
    if effort.size <= n:
        return None
    squares = np.concatenate(([0.0], np.cumsum(effort**2)))
    sse = squares[n:] - squares[:-n] - 2.0 * np.correlate(effort, played, "valid") + float(played @ played)
    spread = float(np.linalg.norm(played - played.mean()))
    if spread == 0.0:
        raise BagError(f"bag {path}: the played signal is constant, so its samples cannot be located "
                       f"in a recording without its commands")
    fit = 100.0 * (1.0 - np.sqrt(np.maximum(sse, 0.0)) / spread)
    best = int(np.argmax(fit))
    if fit[best] < MIN_EFFORT_FIT:
        raise BagError(f"bag {path}: the recorded effort matches the played signal by at most "
                       f"{fit[best]:.1f} % (at least {MIN_EFFORT_FIT:.0f} % needed) and the bag has no "
                       f"commands: the played samples cannot be located")
    far = np.abs(np.arange(fit.size) - best) > NEAR
    if far.any() and float(fit[far].max()) >= fit[best] - EFFORT_MARGIN:
        other = int(np.flatnonzero(far)[np.argmax(fit[far])])
        raise BagError(f"bag {path}: the played signal matches the recorded effort from sample {best} "
                       f"({fit[best]:.1f} %) and from sample {other} ({fit[other]:.1f} %) alike: the cut "
                       f"is ambiguous (record the command topic too)")
    return PlayedCut(best, best + n, "effort", float(fit[best]))
