"""One rig description: what the bench must know about a rig before it touches it.

A rig is described once, in the form ROS 2 users already write (a parameter
file, read by ``msd_bench.io.rigs.rig_file``); this module only parses the
mapping of parameters, so the science never opens a file. Why one place: the
sample rate, the stroke, the force limit, the units and the face were spread
over presets and command-line options, and nothing checked that they agreed.
A missing or inconsistent key is refused here in one line naming the key and
the source, before anything is started (docs/rig-description.md).

The decision period is a separate choice from the sample period (issue 37
item 3): the agent decides every ``decision_period`` seconds and the command is
held over the rig samples between decisions, so the period must be a whole
number of samples.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.model import StepModel, check_rate
from msd_bench.core.physics.plant import DT, PlantParams

if TYPE_CHECKING:
    from msd_bench.core.rigs.hold import HoldLoop
    from msd_bench.core.rigs.scales import Scales

FACES = ("msd", "ros2_control")
"""The faces a rig may show (msd_msgs_py/interface.py)."""

DEFAULT_DECISION_PERIOD = DT
"""The paper's decision period, s (10 ms)."""

WHOLE_TOLERANCE = 1e-9
"""Relative slack when a period is checked to be a whole number of samples (float rates)."""

KEYS = ("rate", "stroke", "position_min", "position_max", "force_limit", "position_unit",
        "force_unit", "interface", "plant_ns", "controller", "joint", "controller_joints",
        "effort", "decision_period", "actuator_delay_samples", "actuator_delay", "lag",
        "hold_stiffness", "hold_damping", "hold_position")
"""Every key a description may hold; any other is refused with a 'did you mean'."""


