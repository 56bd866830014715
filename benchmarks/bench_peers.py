"""Our identification beside the peer libraries, on the same records, clean and with a noisy sensor.

Usage (the peers are an optional extra; SysIdentPy caps numpy at 2.3.5, so use a separate venv)::

    python -m venv .venv-peers && .venv-peers/bin/pip install torch==2.13.0 && \\
        .venv-peers/bin/pip install -e ".[peers]"
    .venv-peers/bin/python benchmarks/bench_peers.py [--id-seeds 3] [--noise 0 0.002] \
        [--out docs/results/peers.json]

For every identification seed (excitation seeds as ``msd-bench paper``'s) and
every sensor noise level, the records are made in process, each method is
fitted on the training record(s) and scored on the broad validation record:

* ``sim_fit_truth`` — free-run simulation from an estimated initial state
  (least squares on the first 300 samples, as MATLAB ``compare``), Best-Fit
  against the noise-free truth; ``sim_fit`` the same against the measurement;
* ``one_step_fit`` — one-step-ahead prediction from the measured history,
  beside the naive baselines (repeat the last sample; constant velocity
  ``2y[k-1] - y[k-2]``) so nobody reads 99.9 % one-step as quality;
* ``fit_seconds`` — wall time of the fit on this (shared, 2-core) machine.

Methods: ours (GLM, PLM, NLARX improved, grey-box) through
:mod:`msd_bench.core.identification.identify`; SysIdentPy FROLS (polynomial NARX of degree 3,
lags 2) with AIC order selection and with 20 terms forced; PySINDy with a
polynomial (degree 3) + sin library on the state (x, v) and the force u,
stop samples masked, derivatives by Euler-consistent differences on clean
records and by Savitzky-Golay from positions only on noisy ones (the force
smoothed by the same filter, so both sides of the equation see it). The sin
library holds sin(x) with the spring's spatial frequency g = 1, an advantage
the grey-box (which fits g) does not get. There is no floor: this is a
comparison; the JSON (with command, commit and machine) goes to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import savgol_filter

from msd_bench.core.identification import identify
from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.identification.excitation import MultilevelConfig, PrbsConfig
from msd_bench.core.identification.fit import fit_percent
from msd_bench.core.identification.nlarx import NlarxConfig
from msd_bench.core.identification.plm import PLM_BIASES
from msd_bench.core.physics import plant
from msd_bench.core.physics.sensor import SensorModel, clear_of_stops

FloatArray = np.ndarray
Simulator = Callable[[FloatArray, FloatArray], FloatArray]
"""(u, y_head) -> free-run y over u, started from the first two values of y_head."""


@dataclass(frozen=True)
class Records:
    bias_train: dict[float, IOData]
    broad_train: IOData
    broad_val: IOData


def make_records(p: plant.PlantParams, id_seed: int, sensor: SensorModel) -> Records:
    """The paper's records of one identification seed (seeds as the pipeline's ``record_seeds``)."""
    train_seed, val_seed = 1000 + 10 * id_seed, 5000 + 10 * id_seed
    return Records(
        {b: identify.bias_record(p, b, train_seed + i, PrbsConfig(), sensor)
         for i, b in enumerate(PLM_BIASES)},
        identify.broad_record(p, train_seed + 7, MultilevelConfig(), sensor),
        identify.broad_record(p, val_seed + 7, MultilevelConfig(n_samples=4000), sensor),
    )


def score_ours(name: str, rec: Records, p: plant.PlantParams, id_seed: int) -> dict[str, Any]:
    t0 = time.perf_counter()
    if name == "glm":
        model = identify.identify_glm(rec.broad_train, identify.GlmConfig(stroke=p.L))
    elif name == "plm":
        model = identify.identify_plm(rec.bias_train, identify.PlmConfig(stroke=p.L))
    elif name == "greybox":
        model = identify.identify_greybox(rec.broad_train, identify.GreyboxConfig(stroke=p.L, force=p.F))
    else:
        cfg = NlarxConfig(form=name.removeprefix("nlarx-"), seed=id_seed)
        model = identify.identify_nlarx(rec.broad_train, cfg, p.L)
    seconds = time.perf_counter() - t0
    r = identify.evaluate(model, rec.broad_val)
    return {"sim_fit_truth": r.sim_fit_truth, "sim_fit": r.sim_fit, "sim_fit_raw_start": r.sim_fit_raw_start,
            "one_step_fit": r.one_step_fit, "fit_seconds": seconds}


def score_peer(sim: Simulator, one_step: Callable[[Experiment], FloatArray], seconds: float,
               valid: IOData, extra: dict[str, Any]) -> dict[str, Any]:
    """Estimated-start free run and one-step of a peer model, scored like ours."""
    e = valid.experiments[0]
    n = identify.INIT_HORIZON
    scale = max(float(np.std(e.y[:n])), 1e-6)

    def head_residual(z: FloatArray) -> FloatArray:
        out = sim(e.u[:n], np.array([z[0], z[1]]))
        return np.nan_to_num((out - e.y[:n]) / scale, nan=1e6, posinf=1e6, neginf=-1e6)

    z = least_squares(head_residual, e.y[:2].copy(), method="lm", max_nfev=200).x
    yhat = sim(e.u, z)
    ok = bool(np.all(np.isfinite(yhat)))
    yhat = np.nan_to_num(yhat, nan=0.0, posinf=1e3, neginf=-1e3)
    return {"sim_fit_truth": fit_percent(e.y_true, yhat) if ok else None,
            "sim_fit": fit_percent(e.y, yhat) if ok else None,
            "one_step_fit": fit_percent(e.y, one_step(e)), "fit_seconds": seconds,
            "finite": ok, **extra}


def sysidentpy_peer(rec: Records, forced_terms: int | None) -> dict[str, Any]:
    from sysidentpy.basis_function import Polynomial
    from sysidentpy.model_structure_selection import FROLS
    from sysidentpy.parameter_estimation import LeastSquares

    tr = rec.broad_train.experiments[0]
    kw: dict[str, Any] = ({"order_selection": True, "info_criteria": "aic", "n_info_values": 25}
                          if forced_terms is None else {"order_selection": False, "n_terms": forced_terms})
    model = FROLS(ylag=2, xlag=2, basis_function=Polynomial(degree=3), estimator=LeastSquares(),
                  model_type="NARMAX", **kw)  # NARMAX without noise terms: a NARX
    t0 = time.perf_counter()
    model.fit(X=tr.u[:, None], y=tr.y[:, None])
    seconds = time.perf_counter() - t0

    def sim(u: FloatArray, head: FloatArray) -> FloatArray:
        y0 = np.zeros((u.size, 1))
        y0[:2, 0] = head
        return np.ravel(model.predict(X=u[:, None], y=y0[:2]))[: u.size]

    def one(e: Experiment) -> FloatArray:
        return np.ravel(model.predict(X=e.u[:, None], y=e.y[:, None], steps_ahead=1))[: e.u.size]

    terms = int(np.asarray(model.final_model).shape[0])
    return score_peer(sim, one, seconds, rec.broad_val, {"terms": terms})


def sindy_peer(rec: Records, p: plant.PlantParams, noisy: bool) -> dict[str, Any]:
    import pysindy as ps

    tr = rec.broad_train.experiments[0]
    dt = rec.broad_train.dt
    t0 = time.perf_counter()
    if noisy:  # derivatives from positions only, Savitzky-Golay (window 31, cubic)
        x = savgol_filter(tr.y, 31, 3)
        v = savgol_filter(tr.y, 31, 3, deriv=1, delta=dt)
        a = savgol_filter(tr.y, 31, 3, deriv=2, delta=dt)
        u_fit = savgol_filter(tr.u, 31, 3)  # the same smoothing on the force keeps the equation aligned
        free = clear_of_stops(tr.y, p.L, 31)
    else:  # Euler-consistent differences: v_k = (x_k - x_{k-1})/dt, a_k = (x_{k+1} - 2x_k + x_{k-1})/dt²
        x = tr.y
        v = np.concatenate([[0.0], np.diff(tr.y)]) / dt
        a = np.concatenate([[0.0], np.diff(tr.y, 2), [0.0]]) / dt**2
        u_fit = tr.u
        free = clear_of_stops(tr.y, p.L, 1)
    free[:2] = False
    free[-2:] = False
    state = np.column_stack([x, v])[free]
    deriv = np.column_stack([v, a])[free]
    lib = ps.PolynomialLibrary(degree=3) + ps.CustomLibrary(
        library_functions=[lambda s: np.sin(s)], function_names=[lambda s: f"sin({s})"])
    model = ps.SINDy(feature_library=lib, optimizer=ps.STLSQ(threshold=0.05))
    model.fit(state, t=dt, x_dot=deriv, u=u_fit[free][:, None], feature_names=["x", "v", "u"])
    seconds = time.perf_counter() - t0
    coef = model.coefficients()[1]
    names = model.get_feature_names()

    def accel(xk: float, vk: float, uk: float) -> float:
        return float(model.predict(np.array([[xk, vk]]), u=np.array([[uk]]))[0, 1])

    def step(xk: float, vk: float, uk: float) -> tuple[float, float]:
        """Euler step with the plant's hard stops (the stroke is known, as for the grey-box)."""
        vn = vk + dt * accel(xk, vk, min(max(uk, -p.F), p.F))
        xf = xk + dt * vn
        xn = min(max(xf, -p.x_max), p.x_max)
        return xn, (0.0 if xn != xf else vn)

    def sim(u: FloatArray, head: FloatArray) -> FloatArray:
        out = np.empty(u.size)
        out[0], xk, vk = head[0], head[1], (head[1] - head[0]) / dt
        for k in range(1, u.size):
            out[k] = xk
            if not (np.isfinite(xk) and np.isfinite(vk)):
                out[k:] = np.nan
                break
            xk, vk = step(xk, vk, float(u[k]))
        return out

    def one(e: Experiment) -> FloatArray:
        yhat = e.y.copy()
        for k in range(2, e.y.size):
            yhat[k] = step(float(e.y[k - 1]), float((e.y[k - 1] - e.y[k - 2]) / dt), float(e.u[k - 1]))[0]
        return yhat

    model_terms = {n: float(c) for n, c in zip(names, coef, strict=True) if c != 0.0}
    return score_peer(sim, one, seconds, rec.broad_val, {"acceleration_terms": model_terms})


