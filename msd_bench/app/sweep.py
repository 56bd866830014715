"""A sweep over a run directory: the tasks not written yet go to the executor, each result is written
as it arrives (atomically, with its record), and what a killed sweep finished is never redone.

The driver writes every file (the workers only compute), so a resumed sweep
needs nothing from the workers of the run that died, and the files are the
same whichever executor and how many workers computed them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from msd_bench.app.executor import ExecutorOptions, Log, Task, run_tasks
from msd_bench.io.storage.run_dir import RunDir

WriteResult = Callable[[Task, Any], Sequence[Path]]
"""Writes a task's result under the run directory (atomically) and returns the files it wrote."""


def run_sweep(rd: RunDir, tasks: Sequence[Task], write_result: WriteResult, options: ExecutorOptions,
              log: Log, on_written: Callable[[Task], None] | None = None) -> int:
    """Run the ``tasks`` not done in ``rd`` and write each; returns how many were done already.

    A resumed run says how many tasks it skipped: they keep their files and
    modification times, and the run's final files are built from all of them.
    """
    todo = [t for t in tasks if not rd.is_done(t.id)]
    skipped = len(tasks) - len(todo)
    if skipped:
        log(f"resuming: {skipped} of {len(tasks)} tasks already written, not recomputed")

    def write(task: Task, result: Any) -> None:
        rd.run_task(task.id, lambda: write_result(task, result))
        if on_written is not None:
            on_written(task)

    run_tasks(todo, options, write, log)
    return skipped