@dataclass(frozen=True)
class RigDescription:
    """A rig as the bench sees it: rate, stroke, force, units, face and known facts."""

    rate: float
    """Sample rate, Hz (> 0)."""
    position_min: float
    """Lower position limit, in ``position_unit`` (the stroke is centred when only a length is given)."""
    position_max: float
    """Upper position limit (> position_min)."""
    force_limit: float
    """Largest command magnitude, in ``force_unit`` (> 0)."""
    position_unit: str = "m"
    force_unit: str = "N"
    interface: str = "msd"
    """Face: ``msd`` or ``ros2_control``."""
    plant_ns: str = ""
    """Namespace of the plant-like node ('' = the emulator's own)."""
    controller: str = ""
    joint: str = ""
    controller_joints: tuple[str, ...] = ()
    effort: str = ""
    """Names as the ros2_control face options name them ('' = the face's default)."""
    decision_period: float = DEFAULT_DECISION_PERIOD
    """Agent decision period, s: a whole number of rig samples."""
    actuator_delay_samples: int | None = None
    """A measured actuator delay, samples (optional known fact)."""
    lag: float | None = None
    """A measured first-order lag, s (optional known fact)."""
    hold_stiffness: float | None = None
    """The stated position loop the rig's drive holds it under, force per position unit (None: the rig
    runs bare). A rig with no equilibrium of its own (a springless stage) is recorded and run under it;
    the commands the bench sends are the force beyond the loop's (docs/rig-families.md §stage)."""
    hold_damping: float = 0.0
    """The loop's damping, force per (position unit per second), on the velocity estimated from the
    measured positions."""
    hold_position: float = 0.0
    """The position the loop holds, in ``position_unit``."""

    @property
    def dt(self) -> float:
        """Sample period, s."""
        return 1.0 / self.rate

    @property
    def stroke(self) -> float:
        """Full length of travel, in ``position_unit``."""
        return self.position_max - self.position_min

    @property
    def samples_per_decision(self) -> int:
        """Rig samples the command is held over between two decisions (≥ 1)."""
        return decision_samples(self.decision_period, self.rate, "decision_period", "")

    def check_model(self, model: StepModel, where: str) -> None:
        """Refuse in one line a model identified at another sample period than this rig's."""
        check_rate(model, self.dt, f"the rig of {where}" if where else "the rig")

    def facts(self) -> dict[str, object]:
        """What a run's report states about the rig it ran with (run.json ``rig``)."""
        return {"rate_hz": self.rate, "dt_s": self.dt, "stroke": self.stroke,
                "position_limits": [self.position_min, self.position_max],
                "force_limit": self.force_limit, "position_unit": self.position_unit,
                "force_unit": self.force_unit, "interface": self.interface,
                "decision_period_s": self.decision_period,
                "samples_per_decision": self.samples_per_decision, **self._hold_facts()}

    def _hold_facts(self) -> dict[str, object]:
        """The stated hold loop, when there is one (a bare rig's facts are unchanged)."""
        if self.hold_stiffness is None:
            return {}
        return {"hold_loop": {"stiffness": self.hold_stiffness, "damping": self.hold_damping,
                              "position": self.hold_position}}

    def hold(self) -> HoldLoop | None:
        """The stated hold loop (None: the rig runs bare)."""
        if self.hold_stiffness is None:
            return None
        from msd_bench.core.rigs.hold import HoldLoop  # lazy, as scales: a bare rig never needs it

        return HoldLoop(self.hold_stiffness, self.hold_damping, self.hold_position)

    def latency(self, default: float) -> float:
        """Seconds before a braking command fully acts on this rig, for the supervisor's braking bound:
        the sample the command holds, the stated dead time and the stated lag (a first-order lag of
        time constant τ loses as much impulse as a dead time τ). Why from the description: a drive
        slower than the default's would let the bound promise a stop the mass overruns. A part the
        description does not state is not assumed 0: then ``default`` (the paper's latency in the
        rig's time) stands unless the stated part alone is longer."""
        if self.actuator_delay_samples is None and self.lag is None:
            return default
        stated = self.dt * (1 + (self.actuator_delay_samples or 0)) + (self.lag or 0.0)
        if self.actuator_delay_samples is None or self.lag is None:
            return max(default, stated)
        return stated

    def scales(self) -> Scales:
        """The factors from the paper's plant to this rig (exactly 1.0 each on the default)."""
        from msd_bench.core.rigs.scales import Scales  # lazy: scales imports physics only
        return Scales.of(self.stroke, self.force_limit, self.dt)

    def emulated_plant(self, base: PlantParams | None = None) -> PlantParams:
        """The plant the emulator serves for this description: ``base`` (default: the paper's
        plant) in the rig's units of length and force, sampled at the rig's rate.

        Why: a real rig brings its own plant; the emulator needs one, and the one that keeps the
        task physically the same is the similarity transform of docs/decisions.md §Scales with
        lengths × l = stroke / 5 m and forces × f = force limit / 10 N (m × f/l, c × f/l, k × f,
        g / l, h × f/l³, L = stroke, F = force limit), and time × 1: durations are stated in
        seconds, so the plant keeps its time constants and only its sample period becomes the
        rig's (1/rate). On the default description every factor is exactly 1.0 and the default
        plant comes back bit for bit. The emulator's hard stops sit at ±L/2, so limits that are
        not centred on 0 are refused in one line.
        """
        if self.position_min != -self.position_max:
            raise ConfigError(f"position limits [{self.position_min:g}, {self.position_max:g}]: the "
                              f"emulator's plant has its stops at ±stroke/2; give a stroke centred on 0")
        p = PlantParams() if base is None else base
        paper = PlantParams()
        length, force = self.stroke / paper.L, self.force_limit / paper.F
        return PlantParams(m=p.m * force / length, c=p.c * force / length, k=p.k * force,
                           g=p.g / length, h=p.h * force / length**3, L=p.L * length,
                           F=p.F * force, dt=self.dt)


def default_description() -> RigDescription:
    """The emulator's default plant as a description (what config/rigs/default.yaml must say)."""
    half = 0.5 * PlantParams().L
    return RigDescription(rate=1.0 / DT, position_min=-half, position_max=half,
                          force_limit=PlantParams().F)


def measured_parameters(stamps_ns: Sequence[int], positions: Sequence[float],
                        saturated_efforts: Sequence[float] | NDArray[np.float64]) -> dict[str, float]:
    """A starting description's numbers from what ``check-rig`` saw on a node: the rate from the
    median stamp interval, the stroke the mass moved within (twice the largest |position|: a lower
    bound, the stops were not looked for) and the force limit the effort settled at under a command
    beyond it (the mean |effort| of the last five such rows). A one-line ConfigError when one of
    them was not measured (too few rows, a mass that never moved, no effort under the over-limit
    command): a description is never written with a guessed value.
    """
    stamps = np.unique(np.asarray(stamps_ns, dtype=np.int64))
    if stamps.size < 3:
        raise ConfigError(f"rate: only {stamps.size} distinct stamps seen; nothing to measure it from")
    period = float(np.median(np.diff(stamps))) * 1e-9
    x = np.asarray(positions, dtype=np.float64)
    x = x[np.isfinite(x)]
    if x.size == 0 or float(np.max(np.abs(x))) == 0.0:
        raise ConfigError("stroke: the position never left 0; nothing to measure it from")
    effort = np.abs(np.asarray(saturated_efforts, dtype=np.float64)[-5:])
    if effort.size == 0 or not np.all(np.isfinite(effort)) or float(np.mean(effort)) == 0.0:
        raise ConfigError("force_limit: no effort seen under the over-limit command; "
                          "nothing to measure it from")
    return {"rate": float(f"{1.0 / period:.6g}"), "stroke": float(f"{2.0 * float(np.max(np.abs(x))):.6g}"),
            "force_limit": float(f"{float(np.mean(effort)):.6g}")}


