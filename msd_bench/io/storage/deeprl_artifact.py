"""The deep-RL policy artifact: weights as ``.npz`` beside a JSON meta file, loadable without SB3.

``<stem>.json`` (schema ``msd-bench/deeprl-policy`` v1) holds the algorithm,
its hyper-parameters, the SB3 and torch versions it was trained with, the
seeds, the budget, the feature scaling and the SHA-256 of ``<stem>.npz``;
the archive holds the six weight stacks (:class:`msd_bench.core.deeprl.mlp.Net`).
Reading is bounded (:mod:`msd_bench.io.storage.safe_read`, :mod:`msd_bench.io.storage.safe_npz`)
and every defect is one :class:`ArtifactError` line naming the file.
"""

from __future__ import annotations

import hashlib
import io
import json
from pathlib import Path
from typing import Any

import numpy as np

from msd_bench.core.deeprl import mlp
from msd_bench.core.deeprl.mlp import Net
from msd_bench.core.errors import MsdBenchError
from msd_bench.io.storage.artifacts import SCHEMA_VERSION, ArtifactError, jsonable
from msd_bench.io.storage.atomic import write_bytes_atomic
from msd_bench.io.storage.safe_npz import MAX_NPZ_BYTES, read_npz_bounded
from msd_bench.io.storage.safe_read import read_json_bounded

POLICY_SCHEMA = "msd-bench/deeprl-policy"
WEIGHTS = ("w1", "b1", "w2", "b2", "w3", "b3")
FEATURES = {"pos_scale": mlp.POS_SCALE, "dy_scale": mlp.DY_SCALE, "force_scale": mlp.FORCE_SCALE}
"""The input scaling the weights were trained for; a file with another is refused."""


def paths(stem: Path) -> tuple[Path, Path]:
    """The meta file and the weights archive of the artifact ``stem``."""
    stem = Path(stem)
    return stem.with_suffix(".json"), stem.with_suffix(".npz")


def save_policy(stem: Path, net: Net, meta: dict[str, Any], *, root: Path | None = None) -> Path:
    """Write the archive, then the meta naming its hash; both new files only (never overwritten)."""
    mlp.check_net(net)
    meta_path, npz_path = paths(stem)
    buf = io.BytesIO()
    arrays: dict[str, Any] = dict(zip(WEIGHTS, net[:6], strict=True))
    np.savez_compressed(buf, **arrays)
    data = buf.getvalue()
    doc = {"schema": POLICY_SCHEMA, "schema_version": SCHEMA_VERSION, **jsonable(meta),
           "activation": "relu" if net.activation == mlp.RELU else "tanh", "features": FEATURES,
           "n_policies": int(net.w1.shape[0]), "weights": npz_path.name,
           "weights_sha256": hashlib.sha256(data).hexdigest()}
    root = root or meta_path.parent
    write_bytes_atomic(npz_path, data, root=root, exclusive=True, error=ArtifactError)
    text = json.dumps(doc, indent=1, sort_keys=True) + "\n"
    write_bytes_atomic(meta_path, text.encode(), root=root, exclusive=True, error=ArtifactError)
    return meta_path


def load_policy(stem: Path) -> tuple[Net, dict[str, Any]]:
    """The network stack and the meta of an artifact, checked field by field."""
    meta_path, npz_path = paths(stem)
    if not meta_path.is_file():
        raise ArtifactError(f"{meta_path}: no such deep-RL policy artifact")
    doc = read_json_bounded(meta_path, ArtifactError)
    _check_meta(doc, meta_path)
    if not npz_path.is_file():
        raise ArtifactError(f"{npz_path}: weights archive of {meta_path.name} is missing")
    data = _read_weights(npz_path)
    if hashlib.sha256(data).hexdigest() != doc["weights_sha256"]:
        raise ArtifactError(f"{npz_path}: weights do not match the SHA-256 in {meta_path.name}")
    members = read_npz_bounded(npz_path, ArtifactError)
    if sorted(members) != sorted(WEIGHTS):
        raise ArtifactError(f"{npz_path}: members must be {', '.join(WEIGHTS)}, got {sorted(members)}")
    try:
        net = mlp.from_arrays([members[k] for k in WEIGHTS], mlp.ACTIVATIONS[doc["activation"]])
    except MsdBenchError as exc:
        raise ArtifactError(f"{npz_path}: {exc}") from None
    if net.w1.shape[0] != doc["n_policies"] or net.w3.shape[1] != 5:
        raise ArtifactError(f"{npz_path}: need {doc['n_policies']} policies over 5 forces, "
                            f"got weights of shape {net.w3.shape}")
    return net, doc


def _read_weights(path: Path) -> bytes:
    """The archive's bytes for its hash, bounded before anything is read."""
    try:
        if path.stat().st_size > MAX_NPZ_BYTES:
            raise ArtifactError(f"{path}: archive exceeds the {MAX_NPZ_BYTES}-byte limit")
        return path.read_bytes()
    except OSError as exc:
        raise ArtifactError(f"{path}: cannot read ({exc.strerror or exc})") from None


def _check_meta(doc: Any, path: Path) -> None:
    if not isinstance(doc, dict) or doc.get("schema") != POLICY_SCHEMA:
        raise ArtifactError(f"{path}: not a {POLICY_SCHEMA} artifact")
    version = doc.get("schema_version")
    if version != SCHEMA_VERSION or isinstance(version, bool | float):
        raise ArtifactError(f"{path}: schema version {str(version)[:40]} is not {SCHEMA_VERSION}")
    activation = doc.get("activation")
    if not isinstance(activation, str) or activation not in mlp.ACTIVATIONS:
        raise ArtifactError(f"{path}: activation must be one of {', '.join(mlp.ACTIVATIONS)}")
    if doc.get("features") != FEATURES:
        raise ArtifactError(f"{path}: feature scaling {str(doc.get('features'))[:80]} is not {FEATURES}")
    n = doc.get("n_policies")
    if not isinstance(n, int) or isinstance(n, bool) or n < 1:
        raise ArtifactError(f"{path}: n_policies must be a positive integer")
    sha = doc.get("weights_sha256")
    if not isinstance(sha, str) or len(sha) != 64:
        raise ArtifactError(f"{path}: weights_sha256 must be a 64-digit hex string")
    if doc.get("weights") != paths(path)[1].name:
        raise ArtifactError(f"{path}: weights must name {paths(path)[1].name}")
