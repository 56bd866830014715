"""A sweep run as its own process, to be killed half-way: ``python -m tests.app.sweep_driver OUT RELEASE``.

Tasks 0 and 1 finish at once; tasks 2 and 3 wait for RELEASE. The final file
``sum.json`` is built from every task's file, as the real sweeps build theirs.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from msd_bench.app.executor import ExecutorOptions, Task
from msd_bench.app.sweep import run_sweep
from msd_bench.io.storage.atomic import write_text_atomic
from msd_bench.io.storage.run_dir import RunDir
from tests.app.executor_tasks import wait_for

TASKS = [f"t{i}" for i in range(4)]


def main(out: str, release: str, kind: str = "local") -> int:
    rd = RunDir.open(Path(out), "sweep-test", [*TASKS, "sum"], {"n": 4})
    tasks = [Task(t, wait_for, (release if i >= 2 else out, i)) for i, t in enumerate(TASKS)]

    def write(task: Task, result: object) -> list[Path]:
        text = json.dumps({"task": task.id, "value": result})
        return [write_text_atomic(rd.root / f"parts/{task.id}.json", text, root=rd.root)]

    options = ExecutorOptions(kind=kind, workers=2)
    run_sweep(rd, tasks, write, options, lambda line: print(line, flush=True))
    total = sum(json.loads((rd.root / f"parts/{t}.json").read_text())["value"] for t in TASKS)
    rd.run_task("sum", lambda: [write_text_atomic(rd.root / "sum.json", json.dumps({"sum": total}),
                                                  root=rd.root)])
    rd.mark_complete()
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