PEERS = ("sysidentpy-frols-aic", "sysidentpy-frols-20-terms", "pysindy-poly3-sin")


def fit_peer(method: str, rec: Records, p: plant.PlantParams, noisy: bool) -> dict[str, Any]:
    if method == "sysidentpy-frols-aic":
        return sysidentpy_peer(rec, None)
    if method == "sysidentpy-frols-20-terms":
        return sysidentpy_peer(rec, 20)
    return sindy_peer(rec, p, noisy)


def run(id_seeds: int, noises: list[float], ours: list[str]) -> dict[str, Any]:
    p = plant.preset("default")
    rows: list[dict[str, Any]] = []
    naive: list[dict[str, Any]] = []
    for sigma in noises:
        sensor = SensorModel(noise_std=sigma)
        for id_seed in range(id_seeds):
            rec = make_records(p, id_seed, sensor)
            naive.append({"noise_std": sigma, "id_seed": id_seed,
                          **identify.naive_one_step_fits(rec.broad_val)})
            for method in [*ours, *PEERS]:
                fit = fit_peer(method, rec, p, sigma > 0) if method in PEERS else score_ours(
                    method, rec, p, id_seed)
                row = {"method": method, "noise_std": sigma, "id_seed": id_seed, **fit}
                rows.append(row)
                print(json.dumps({k: v for k, v in row.items() if k != "acceleration_terms"}),
                      file=sys.stderr, flush=True)
    return {"rows": rows, "naive_one_step": naive, "summary": summarise(rows)}


