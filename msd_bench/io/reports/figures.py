"""PNG figures like the paper's: model fits (Fig. 3–5), Q-table heat maps (Fig. 6/7/11/12)
and closed-loop step responses (Fig. 13), drawn headless with matplotlib's Agg backend."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray

from msd_bench.io.storage.atomic import save_figure_atomic

FloatArray = NDArray[np.float64]


def fit_figure(
    path: Path,
    title: str,
    panels: Sequence[tuple[str, FloatArray, FloatArray, float]],
    dt: float = 0.01,
    max_seconds: float = 60.0,
    root: Path | None = None,
) -> Path:
    """Measured vs simulated output, one panel per record: ``(label, y, yhat, fit %)``."""
    fig, axes = plt.subplots(len(panels), 1, figsize=(9, 2.2 * len(panels) + 0.6), squeeze=False)
    for ax, (label, y, yhat, fit) in zip(axes[:, 0], panels, strict=True):
        n = min(len(y), int(max_seconds / dt))
        t = np.arange(n) * dt
        ax.plot(t, y[:n], lw=1.0, label="measured")
        ax.plot(t, yhat[:n], lw=1.0, ls="--", label=f"model (fit {fit:.1f} %)")
        ax.set_ylabel(f"{label}\nx (m)")
        ax.legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("time (s)")
    fig.suptitle(title)
    return _save(fig, path, root)


def qtable_figure(path: Path, title: str, first: FloatArray, last: FloatArray,
                  root: Path | None = None) -> Path:
    """Filled contours of Q(s, a) after the first and after the last episode."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, q, when in zip(axes, (first, last), ("after episode 1", "after the last episode"), strict=True):
        q2 = np.asarray(q, dtype=float).reshape(q.shape[0], -1)
        actions, states = np.arange(q2.shape[1]) + 1, np.arange(q2.shape[0]) + 1
        cs = ax.contourf(actions, states, q2, levels=20, cmap="viridis")
        fig.colorbar(cs, ax=ax)
        ax.set_xlabel("action index")
        ax.set_ylabel("state index")
        ax.set_title(when)
    fig.suptitle(title)
    return _save(fig, path, root)


def step_response_figure(
    path: Path,
    responses: Mapping[str, FloatArray],
    target: float = 1.0,
    dt: float = 0.01,
    band: float = 0.02,
    root: Path | None = None,
) -> Path:
    """Position and |error| of greedy agents on the true plant (Fig. 13), a panel per agent kind.

    Every seed is drawn thinly so the spread across seeds is visible, the median
    response thickly; the ±band around the target is shaded.
    """
    kinds = list(responses)
    ncols = min(5, len(kinds))
    nrows = -(-len(kinds) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.4 * ncols, 2.8 * nrows), squeeze=False,
                             sharex=True, sharey=True)
    for ax, kind in zip(axes.flat, kinds, strict=False):
        runs = np.asarray(responses[kind], dtype=float)
        t = np.arange(runs.shape[1]) * dt
        for x in runs:
            ax.plot(t, x, lw=0.5, alpha=0.3, color="tab:blue")
            ax.plot(t, np.abs(x - target), lw=0.4, alpha=0.25, color="tab:red")
        ax.plot(t, np.median(runs, axis=0), lw=1.5, color="navy", label="median x")
        ax.axhspan(target * (1 - band), target * (1 + band), color="green", alpha=0.2)
        ax.set_title(f"{kind} (n={len(runs)})", fontsize=9)
        ax.set_ylim(-0.2, 2.6)
    for ax in axes.flat[len(kinds):]:
        ax.axis("off")
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    for ax in axes[:, 0]:
        ax.set_ylabel("x (blue), |e| (red), m")
    fig.suptitle(f"Closed loop on the true plant, unit step (±{100 * band:.0f} % band shaded)")
    return _save(fig, path, root)


def efficiency_figure(path: Path, methods: Sequence[Mapping[str, Any]], root: Path | None = None) -> Path:
    """Success rate against real-plant samples, log x-axis, a line per method with its 95 % band."""
    fig, ax = plt.subplots(figsize=(8, 4.8))
    for m in methods:
        pts = sorted(m["points"], key=lambda p: p["real_samples"])
        x = np.array([p["real_samples"] for p in pts], dtype=float)
        rate = np.array([p["n_success"] / p["n"] for p in pts])
        lo = np.array([p["ci95"][0] for p in pts])
        hi = np.array([p["ci95"][1] for p in pts])
        (line,) = ax.plot(x, 100 * rate, marker="o", label=m.get("label", m["name"]))
        ax.fill_between(x, 100 * lo, 100 * hi, color=line.get_color(), alpha=0.15)
    ax.set_xscale("log")
    ax.set_xlabel("real-plant samples used (identification records, or training steps)")
    ax.set_ylabel("success rate (%), Wilson 95 % band")
    ax.set_ylim(-2, 102)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    fig.suptitle("Data efficiency: success on the true plant vs real samples")
    return _save(fig, path, root)


def _save(fig: Figure, path: Path, root: Path | None) -> Path:
    """Write the PNG atomically, staying inside ``root`` (default: the figure's directory)."""
    path = Path(path)
    try:
        fig.tight_layout()
        return save_figure_atomic(fig, path, root=root)
    finally:
        plt.close(fig)
