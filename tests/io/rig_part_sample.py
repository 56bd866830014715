"""A valid rig task result (as ``app/rigs.rig_task`` writes it) for the reader's tests, built by hand."""

from __future__ import annotations

from typing import Any

from msd_bench.app.config import RunConfig
from msd_bench.app.rigs import RigsConfig
from msd_bench.io.rigs.rigs_report import PARAMETERS

KINDS = ("glm", "glm+robust")
SCENARIOS = ("setpoint=-0.5",)
CFG = RigsConfig(RunConfig(seeds=1, agents=KINDS), rigs=1, scenarios=SCENARIOS, resamples=100)


def part(seed: int = 1000) -> dict[str, Any]:
    """Rig ``seed``'s result: one identified run that succeeded, one kind that could not be identified."""
    ok = {"kind": "glm", "seed": 0, "identified": True, "success": True, "mae": 0.1, "std": 0.1, "po": 1.0,
          "ts": 5.0, "ts5": 4.0, "sse": 1.0, "sse_measured": 1.2, "success_measured": True,
          "rest_samples": 300, "rest_still": True, "start_x": 0.002,
          "scenarios": {"setpoint=-0.5": {"sse": 9.0, "success": False, "sse_measured": 9.5}}}
    return {"rig": seed, "design": False, "parameters": dict.fromkeys(PARAMETERS, 1.0),
            "rests": {"before_experiments": [300], "not_still": 0}, "fits": {},
            "identification_failed": {"nope": "rig 1000: why"},
            "outcomes": [ok, {"kind": "glm+robust", "seed": 0, "success": False, "identified": False}],
            "seconds": {"play": 1.0, "identify": 1.0, "train": 1.0, "validate": 1.0, "total": 4.0}}
