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

from msd_bench.core.errors import ConfigError, MsdBenchError

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
    excluded fields keep their default. Raises :class:`ConfigError` with one line.
    """
    if not (dataclasses.is_dataclass(cls) and isinstance(cls, type)):
        raise TypeError(f"{cls!r} is not a dataclass")
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
