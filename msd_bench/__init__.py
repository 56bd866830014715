"""msd-bench: a ROS 2 bench for system identification then off-plant Q-learning.

``import msd_bench`` stays light (no numba, torch, python-control or rclpy):
:func:`load_model` imports what it needs when called.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from msd_bench._version import __version__

if TYPE_CHECKING:
    from msd_bench.core.physics.model import StepModel

__all__ = ["__version__", "load_model"]


def load_model(path: str | os.PathLike[str]) -> StepModel:
    """The fitted model in a model artifact (``models/glm.json`` ...), ready to step.

    A linear model (the GLM) also gives python-control forms:
    ``control.step_response(msd_bench.load_model("models/glm.json").to_transfer_function())``.
    A missing or malformed file raises a one-line ``ArtifactError``.
    """
    from msd_bench.io.storage.artifacts import load_model as _load

    return _load(Path(path))
