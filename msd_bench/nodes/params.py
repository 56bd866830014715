"""Map a frozen config dataclass 1:1 onto declared ROS parameters (docs/design.md §Conventions).

Why generic: every node (plant, excitation, surrogate, agent, recorder) has
config dataclasses — core's for the science (e.g. ``PlantParams``), its own in
``nodes`` for how it runs — with a docstring under each field. Declaring the
parameters from the dataclass keeps the two from drifting: the field's
docstring becomes the parameter's description, its default the default, and
an optional range (``field(metadata={"range": (lo, hi)})`` or a per-class
``RANGES = {"field": (lo, hi)}`` dict, or the ``ranges`` argument) becomes a
``FloatingPointRange``/``IntegerRange`` that ``ros2 param describe`` shows.

Any wrong value — a type ROS cannot coerce, a value outside its range, or one
the dataclass' own validation rejects — surfaces as one
:class:`~msd_bench.core.errors.ConfigError` line, which :mod:`.spin` prints
without a traceback. So does a parameter name no node declares
(:func:`reject_unknown_parameters`: a misspelt ``watchdog_timout`` must not
silently run with the default) and a params file that is not a YAML mapping
(:func:`check_params_files`).
"""

from __future__ import annotations

import ast
import contextlib
import dataclasses
import difflib
import functools
import gc
import inspect
import itertools
import math
import textwrap
import threading
import typing
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar

import yaml
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.exceptions import InvalidParameterValueException, ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter

from msd_bench.app.job import JobError, read_job
from msd_bench.core.errors import ConfigError, MsdBenchError
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.rigs.description import RigDescription, parse_description

T = TypeVar("T")
Range = tuple[float, float]

_SCALARS: dict[type, Parameter.Type] = {
    bool: Parameter.Type.BOOL,
    int: Parameter.Type.INTEGER,
    float: Parameter.Type.DOUBLE,
    str: Parameter.Type.STRING,
}
_ARRAYS: dict[type, Parameter.Type] = {
    bool: Parameter.Type.BOOL_ARRAY,
    int: Parameter.Type.INTEGER_ARRAY,
    float: Parameter.Type.DOUBLE_ARRAY,
    str: Parameter.Type.STRING_ARRAY,
}


_AST_LOCK = threading.Lock()
"""Serialises our ``ast.parse`` calls (see :func:`_parsing_alone`)."""


@contextlib.contextmanager
def _parsing_alone() -> Iterator[None]:
    """Parse with no other parse able to start inside: CPython 3.11 keeps the AST-to-object
    conversion's recursion depth in state shared by every parse, so a parse nested in another one
    fails the outer with "AST constructor recursion depth mismatch". Nesting happens when a garbage
    collection inside the conversion runs a finalizer that formats a traceback (3.11's traceback
    module parses the source line) — seen when building a node after check-rig tests — or when
    another thread parses. Hence a lock and no collection while parsing."""
    with _AST_LOCK:
        enabled = gc.isenabled()
        gc.disable()
        try:
            yield
        finally:
            if enabled:
                gc.enable()


@functools.cache
def field_docs(cls: type) -> dict[str, str]:
    """Docstrings written under the fields of a dataclass, read from its source with ``ast``."""
    with _parsing_alone():  # inspect.getsource parses the whole module with ast as well
        try:
            source = textwrap.dedent(inspect.getsource(cls))
        except (OSError, TypeError):
            return {}
        body = ast.parse(source).body[0]
    docs: dict[str, str] = {}
    stmts = getattr(body, "body", [])
    for stmt, nxt in itertools.pairwise(stmts):
        if (
            isinstance(stmt, ast.AnnAssign)
            and isinstance(stmt.target, ast.Name)
            and isinstance(nxt, ast.Expr)
            and isinstance(nxt.value, ast.Constant)
            and isinstance(nxt.value.value, str)
        ):
            docs[stmt.target.id] = inspect.cleandoc(nxt.value.value)
    return docs


def _ros_type(hint: Any, name: str) -> tuple[Parameter.Type, type, bool]:
    """(parameter type, Python element type, is-sequence) of a field's annotation."""
    origin = typing.get_origin(hint)
    if origin in (tuple, list):
        elem = typing.get_args(hint)[0]
        if elem in _ARRAYS:
            return _ARRAYS[elem], elem, True
    elif hint in _SCALARS:
        return _SCALARS[hint], hint, False
    raise TypeError(f"field {name!r}: type {hint!r} has no ROS parameter equivalent")


