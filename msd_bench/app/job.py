"""One job description per node process, written by one function from the run configuration.

Why: bench.py used to flatten a run into ``-p key:=value`` strings and every
node config re-declared ``episodes``, ``steps``, ``dt = 0.01``, ``force = 10.0``
with defaults of its own, so the two engines could drift apart without a test
noticing. Now :func:`job_document` is the only place a node's job is built from
a :class:`~msd_bench.app.config.RunConfig`; bench.py writes it to a file in the
run directory and hands the node its path (``-p job:=<path>``). The shared
quantities' defaults are read from the run configuration's type
(:data:`SHARED_DEFAULTS`), so a node started by hand with ``-p`` parameters
gets the same defaults as the in-process engine.

A document is ``{"schema": "msd-bench.job", "version": 1, "role": ROLE,
"params": {...}}``; :func:`read_job` reads one back with the bounded reader and
checks the envelope. Field names, types and ranges are the node config's
(checked where the node builds its config: :mod:`msd_bench.nodes.params`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from msd_bench.app.config import RunConfig
from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.plant import PlantParams, preset
from msd_bench.core.rigs.rest import RestConfig
from msd_bench.io.storage.safe_read import read_json_bounded

JOB_SCHEMA = "msd-bench.job"
"""The ``schema`` of every job document."""
JOB_VERSION = 1
"""The only version read; a change of meaning bumps it."""
MAX_JOB_BYTES = 1 << 20
"""Largest job file read (1 MiB): a real one is under 2 KiB."""


class JobError(ConfigError):
    """A job file that cannot be used: the message names the file and the field."""


def _run_default(name: str) -> Any:
    """The default of ``RunConfig.<name>``, read from the type (no instance, no agent check)."""
    for f in dataclasses.fields(RunConfig):
        if f.name == name:
            return f.default
    raise KeyError(name)


DEFAULT_PLANT: PlantParams = preset(str(_run_default("preset")))
"""The run configuration's default plant: its ``dt``, ``F`` and ``L`` are the nodes' defaults."""

SHARED_DEFAULTS: Mapping[str, Any] = {
    **{name: _run_default(name) for name in (
        "episodes", "steps", "planning_steps", "validation_steps", "window", "target", "shaping",
        "nlarx_scale")},
    "plant_episodes": _run_default("dyna_episodes"),
    "dt": DEFAULT_PLANT.dt,
    "force": DEFAULT_PLANT.F,
    "stroke": DEFAULT_PLANT.L,
}
"""The quantities a run shares with its nodes, declared once: node configs take their defaults
from here (a test fails on a node config that re-declares one with a literal default)."""


SHARED_ALIASES: Mapping[str, str] = {"force_limit": "force"}
"""Node config fields that are a shared quantity under another name (the surrogate's saturation
is the plant's F): they too take their default from :data:`SHARED_DEFAULTS`."""


def shared(name: str) -> Any:
    """The default of shared quantity ``name`` (for a node config's ``field(default=...)``)."""
    return SHARED_DEFAULTS[SHARED_ALIASES.get(name, name)]


def agent_params(run: RunConfig) -> dict[str, Any]:
    """An agent's run quantities: what :func:`msd_bench.designs.protocol.settings_from` makes the
    design's :class:`~msd_bench.designs.protocol.Settings` of, in-process and in the agent node alike.
    Both budgets travel; which one a kind spends is its design's rule, stated there once."""
    p = run.plant
    return {
        "steps": run.steps, "validation_steps": run.validation_steps, "window": run.window,
        "target": float(run.target), "dt": p.dt, "force": p.F, "stroke": p.L, "shaping": run.shaping,
        "decision_samples": run.decision_samples,
        "episodes": run.episodes, "plant_episodes": run.dyna_episodes, "planning_steps": run.planning_steps,
        "pace": 1.0, **rest_params(run),
    }


def rest_params(run: RunConfig) -> dict[str, Any]:
    """The stillness test of a node that waits for rest on a rig (agent, excitation): the default test
    on the run's rig (:meth:`RestConfig.scaled`: the same seconds and share of the stroke); nothing
    on the paper's plant, whose nodes keep their own defaults."""
    if run.scales.is_default:
        return {}
    rest = RestConfig().scaled(run.scales)
    return {"rest_window": rest.window, "rest_threshold": rest.threshold}


def hold_params(run: RunConfig) -> dict[str, float]:
    """The run's stated hold loop as a job's ``hold_*`` parameters (none on a bare rig): the
    identifier's and the agent's read it alike."""
    hold = run.hold
    return {} if hold is None else hold.params()


def _identifier_params(run: RunConfig, seed: int) -> dict[str, Any]:
    p = run.plant
    return {"models": list(run.surrogates_needed()), "nlarx_scale": float(run.nlarx_scale), "seed": seed,
            "stroke": p.L, "force": p.F, "dt": p.dt, **hold_params(run)}  # the held system is identified


def _excitation_params(run: RunConfig) -> dict[str, Any]:
    # the real-time period; the signal is the experiment's (placement)
    return {"dt": run.plant.dt, **rest_params(run)}


def _recorder_params(_run: RunConfig) -> dict[str, Any]:
    return {}  # a recorder stores what it is told to: nothing of it is a run quantity


def _surrogate_params(run: RunConfig) -> dict[str, Any]:
    p = run.plant
    return {"dt": p.dt, "force_limit": p.F}  # what the model artifact does not carry


_RUN_PARAMS = {"excitation": _excitation_params, "recorder": _recorder_params,
               "surrogate": _surrogate_params}
"""The roles whose run quantities depend on the run alone (the agent's and identifier's take more)."""

ROLES = ("agent", "identifier", *_RUN_PARAMS)
"""The node roles a job document is written for (one schema each: the node configs' fields, by
parameter name: ``prbs.bias`` for a section declared under ``prbs.``)."""


def job_document(role: str, run: RunConfig, placement: Mapping[str, Any], *, seed: int = 0) -> dict[str, Any]:
    """The job of one node of ``role`` in ``run``: the run's quantities plus where it runs.

    ``placement`` is what only the graph knows (paths, namespaces, the kind and its seeds,
    lock-step); it may not restate a quantity the run configuration decides, so the two
    engines cannot disagree on one. ``seed`` (identifier): the identification seed.
    """
    if role == "agent":
        params = agent_params(run)
    elif role == "identifier":
        params = _identifier_params(run, seed)
    elif role in _RUN_PARAMS:
        params = _RUN_PARAMS[role](run)
    else:
        raise ConfigError(f"unknown job role {role!r}; choose from {', '.join(ROLES)}")
    clash = sorted(set(placement) & set(params))
    if clash:
        raise ConfigError(f"{role} job: {clash[0]} comes from the run configuration, not the placement")
    return {"schema": JOB_SCHEMA, "version": JOB_VERSION, "role": role, "params": {**params, **placement}}


def read_job(path: str | Path, role: str) -> dict[str, Any]:
    """The ``params`` of the job file at ``path`` for a node of ``role``; JobError naming file and field."""
    try:
        doc = read_json_bounded(Path(path), JobError, max_bytes=MAX_JOB_BYTES)
    except JobError as exc:  # the reader names the path; say what it is
        raise JobError(f"job file {exc}") from None
    if not isinstance(doc, dict):
        raise JobError(f"job file {path}: expected a JSON object, got {type(doc).__name__}")
    unknown = sorted(set(doc) - {"schema", "version", "role", "params"})
    if unknown:
        raise JobError(f"job file {path}: unknown field {unknown[0]!r}")
    if doc.get("schema") != JOB_SCHEMA:
        raise JobError(f"job file {path}: field schema must be {JOB_SCHEMA!r}, got {doc.get('schema')!r}")
    version = doc.get("version")
    if type(version) is not int or version != JOB_VERSION:
        raise JobError(f"job file {path}: field version {version!r} is not supported (this build reads "
                       f"{JOB_VERSION})")
    if doc.get("role") != role:
        raise JobError(f"job file {path}: field role is {doc.get('role')!r}, but this node is a {role!r}")
    params = doc.get("params")
    if not isinstance(params, dict):
        raise JobError(f"job file {path}: field params must be an object")
    return params
