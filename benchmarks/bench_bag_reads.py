"""The identifier's bag reads: roles_from_dir + load_records, now against the per-message, read-twice path.

Prints JSON. Both run in this process on the same bags, best of ``--repeat``:
the baseline declines the whole-topic JointState reader (every row decoded
one message at a time) and drops the samples roles_from_dir kept (every bag
read again to identify), which is the work the identifier did before each bag
was read once. The records of both must be byte-identical (``identical``).
No hard floor: ``speedup`` is the ratio to watch.

    .venv/bin/python benchmarks/bench_bag_reads.py [--bags RUN/excitation] [--repeat 3]

Without ``--bags`` it writes 12 bags of a bench run's sizes (94,000 rows) to a
temporary directory first.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from unittest import mock

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from msd_bench.core.identification.records import Records
from msd_bench.io.bags import cdr
from msd_bench.io.bags.bag_records import load_records, roles_from_dir
from msd_bench.io.bags.reader import write_experiment

SIZES = {"broad": 12_000, "val_broad": 2_000,
         **{f"bias_{b}": 13_000 for b in ("m10", "m5", "0", "p5", "p10")},
         **{f"val_bias_{b}": 3_000 for b in ("m10", "m5", "0", "p5", "p10")}}
"""A bench run's 12 bags and their rows."""


def _write_bags(root: Path) -> Path:
    rng = np.random.default_rng(0)
    for name, n in SIZES.items():
        bias = None if "broad" in name else float(name.rsplit("_", 1)[1].replace("m", "-").replace("p", ""))
        params = {"role": "validation" if name.startswith("val") else "train", "bias": bias}
        t = 1_700_000_000 * 10**9 + np.arange(n, dtype=np.int64) * 10_000_000
        write_experiment(root / name, t, rng.normal(size=n), rng.normal(size=n), rng.normal(size=n),
                         params=params)
    return root


def _current(bags: Path) -> Records:
    return load_records(roles_from_dir(bags), need_plm=True)


def _baseline(bags: Path) -> Records:
    with mock.patch.object(cdr, "joint_state_columns", lambda raws: None):
        roles = [replace(r, samples=None) for r in roles_from_dir(bags)]
        return load_records(roles, need_plm=True)


def _best(fn: Callable[[Path], Records], bags: Path, repeat: int) -> tuple[float, Records]:
    times, out = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn(bags)
        times.append(time.perf_counter() - start)
    assert out is not None
    return min(times), out


def _fingerprint(records: Records) -> list[bytes]:
    ios = [*records.bias_train.values(), *records.bias_val.values(), records.broad_train, records.broad_val]
    return [a.tobytes() for io in ios for e in io.experiments for a in (e.u, e.y)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bags", type=Path, help="a directory of our bags (default: write 12)")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        bags = args.bags or _write_bags(Path(tmp))
        t_base, base = _best(_baseline, bags, args.repeat)
        t_now, now = _best(_current, bags, args.repeat)
        rows = sum(e.u.size for io in (*now.bias_train.values(), *now.bias_val.values(),
                                       now.broad_train, now.broad_val) for e in io.experiments)
    print(json.dumps({
        "bags": str(args.bags or "12 written bags"),
        "rows_identified": int(rows),
        "seconds": {"per_message_read_twice_baseline": round(t_base, 3),
                    "whole_topic_read_once": round(t_now, 3)},
        "speedup": round(t_base / t_now, 2),
        "identical": _fingerprint(base) == _fingerprint(now),
    }, indent=2))


if __name__ == "__main__":
    main()
