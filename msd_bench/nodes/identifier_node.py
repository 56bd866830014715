"""The identifier node: bags in, surrogate model artifacts and fit reports out.

It reads the experiment bags of a run (ours describe themselves; a rig's are
described by parameters), fits the requested surrogates (GLM, PLM, NLARX paper
and improved, grey-box: any kind of the model registry;
:func:`msd_bench.app.pipeline.identify_surrogates`), writes one
JSON artifact per model with provenance (bag paths and content hashes, the
parameters, the seed) and ``fits.json``, then finishes. It is a ROS node so
it runs, logs and is configured like every other part of the bench.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rclpy.node import Node
from rclpy.task import Future

from msd_bench.app.bag_identification import IdentifierConfig, identify_from_bags
from msd_bench.app.serve_protocol import event_line
from msd_bench.io.bags.bag_interface import ForceSource
from msd_bench.nodes.interface_params import declare_interface
from msd_bench.nodes.params import declare_config

SAVED = "saved model {name}: {path}"
"""The line the node logs as each model is written, for people; a launcher reads the event."""
SAVED_EVENT = "model_saved"
"""The structured event announcing each model written (``model``, ``path``): a launcher can start
that model's agents then (:func:`msd_bench.app.serve_protocol.event_line`)."""
IDENTIFIED_EVENT = "identified"
"""The structured event announcing the end: every model and ``fits.json`` are written."""
NODE_NAME = "identifier"
"""The node's name, which its events carry."""


class IdentifierNode(Node):
    """Runs :func:`identify_from_bags` once, then completes ``done``."""

    def __init__(self, config: IdentifierConfig | None = None, **node_kwargs: Any) -> None:
        super().__init__(NODE_NAME, **node_kwargs)
        self.config = config or declare_config(self, IdentifierConfig, "identifier")
        self.interface = declare_interface(self)
        self.sources: list[ForceSource] = []
        self.done: Future[int] = Future()
        self.report: dict[str, Any] = {}
        self._timer = self.create_timer(0.01, self._run)

    def _run(self) -> None:
        self._timer.cancel()
        self.report = identify_from_bags(self.config, self.interface, self.sources, self._saved,
                                         self._failed)
        for src in self.sources:
            self.get_logger().info(src.line())
        for name, f in self.report.items():
            self.get_logger().info(
                f"{name}: fit {f['sim_fit']:.1f} % (simulation), {f['one_step_fit']:.2f} % (one-step)")
        print(event_line(NODE_NAME, IDENTIFIED_EVENT, {"models": sorted(self.report)}), flush=True)
        self.done.set_result(0)

    def _failed(self, name: str, why: str) -> None:
        self.get_logger().error(f"{name} could not be fitted (the other kinds still are): {why}")

    def _saved(self, name: str, path: Path) -> None:
        self.get_logger().info(SAVED.format(name=name, path=path))
        print(event_line(NODE_NAME, SAVED_EVENT, {"model": name, "path": str(path)}), flush=True)
