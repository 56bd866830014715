"""The surrogate node: an identified model artifact served as a plant-like node (docs/design.md §Nodes).

It is :class:`PlantNode` with a different :class:`ModelSpec`: the model comes
from ``model_path`` (:func:`msd_bench.io.storage.artifacts.load_model`), so a surrogate
speaks exactly the plant's contract and sample alignment, in both clock modes,
and an agent or a recorder is pointed at it by a namespace remap alone.

The namespace defaults to ``/surrogate/<model name>`` (``-r __ns:=...``
overrides it). The name is in the artifact, which is only known once the
parameters are read, so :func:`build_surrogate` reads them first with a
short-lived loader node and then builds the real one.

A surrogate does not publish ``/clock`` unless asked (``-p publish_clock:=true``):
in a ``--via-ros`` graph the plant and every surrogate run in lock-step side
by side, and only one node may own sim time (the plant).

bench.py hands it a job file (``-p job:=<file>``, role ``surrogate``,
:func:`msd_bench.app.job.job_document`): the model path and the plant node's
``lockstep`` as placement, ``dt`` and ``force_limit`` from the run's plant.
Started by hand, ``-p`` parameters alone do; their defaults are the run
configuration's (:func:`msd_bench.app.job.shared`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rclpy.node import Node

from msd_bench.app.job import shared
from msd_bench.core.errors import ConfigError
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel, check_rate
from msd_bench.io.storage.artifacts import load_model
from msd_bench.nodes.params import declare_config, use_job
from msd_bench.nodes.plant_node import ModelSpec, PlantNode, PlantNodeConfig
from msd_msgs_py.contract import surrogate_namespace as namespace_for


@dataclass(frozen=True)
class SurrogateConfig:
    """Which model artifact to serve, and the two facts a model artifact does not carry."""

    model_path: str = ""
    """Model artifact to serve (JSON from the identifier, e.g. bags/<run>/models/plm.json); required."""
    dt: float = field(default=shared("dt"), metadata={"range": (1e-4, 10.0)})
    """Sample time in s the model was identified at (real-time period, lock-step clock increment)."""
    force_limit: float = field(default=shared("force_limit"), metadata={"range": (1e-6, 1e6)})
    """Commands are saturated to ±force_limit N before they act (the plant's F)."""

    def __post_init__(self) -> None:
        if not self.model_path:
            raise ConfigError("model_path is required (a model artifact, e.g. bags/<run>/models/plm.json)")


def load_spec(config: SurrogateConfig) -> ModelSpec:
    """The artifact at ``config.model_path`` as a :class:`ModelSpec` (ArtifactError if unreadable)."""
    model = load_model(Path(config.model_path))
    check_rate(model, config.dt, "the surrogate node (parameter dt)")
    return ModelSpec(model, config.dt, config.force_limit)


ROLE = "surrogate"
"""The surrogate's job role (:mod:`msd_bench.app.job`)."""


def declare_surrogate(node: Node) -> ModelSpec:
    """Declare the :class:`SurrogateConfig` parameters on ``node`` (from its job file if given) and
    load the model."""
    return load_spec(declare_config(node, SurrogateConfig, ROLE))


class SurrogateNode(PlantNode):
    """The plant node serving a model artifact; its job file is read before any parameter is declared,
    so the plant node's own parameters (``lockstep``) come from it too."""

    def _declare_config(self) -> PlantNodeConfig:
        use_job(self, ROLE)
        return super()._declare_config()


def surrogate_namespace(model: StepModel) -> str:
    """``/surrogate/<name>`` (:func:`msd_msgs_py.contract.surrogate_namespace`; the kind if unnamed)."""
    return namespace_for(model.name or kernels.KIND_NAMES[model.kind])


def build_surrogate(*, namespace: str | None = None, **node_kwargs: Any) -> PlantNode:
    """A plant-like node serving ``model_path`` under ``namespace`` (default from the model name).

    ``node_kwargs`` go to both nodes (``context``, ``parameter_overrides`` in tests);
    a missing or unreadable artifact raises one-line ConfigError/ArtifactError.
    """
    if namespace is None:
        loader = Node("surrogate_loader", start_parameter_services=False, **node_kwargs)
        try:
            namespace = surrogate_namespace(declare_surrogate(loader).model)
        finally:
            loader.destroy_node()
    return SurrogateNode(declare_surrogate, node_name="surrogate", namespace=namespace, clock_owner=False,
                         **node_kwargs)