def _descriptor(
    name: str, doc: str, ptype: Parameter.Type, bounds: Range | None
) -> ParameterDescriptor:
    desc = ParameterDescriptor(name=name, type=ptype.value, description=doc, read_only=True)
    if bounds is not None and ptype == Parameter.Type.DOUBLE:
        desc.floating_point_range = [
            FloatingPointRange(from_value=float(bounds[0]), to_value=float(bounds[1]), step=0.0)
        ]
    elif bounds is not None and ptype == Parameter.Type.INTEGER:
        desc.integer_range = [
            IntegerRange(from_value=int(bounds[0]), to_value=int(bounds[1]), step=0)
        ]
    return desc


def _coerce_overrides(node: Node, name: str, ptype: Parameter.Type) -> bool:
    """Let ``-p mass:=2`` set a float field: ROS parses ``2`` as an integer and would refuse it.

    ``-p seeds:=[]`` arrives untyped (NOT_SET) and ROS cannot store an empty
    array of a declared type: returns True ("the user gave an empty array"),
    removes the override, and the dataclass judges the empty value. For a
    scalar an untyped value is a missing value.
    """
    overrides: dict[str, Parameter[Any]] = getattr(node, "_parameter_overrides", {})
    given = overrides.get(name)
    if given is None:
        return False
    if given.type_ == Parameter.Type.NOT_SET:
        if ptype not in _ARRAYS.values():
            raise ConfigError(f"parameter {name}: no value given (expected a {ptype.name.lower()})")
        del overrides[name]
        return True
    if ptype == Parameter.Type.DOUBLE and given.type_ == Parameter.Type.INTEGER:
        overrides[name] = Parameter(name, Parameter.Type.DOUBLE, float(given.value))
    elif ptype == Parameter.Type.DOUBLE_ARRAY and given.type_ == Parameter.Type.INTEGER_ARRAY:
        overrides[name] = Parameter(name, Parameter.Type.DOUBLE_ARRAY, [float(v) for v in given.value])
    return False


def _bounds(cls: type, f: dataclasses.Field[Any], ranges: Mapping[str, Range] | None) -> Range | None:
    if ranges and f.name in ranges:
        return ranges[f.name]
    if "range" in f.metadata:
        return typing.cast(Range, f.metadata["range"])
    return typing.cast(Mapping[str, Range], getattr(cls, "RANGES", {})).get(f.name)


def declare_from_dataclass(
    node: Node,
    cls: type[T],
    prefix: str = "",
    *,
    defaults: T | None = None,
    ranges: Mapping[str, Range] | None = None,
    exclude: tuple[str, ...] = (),
) -> T:
    """Declare one read-only parameter per field of ``cls``, read them back, build the config.

    ``prefix`` (e.g. ``"prbs."``) namespaces the parameters; ``defaults`` is an
    instance whose values replace the class defaults (e.g. a plant preset);
    excluded fields keep their default. A node given a job file (:func:`use_job`) takes the
    file's values for these fields as defaults, over ``defaults``; an explicit ``-p`` still wins.
    Raises :class:`ConfigError` with one line (:class:`JobError` naming the file for its values).
    """
    if not (dataclasses.is_dataclass(cls) and isinstance(cls, type)):
        raise TypeError(f"{cls!r} is not a dataclass")
    job = node_job(node)
    if job is not None:
        taken = job.section(cls, prefix, ranges, exclude)
        if taken:
            defaults = job.build(cls, taken, defaults)
    hints = typing.get_type_hints(cls)
    docs = field_docs(cls)
    values: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        if f.name in exclude or not f.init:
            continue
        name = prefix + f.name
        ptype, elem, is_seq = _ros_type(hints[f.name], f.name)
        default = getattr(defaults, f.name) if defaults is not None else _default(f)
        desc = _descriptor(name, docs.get(f.name, ""), ptype, _bounds(cls, f, ranges))
        empty = _coerce_overrides(node, name, ptype)
        initial = _to_ros(default, ptype, is_seq)
        if is_seq and not initial:
            initial = ptype  # rclpy would type a bare [] as a byte array and refuse every override
        try:
            value = node.declare_parameter(name, initial, desc).value
        except InvalidParameterValueException as exc:
            raise ConfigError(f"parameter {name}: {_range_text(exc)}") from None
        except ParameterException as exc:
            raise ConfigError(f"parameter {name}: {_one_line(exc)}") from None
        value = [] if empty or value is None else value
        _check_finite(name, value)
        values[f.name] = tuple(elem(v) for v in value) if is_seq else value
    try:
        return cls(**values)
    except MsdBenchError as exc:
        raise ConfigError(f"{cls.__name__} parameters: {exc}") from None
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{cls.__name__} parameters: {_one_line(exc)}") from None


