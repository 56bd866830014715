"""``drive.json``: what the broad training record's bag shows of the drive, for the agents to be told.

Why a file beside the models: the identifier reads the bags (and fits the actuator between their
commands and effort, :func:`msd_bench.core.rigs.actuation.effort_agreement`); the agent jobs are
written by the graph, which reads no bag. The identifier writes it before any model, so an agent
started as soon as its surrogate is written finds it.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from msd_bench.core.rigs.actuation import EffortAgreement
from msd_bench.io.bags.bag_interface import ForceSource
from msd_bench.io.bags.bag_records import BagRole
from msd_bench.io.storage.atomic import write_text_atomic

DRIVE_FILE = "drive.json"


def broad_drive(roles: Sequence[BagRole], sources: Sequence[ForceSource]) -> EffortAgreement | None:
    """The actuator fitted on the broad training bag (``sources`` in ``roles`` order, as
    :func:`~msd_bench.io.bags.bag_records.load_records` fills them); None: its bag showed none (no
    commands recorded, or a constant effort)."""
    for role, src in zip(roles, sources, strict=False):
        if role.role == "train" and role.bias is None:
            return src.agreement
    return None


def write_drive(out: Path, drive: EffortAgreement | None) -> Path:
    """``out/drive.json`` (``{"drive": null}`` when the bags showed no drive), atomically."""
    doc: dict[str, Any] = {"drive": None if drive is None else {
        "delay_samples": int(drive.delay_samples), "lag_s": float(drive.time_constant_s),
        "fit_percent": float(drive.fit_percent)}}
    return write_text_atomic(out / DRIVE_FILE, json.dumps(doc, indent=1) + "\n", root=out)


def read_drive(models_dir: Path) -> tuple[int, float] | None:
    """(delay in samples, lag in s) of ``models_dir/drive.json``; None when absent or showing none."""
    path = models_dir / DRIVE_FILE
    if not path.is_file():
        return None
    drive = json.loads(path.read_text()).get("drive")
    if not isinstance(drive, dict):
        return None
    return int(drive["delay_samples"]), float(drive["lag_s"])