def summarise(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    out = []
    for method in dict.fromkeys(r["method"] for r in rows):
        for sigma in dict.fromkeys(r["noise_std"] for r in rows):
            sel = [r for r in rows if r["method"] == method and r["noise_std"] == sigma]
            sims = [r["sim_fit_truth"] for r in sel]
            finite = [s for s in sims if s is not None]
            out.append({
                "method": method, "noise_std": sigma, "n_id_seeds": len(sel),
                "sim_fit_truth_mean": float(np.mean(finite)) if finite else None,
                "sim_fit_truth_min": float(np.min(finite)) if finite else None,
                "diverged": len(sims) - len(finite),
                "one_step_fit_mean": float(np.mean([r["one_step_fit"] for r in sel])),
                "fit_seconds_mean": float(np.mean([r["fit_seconds"] for r in sel])),
            })
    return out


def provenance(argv: list[str]) -> dict[str, Any]:
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], capture_output=True, text=True, check=False).stdout.strip()

    versions = {}
    for mod in ("numpy", "scipy", "torch", "sysidentpy", "pysindy"):
        try:
            versions[mod] = __import__(mod).__version__
        except ImportError:
            versions[mod] = None
    return {
        "command": " ".join(["python", "benchmarks/bench_peers.py", *argv]),
        "git_commit": git("rev-parse", "HEAD"),
        "git_dirty": bool(git("status", "--porcelain", "--untracked-files=no")),
        "machine": {"platform": platform.platform(), "processor": platform.processor() or platform.machine(),
                    "cpus": __import__("os").cpu_count(), "python": platform.python_version()},
        "versions": versions,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--id-seeds", type=int, default=3)
    ap.add_argument("--noise", type=float, nargs="+", default=[0.0, 0.002], help="sensor noise sd, m")
    ap.add_argument("--ours", nargs="*", default=["glm", "plm", "nlarx-improved", "greybox"])
    ap.add_argument("--out", type=Path, default=Path("docs/results/peers.json"))
    args = ap.parse_args()
    try:
        import pysindy  # noqa: F401
        import sysidentpy  # noqa: F401
    except ImportError as exc:
        sys.exit(f"bench_peers needs the optional peers: pip install -e '.[peers]' ({exc.name} missing)")
    doc = {**provenance(sys.argv[1:]), **run(args.id_seeds, args.noise, args.ours)}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=1) + "\n")
    print(json.dumps({"summary": doc["summary"], "naive_one_step": doc["naive_one_step"]}, indent=1))


if __name__ == "__main__":
    main()