def _default(f: dataclasses.Field[Any]) -> Any:
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    raise TypeError(f"field {f.name!r} has no default: cannot declare it as a ROS parameter")


def _to_ros(value: Any, ptype: Parameter.Type, is_seq: bool) -> Any:
    if is_seq:
        return list(value)
    return float(value) if ptype == Parameter.Type.DOUBLE else value


def _check_finite(name: str, value: Any) -> None:
    items = value if isinstance(value, list | tuple) else [value]
    for v in items:
        if isinstance(v, float) and not math.isfinite(v):
            raise ConfigError(f"parameter {name} must be finite, got {v}")


ROS_OWN_NAMES = frozenset({"use_sim_time", "start_type_description_service"})
"""Parameters rclpy itself reads; every node accepts them."""
ROS_OWN_PREFIXES = ("qos_overrides.",)
"""Prefixes of parameters rclpy reads (QoS overrides of publishers and subscriptions)."""


OWN_CLOCK_REFUSED = "use_sim_time"
"""rclpy's parameter that swaps a node's clock for ``/clock`` (:func:`keep_own_clock` refuses it)."""


def _own_clock_reason(node: Node) -> str:
    return (f"parameter use_sim_time: {node.get_fully_qualified_name()} paces itself on its own clock "
            "(it publishes /clock in lock-step, runs on the monotonic clock in real time); "
            "only the recorder and the other consumers of /clock take use_sim_time")


def keep_own_clock(node: Node) -> None:
    """Refuse ``use_sim_time`` on a plant-like node, at start (ConfigError) and at run time.

    Why: rclpy accepts ``use_sim_time`` on every node, from ``-p``, a params
    file or a ``ros2 param set`` (a SetParameters call any participant on the
    domain may make); on the plant, rig or surrogate it would stamp samples
    with a ``/clock`` the node itself (or nobody) publishes. At run time the
    refusal is a SetParametersResult with the reason; our callback is added
    after rclpy's TimeSource's, so it runs first and the clock never switches.
    """
    if node.get_parameter(OWN_CLOCK_REFUSED).value is not False:
        raise ConfigError(_own_clock_reason(node))

    def refuse(params: list[Parameter[Any]]) -> SetParametersResult:
        if any(p.name == OWN_CLOCK_REFUSED and p.value is not False for p in params):
            return SetParametersResult(successful=False, reason=_own_clock_reason(node))
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(refuse)


def _params_files(argv: Sequence[str]) -> list[str]:
    """Paths given with ``--params-file`` (or ``-p``-less file forms) after ``--ros-args``."""
    files = []
    for flag, value in itertools.pairwise(argv):
        if flag == "--params-file":
            files.append(value)
    return files


def _load_params_file(path: str) -> dict[Any, Any]:
    try:
        doc = yaml.safe_load(Path(path).read_text())
    except OSError as exc:
        raise ConfigError(f"params file {path}: cannot read it ({exc.strerror or exc})") from None
    except yaml.YAMLError as exc:
        where = getattr(exc, "problem_mark", None)
        line = f" (line {where.line + 1})" if where is not None else ""
        raise ConfigError(f"params file {path} is not valid YAML{line}") from None
    if not isinstance(doc, dict) or not all(
        isinstance(v, dict) and isinstance(v.get("ros__parameters"), dict) for v in doc.values()
    ):
        raise ConfigError(
            f"params file {path} is not a ROS params file: expected `<node or /**>: ros__parameters: {{...}}`"
        )
    return doc