def record_parameters(u: NDArray[np.float64], y: NDArray[np.float64], dt: float,
                      units: tuple[str, str]) -> dict[str, object]:
    """A description's parameters from a measured record (input ``u``, output ``y``, sample time
    ``dt``; ``units`` = (input unit, output unit)): the rate is the record's; the stroke, centred on
    0, is the least that holds every measured output (twice the largest |y|); the force limit is the
    largest |u| the record applied, the only input known to be safe; the agent decides every sample
    (a period the rig's samples divide whole: the paper's 10 ms is rarely a whole number of them).
    Why from the record: a real rig's description is written from what was measured on it, never
    typed from memory; a record with a non-finite or all-zero channel is one ConfigError line."""
    out, force = np.asarray(y, dtype=np.float64), np.asarray(u, dtype=np.float64)
    for name, values in (("output", out), ("input", force)):
        if values.size == 0 or not np.all(np.isfinite(values)) or not np.any(values):
            raise ConfigError(f"the record's {name} is empty, not finite or all zero; no description from it")
    if not (math.isfinite(dt) and dt > 0):
        raise ConfigError(f"the record's sample time must be a positive number of seconds, not {dt!r}")
    return {"rate": 1.0 / dt, "stroke": 2.0 * float(np.max(np.abs(out))),
            "force_limit": float(np.max(np.abs(force))), "position_unit": units[1], "force_unit": units[0],
            "decision_period": dt}


def decision_samples(period: float, rate: float, key: str, source: str) -> int:
    """``period`` in rig samples; a one-line ConfigError when it is not a whole number ≥ 1."""
    samples = period * rate
    whole = round(samples)
    if whole < 1 or not math.isclose(samples, whole, rel_tol=WHOLE_TOLERANCE, abs_tol=0.0):
        raise ConfigError(f"{key}{_at(source)}: {period:g} s is not a whole number of rig samples "
                          f"at {rate:g} Hz ({samples:g} samples)")
    return whole


def parse_description(params: Mapping[str, object], source: str = "") -> RigDescription:
    """A description from a mapping of parameters; one-line ConfigError naming key and source."""
    _refuse_unknown(params, source)
    rate = _positive(params, "rate", source)
    low, high = _limits(params, source)
    desc = RigDescription(
        rate=rate, position_min=low, position_max=high,
        force_limit=_positive(params, "force_limit", source),
        position_unit=_name(params, "position_unit", "m", source),
        force_unit=_name(params, "force_unit", "N", source),
        interface=_face(params, source),
        plant_ns=_text(params, "plant_ns", source), controller=_text(params, "controller", source),
        joint=_text(params, "joint", source),
        controller_joints=_names(params, "controller_joints", source),
        effort=_text(params, "effort", source),
        decision_period=_optional_positive(params, "decision_period", source)
        or DEFAULT_DECISION_PERIOD,
        actuator_delay_samples=_delay(params, rate, source),
        lag=_optional_positive(params, "lag", source), **_hold(params, low, high, source))
    decision_samples(desc.decision_period, rate, "decision_period", source)
    return desc


def _hold(params: Mapping[str, object], low: float, high: float, source: str) -> dict[str, Any]:
    """The stated hold loop's fields: a stiffness > 0 names the loop; its damping (≥ 0) and held position
    (inside the limits) belong to it and are refused without it."""
    stiffness = _optional_positive(params, "hold_stiffness", source)
    damping = _number(params, "hold_damping", source)
    position = _number(params, "hold_position", source)
    if stiffness is None:
        given = "hold_damping" if damping is not None else "hold_position" if position is not None else ""
        if given:
            raise ConfigError(f"{given}{_at(source)} belongs to a hold loop: give hold_stiffness too")
        return {}
    if damping is not None and damping < 0:
        raise ConfigError(f"hold_damping{_at(source)} must be >= 0, got {damping:g}")
    if position is not None and not low < position < high:
        raise ConfigError(f"hold_position{_at(source)} ({position:g}) must be inside the position limits "
                          f"[{low:g}, {high:g}]")
    return {"hold_stiffness": stiffness, "hold_damping": damping or 0.0, "hold_position": position or 0.0}


