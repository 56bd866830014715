"""Gymnasium environment of the paper's set-point task: ``import msd_bench.gym`` registers it.

``gymnasium.make("MsdBench-v0")`` steps the emulated NL-MSD in-process;
``model="models/plm.json"`` steps a fitted surrogate instead, and
``ros_namespace="/msd"`` steps a lock-step plant-like node over ROS 2. See
:mod:`msd_bench.gym.env` for the spaces and the reward.
"""

from __future__ import annotations

import gymnasium

ENV_ID = "MsdBench-v0"

if ENV_ID not in gymnasium.registry:  # a re-import must not warn about overriding the entry
    gymnasium.register(id=ENV_ID, entry_point="msd_bench.gym.env:MsdBenchEnv")

__all__ = ["ENV_ID"]