def check_params_files(argv: Sequence[str]) -> None:
    """Every ``--params-file`` must be readable YAML shaped as ROS expects (rcl would ignore it)."""
    for path in _params_files(argv):
        _load_params_file(path)


def check_rig_files(argv: Sequence[str]) -> None:
    """A params file whose ``/**`` section sets ``rate`` is a rig description: check it whole.

    Why here: ``--ros-args --params-file rig.yaml`` is how a ROS user hands a
    node the rig (docs/rig-description.md); a typo or an inconsistent key must
    be one line before the node starts. The description read is kept
    (:func:`params_file_rig`): a node that serves or guards a plant takes its
    rate, stroke and force limit from it (explicit ``-p`` values still win).
    Two rig files for one process are refused: which one describes the rig
    would be a guess.
    """
    found: list[tuple[str, RigDescription]] = []
    for path in _params_files(argv):
        body = _load_params_file(path).get("/**", {}).get("ros__parameters", {})
        if "rate" not in body:
            continue
        found.append((path, parse_description({str(k): v for k, v in body.items()}, path)))
        if len(found) > 1:
            raise ConfigError(f"rig files {found[0][0]} and {path}: give one rig description per node")
    _RIG[:] = [rig for _, rig in found]


_RIG: list[RigDescription] = []
"""The rig description of this process's params files, if any (set by :func:`check_rig_files`)."""


def params_file_rig() -> RigDescription | None:
    """The rig description this node was given (``--params-file`` or ``--rig``), or None."""
    return _RIG[0] if _RIG else None


def rig_plant(params: PlantParams) -> PlantParams:
    """``params`` on the rig this node was given (:meth:`RigDescription.emulated_plant`: the rig's
    stroke, force limit and rate, the rest scaled consistently); ``params`` itself without one."""
    rig = params_file_rig()
    return params if rig is None else rig.emulated_plant(params)


RIG_OPTION = "--rig"
"""The launch scripts' own option for a rig description (before any ``--ros-args``)."""


def expand_rig_option(argv: Sequence[str]) -> list[str]:
    """``--rig FILE`` (before ``--ros-args``) as the ROS form ``--ros-args --params-file FILE``.

    Why: bench.py, check-rig and the in-process commands take ``--rig FILE``; the
    launch scripts take it too, and hand it to ROS as the parameter file it is, so
    one file serves both forms. A missing file name is one line.
    """
    args = list(argv)
    end = args.index("--ros-args") if "--ros-args" in args else len(args)
    if RIG_OPTION not in args[:end]:
        return args
    i = args.index(RIG_OPTION)
    if i + 1 >= end:
        raise ConfigError("--rig needs a file: --rig rig.yaml (docs/rig-description.md)")
    path = args[i + 1]
    rest = args[:i] + args[i + 2:]
    if not Path(path).is_file():
        raise ConfigError(f"--rig {path}: no such file")
    return [*rest, "--ros-args", "--params-file", path]


def _flat(prefix: str, tree: Mapping[str, Any]) -> Iterable[str]:
    for key, value in tree.items():
        if isinstance(value, dict):
            yield from _flat(f"{prefix}{key}.", value)
        else:
            yield f"{prefix}{key}"


def wildcard_parameter_names(argv: Sequence[str]) -> set[str]:
    """Names set in ``/**`` sections of the params files: meant for every node, so none may refuse them."""
    names: set[str] = set()
    for path in _params_files(argv):
        for section, body in _load_params_file(path).items():
            if str(section).rstrip("/").endswith("**") and str(section).startswith("/**"):
                names |= set(_flat("", body["ros__parameters"]))
    return names


_WILDCARD_NAMES: set[str] = set()
"""Names from the ``/**`` sections of this process's params files (set by :mod:`.spin`)."""


def allow_wildcard_names(names: Iterable[str]) -> None:
    """Remember the ``/**`` names of this process (see :func:`wildcard_parameter_names`)."""
    _WILDCARD_NAMES.clear()
    _WILDCARD_NAMES.update(names)