def _at(source: str) -> str:
    """`` in FILE`` when the source is known."""
    return f" in {source}" if source else ""


def _refuse_unknown(params: Mapping[str, object], source: str) -> None:
    """An unknown key is a typo until proven otherwise: name it, and the closest known one."""
    for key in params:
        if key not in KEYS:
            close = difflib.get_close_matches(str(key), KEYS, n=1)
            hint = f"; did you mean {close[0]}?" if close else f"; known: {', '.join(KEYS)}"
            raise ConfigError(f"unknown rig key {key!r}{_at(source)}{hint}")


def _number(params: Mapping[str, object], key: str, source: str) -> float | None:
    """A finite number, or None when absent; anything else is one line."""
    if key not in params:
        return None
    value = params[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ConfigError(f"{key}{_at(source)} must be a finite number, got {value!r:.40}")
    return float(value)


def _positive(params: Mapping[str, object], key: str, source: str) -> float:
    """A required number > 0."""
    value = _optional_positive(params, key, source)
    if value is None:
        raise ConfigError(f"{key}{_at(source)} is missing (see docs/rig-description.md)")
    return value


def _optional_positive(params: Mapping[str, object], key: str, source: str) -> float | None:
    """An optional number, > 0 when given."""
    value = _number(params, key, source)
    if value is not None and value <= 0:
        raise ConfigError(f"{key}{_at(source)} must be > 0, got {value:g}")
    return value


def _limits(params: Mapping[str, object], source: str) -> tuple[float, float]:
    """Position limits: an ordered pair, or a stroke centred on 0 — not both."""
    low = _number(params, "position_min", source)
    high = _number(params, "position_max", source)
    if low is None and high is None:
        half = 0.5 * _positive(params, "stroke", source)
        return -half, half
    if "stroke" in params:
        raise ConfigError(f"stroke{_at(source)}: give either stroke or position_min/position_max")
    if low is None or high is None:
        missing = "position_min" if low is None else "position_max"
        raise ConfigError(f"{missing}{_at(source)} is missing (position limits come in a pair)")
    if not low < high:
        raise ConfigError(f"position_min{_at(source)} ({low:g}) must be below position_max ({high:g})")
    return low, high


def _text(params: Mapping[str, object], key: str, source: str) -> str:
    """An optional string ('' when absent)."""
    value = params.get(key, "")
    if not isinstance(value, str):
        raise ConfigError(f"{key}{_at(source)} must be a string, got {value!r:.40}")
    return value


def _name(params: Mapping[str, object], key: str, default: str, source: str) -> str:
    """A non-empty unit name."""
    value = _text(params, key, source) if key in params else default
    if not value.strip():
        raise ConfigError(f"{key}{_at(source)} must not be empty")
    return value


def _names(params: Mapping[str, object], key: str, source: str) -> tuple[str, ...]:
    """An optional list of strings."""
    value = params.get(key, [])
    if not isinstance(value, list | tuple) or not all(isinstance(v, str) for v in value):
        raise ConfigError(f"{key}{_at(source)} must be a list of names, got {value!r:.40}")
    return tuple(value)


def _face(params: Mapping[str, object], source: str) -> str:
    """``msd`` or ``ros2_control``."""
    face = _text(params, "interface", source) or "msd"
    if face not in FACES:
        raise ConfigError(f"interface{_at(source)} must be one of {', '.join(FACES)}, got {face!r:.40}")
    return face


def _delay(params: Mapping[str, object], rate: float, source: str) -> int | None:
    """A measured delay given in samples or seconds (not both), as whole samples ≥ 0."""
    in_samples = _number(params, "actuator_delay_samples", source)
    in_seconds = _number(params, "actuator_delay", source)
    if in_samples is not None and in_seconds is not None:
        raise ConfigError(f"actuator_delay{_at(source)}: give it in samples or in seconds, not both")
    if in_samples is not None:
        if in_samples < 0 or in_samples != int(in_samples):
            raise ConfigError(f"actuator_delay_samples{_at(source)} must be a whole number ≥ 0, "
                              f"got {in_samples:g}")
        return int(in_samples)
    if in_seconds is None:
        return None
    if in_seconds < 0:
        raise ConfigError(f"actuator_delay{_at(source)} must be ≥ 0, got {in_seconds:g}")
    return decision_samples(in_seconds, rate, "actuator_delay", source) if in_seconds > 0 else 0


__all__ = ["FACES", "KEYS", "RigDescription", "decision_samples", "default_description",
           "measured_parameters", "parse_description"]
