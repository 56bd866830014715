"""Regenerate the pinned learner outputs (run only when a change *means* to alter results).

Why: refactors of the learner, the kernels or the application layer must not
change what any agent kind learns. The models here are stored artifacts (not
freshly identified, whose last digits differ between CPUs), so the digests
pin the learner and the kernels alone. ``tests/core/test_pinned.py`` checks them.

    python tests/data/pinned/make_pins.py   # rewrites digests.json
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2]))

from tests.data.pinned.pinned_runs import RUNS, run_case  # noqa: E402


def digest(a: np.ndarray) -> str:
    """SHA-256 of the array's float64 bytes: equal iff bit-identical."""
    return hashlib.sha256(np.ascontiguousarray(a, dtype=np.float64).tobytes()).hexdigest()


def main() -> None:
    out = {}
    for name in RUNS:
        q, x = run_case(name)
        out[name] = {"q": digest(q), "x": digest(x), "x_last": float(x[0, -1])}
        print(name, out[name]["x_last"])
    (HERE / "digests.json").write_text(json.dumps(out, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