def reject_unknown_parameters(node: Node, allowed: Iterable[str] = ()) -> None:
    """One ConfigError line for an override that names no parameter this node declared.

    Call it once every parameter is declared — nodes that do slow work at
    start-up (the plant's duplicate check) call it before that work, and
    :mod:`.spin` calls it again after building any node.
    """
    overrides: dict[str, Any] = getattr(node, "_parameter_overrides", {})
    declared = set(node.list_parameters([], 0).names)  # depth 0: every level
    ok = declared | ROS_OWN_NAMES | set(allowed) | _WILDCARD_NAMES
    unknown = sorted(n for n in overrides if n not in ok and not n.startswith(ROS_OWN_PREFIXES))
    check_job_used(node)
    if unknown:
        close = difflib.get_close_matches(unknown[0], sorted(declared), n=1)
        hint = f"; did you mean {close[0]}?" if close else f"; known: {', '.join(sorted(declared))}"
        raise ConfigError(f"node {node.get_fully_qualified_name()} has no parameter {unknown[0]}{hint}")


def _range_text(exc: InvalidParameterValueException) -> str:
    """rclpy's out-of-range message without the repetitions: the value and the bounds."""
    text = _one_line(exc)
    reason = text.split("Reason: ", 1)[-1].rsplit(":", 1)[0]
    return reason.replace("Parameter ", "value ", 1)


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


_INT64 = (-(2**63), 2**63 - 1)
"""The range of a ROS integer parameter (an int beyond it would not even convert to a double)."""

JOB_PARAMETER = "job"
"""The parameter naming a node's job file (:mod:`msd_bench.app.job`)."""
_JOB_ATTR = "_msd_job"
"""Where a node keeps the job file it was given (read once, consulted by every declaration)."""


def _job_value(path: str, cls: type, f: dataclasses.Field[Any], hint: Any, value: Any, name: str,
               ranges: Mapping[str, Range] | None) -> Any:
    """One job-file value checked against its field's type and range; JobError naming file and field."""
    where = f"job file {path}: field {name}"
    _, elem, is_seq = _ros_type(hint, f.name)
    items = value if is_seq else [value]
    if is_seq and not isinstance(value, list):
        raise JobError(f"{where} must be a list, got {type(value).__name__}")
    for v in items:
        ok = (type(v) is elem) or (elem is float and type(v) is int)
        if not ok:
            raise JobError(f"{where} must be {'a list of ' if is_seq else ''}{elem.__name__}, got {v!r}")
        if isinstance(v, float) and not math.isfinite(v):
            raise JobError(f"{where} must be finite, got {v}")
        if type(v) is int and not _INT64[0] <= v <= _INT64[1]:  # ROS integers are 64-bit; floats too small
            raise JobError(f"{where}: an integer of {v.bit_length()} bits does not fit a ROS parameter")
    bounds = _bounds(cls, f, ranges)
    if bounds is not None and not is_seq and not bounds[0] <= value <= bounds[1]:
        raise JobError(f"{where}: {value!r} is outside [{bounds[0]}, {bounds[1]}]")
    return tuple(elem(v) for v in items) if is_seq else elem(value)


@dataclasses.dataclass
class JobFile:
    """A node's job file, read once: its ``params`` are named as the node's parameters are.

    Why one flat mapping keyed by parameter name (``episodes``, ``prbs.bias``, ``lockstep``):
    a node declares several configs (the excitation its own and one per signal kind, the
    surrogate the plant node's and its model's), and each declaration takes its section by
    the same name a ``-p`` would use, so a job file and ``-p`` arguments say one thing one way.
    """

    path: str
    """The file, as given (every error names it)."""
    role: str
    """The node role it was written for (checked against the envelope)."""
    params: dict[str, Any]
    """The parameters, by name."""
    used: set[str] = dataclasses.field(default_factory=set)
    """Names a declaration has taken (the rest are unknown fields: :meth:`check_used`)."""

    @classmethod
    def read(cls, path: str, role: str) -> JobFile:
        """Read and check the envelope (:func:`msd_bench.app.job.read_job`)."""
        return cls(path, role, read_job(path, role))

    def section(self, cls: type[T], prefix: str = "", ranges: Mapping[str, Range] | None = None,
                exclude: tuple[str, ...] = ()) -> dict[str, Any]:
        """The file's values for the fields of ``cls`` under ``prefix``, each typed and in range."""
        hints = typing.get_type_hints(cls)
        fields = {f.name: f for f in dataclasses.fields(cls)  # type: ignore[arg-type]
                  if f.init and f.name not in exclude}
        values: dict[str, Any] = {}
        for name, f in fields.items():
            key = prefix + name
            if key in self.params:
                values[name] = _job_value(self.path, cls, f, hints[name], self.params[key], key, ranges)
                self.used.add(key)
        return values

    def build(self, cls: type[T], values: Mapping[str, Any], defaults: T | None = None) -> T:
        """``cls`` from the file's ``values`` over ``defaults``: the file alone must make a valid config."""
        base = {} if defaults is None else {f.name: getattr(defaults, f.name)
                                            for f in dataclasses.fields(cls) if f.init}  # type: ignore[arg-type]
        try:
            return cls(**{**base, **values})
        except MsdBenchError as exc:
            raise JobError(f"job file {self.path}: {exc}") from None
        except (TypeError, ValueError) as exc:
            raise JobError(f"job file {self.path}: {_one_line(exc)}") from None

    def check_used(self) -> None:
        """Every field of the file was taken by a declaration; else JobError naming the first other."""
        unknown = sorted(set(self.params) - self.used)
        if unknown:
            raise JobError(f"job file {self.path}: unknown field {unknown[0]!r} for a {self.role} node")


