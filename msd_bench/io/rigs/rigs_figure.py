"""``rigs.png``: each rig's success fraction against each of its parameters, a colour per agent kind.

Drawn from ``rigs.json`` only. One panel per parameter, so a parameter that
ruins a kind (friction for the PLM, the lag for the paper agent) shows as a
slope; points are jittered a little sideways where a parameter takes few values
(delay, quantisation).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from msd_bench.io.rigs.rigs_report import columns
from msd_bench.io.storage.atomic import save_figure_atomic


def rigs_figure(path: Path, doc: Mapping[str, Any], root: Path | None = None) -> Path:
    """Success fraction per rig (over its seeds) against each parameter, a series per kind."""
    params, cols = columns(doc), 3
    rows = -(-len(params) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(11, 3.0 * rows), squeeze=False)
    jitter = np.random.default_rng(0)
    for ax, column in zip(axes.flat, params, strict=False):
        values = np.array([float(r["parameters"][column.key]) for r in doc["rigs"]])
        spread = np.ptp(values) if values.size else 0.0
        for i, kind in enumerate(doc["agents"]):
            frac = []
            for r in doc["rigs"]:
                runs = [o for o in r["outcomes"] if o["kind"] == kind]
                frac.append(sum(bool(o["success"]) for o in runs) / max(1, len(runs)))
            few = len(set(values)) < 5
            shift = jitter.uniform(-0.01, 0.01, values.size) * (spread or 1.0) if few else 0.0
            ax.scatter(values + shift, 100 * np.array(frac) + 1.5 * (i - len(doc["agents"]) / 2), s=12,
                       alpha=0.7, label=kind)
        ax.set_xlabel(f"{column.key} ({column.unit})")
        ax.set_ylabel("success (%)")
        ax.set_ylim(-8, 108)
        ax.grid(True, alpha=0.3)
    for ax in list(axes.flat)[len(params):]:
        ax.set_visible(False)
    axes[0, 0].legend(fontsize=7, loc="lower left")
    fig.suptitle(f"Success per rig against each parameter ({len(doc['rigs'])} {doc['rig_set']} rigs)")
    try:
        fig.tight_layout()
        return save_figure_atomic(fig, path, root=root)
    finally:
        plt.close(fig)