def config_from_job(path: str, cls: type[T], role: str) -> T:
    """Build ``cls`` from the job file at ``path`` (node ``role``): every field named, typed and in range.

    Why here and not in app: the schema of a role is its node configs' fields, their types
    and ranges; the envelope (schema, version, role) is checked by :func:`msd_bench.app.job.read_job`.
    For a node of one config; a node of several declares each (:func:`use_job`).
    """
    job = JobFile.read(path, role)
    config = job.build(cls, job.section(cls))
    job.check_used()
    return config


Section = tuple[str, type, Mapping[str, Range] | None]
"""``(prefix, config class, ranges)``: one declaration of a node (:func:`declare_from_dataclass`)."""


def sections_from_job(path: str, role: str, sections: Sequence[Section]) -> list[Any]:
    """Each section's config from the job file at ``path``, as a node making those declarations would
    build them from the file alone (no ROS): the check of a several-config node's job without a node."""
    job = JobFile.read(path, role)
    configs: list[Any] = [job.build(cls, job.section(cls, prefix, ranges))
                          for prefix, cls, ranges in sections]
    job.check_used()
    return configs


def node_job(node: Node) -> JobFile | None:
    """The job file ``node`` was given, if any (:func:`use_job`)."""
    job = getattr(node, _JOB_ATTR, None)
    return job if isinstance(job, JobFile) else None


def use_job(node: Node, role: str) -> JobFile | None:
    """Declare ``job`` on ``node`` and read the file it names (once); None without one.

    From then on every :func:`declare_from_dataclass` on the node takes its defaults from the
    file, and an explicit ``-p`` still wins (a declared default yields to an override).
    """
    known = node_job(node)
    if known is not None or node.has_parameter(JOB_PARAMETER):
        return known
    desc = ParameterDescriptor(name=JOB_PARAMETER, type=Parameter.Type.STRING.value, read_only=True,
                               description="Job file written by bench.py (msd_bench.app.job); "
                                           "empty: the parameters alone")
    try:
        path: object = node.declare_parameter(JOB_PARAMETER, "", desc).value
    except ParameterException as exc:
        raise ConfigError(f"parameter {JOB_PARAMETER}: {_one_line(exc)}") from None
    if not path:
        return None
    job = JobFile.read(str(path), role)
    setattr(node, _JOB_ATTR, job)
    return job


def check_job_used(node: Node) -> None:
    """Once a node has declared everything: a job field no declaration took is one JobError line."""
    job = node_job(node)
    if job is not None:
        job.check_used()


def declare_config(node: Node, cls: type[T], role: str) -> T:
    """The node's config: from its job file (``-p job:=<path>``) if given, else from ``-p`` parameters.

    Either way every field is declared as a read-only parameter (``ros2 param get`` shows
    what the node runs with); with a job file its values are the parameters' defaults, so
    an explicit ``-p`` still wins.
    """
    use_job(node, role)
    return declare_from_dataclass(node, cls)
