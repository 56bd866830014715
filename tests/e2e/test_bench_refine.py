"""``bench.py --plant-ns /refrig --refine 1`` against the rig emulator (``rig.py``), in real time.

The reduced size (:data:`LOOK`: the README's short records, one learning seed, 20 training episodes,
6 s validation runs, the grey-box's robust agent, no node scenario) takes about 95 s on an idle
2-core machine, most of it real time: recording, the agents stage, then the refinement's three runs
on the node (the open-loop try, the refitted agent's try, the fresh run of the kept one). Hence the
realtime tier (``.ci/run`` runs it; docs/testing.md §Tiers), not the default one.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from msd_bench.graph import launch
from msd_bench.graph.domains import claim_domain

pytestmark = [pytest.mark.e2e, pytest.mark.realtime]

REPO = Path(__file__).resolve().parents[2]
NS = "/refrig"
LOOK = ("--samples", "600", "--val-samples", "400", "--seeds", "1", "--episodes", "20", "--steps", "300",
        "--validation-steps", "600", "--agents", "greybox+robust", "--node-scenarios", "", "--refine", "1")
"""The documented reduced size of ``bench.py --refine`` (docs/rigs.md §Refinement in real time)."""
SEED = "refine/greybox+robust/seed_0"
Run = tuple[Path, subprocess.CompletedProcess[str]]
"""The run's directory and its bench.py process."""


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Run:
    out = tmp_path_factory.mktemp("refine") / "run"
    domain, lock = claim_domain(None)  # a domain of its own, as a bench run claims one
    try:
        with launch.process_group(domain) as procs:
            procs.start("rig.py", ["-r", f"__ns:={NS}"], name="rig").wait_for_line(r"ready", timeout=60.0)
            argv = [sys.executable, "launch_scripts/bench.py", "--plant-ns", NS, "--out", str(out), *LOOK]
            proc = subprocess.run(argv, cwd=REPO, capture_output=True, text=True, timeout=900.0,
                                  env=launch.ros_env(domain))
    finally:
        lock.close()
    return out, proc


def _doc(out: Path) -> dict[str, Any]:
    doc: dict[str, Any] = json.loads((out / "refine" / "refine.json").read_text())
    return doc


def test_it_completes_and_its_report_shows_each_round(run: Run) -> None:
    out, proc = run
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr
    for r in (0, 1):
        assert f"greybox+robust seed 0 round {r}: SSE" in proc.stderr
    text = (out / "report" / "refine.md").read_text()
    assert "| greybox+robust | 0 | 1 |" in text and "| greybox+robust | 1 | 1 |" in text
    assert text in proc.stdout  # printed with the tables
    facts = json.loads((out / "run.json").read_text())["refine"]
    rounds = facts["summary"]["greybox+robust"]["rounds"]
    assert facts["rounds"] == 1 and facts["refine_weight"] == 1 and [r["tries"] for r in rounds] == [1, 1]
    (row,) = _doc(out)["kinds"]["greybox+robust"]
    assert facts["chosen"]["greybox+robust"] == [row["chosen_round"]]


def test_every_try_and_the_fresh_run_went_through_the_supervisor(run: Run) -> None:
    out, _ = run
    (row,) = _doc(out)["kinds"]["greybox+robust"]
    events = [r["supervisor"] for r in row["rounds"]] + [row["fresh"]["supervisor"]]
    # each run is the supervisor's whole 600-sample run, every sample answered by a filtered command
    # (599: the command answering the run's last sample can reach it after the run has ended). More may
    # be filtered: the rest's zero-force commands still in flight when the run begins are filtered too,
    # one idle, 48 seen beside a rigs sweep. Fewer than two runs' worth: no run counts another's.
    assert all(e is not None and e["samples"] == 600 and e["complete"] and 599 <= e["steps"] < 2 * 600
               for e in events), events
    assert [e["run"] for e in events] == [1, 2, 3]  # the refinement's supervisor saw these three runs only


def test_the_refit_joins_the_try_and_the_better_measured_try_is_kept(run: Run) -> None:
    out, _ = run
    (row,) = _doc(out)["kinds"]["greybox+robust"]
    first, second = row["rounds"]
    assert first["fit"] == {} and second["fit"]["fit_sim_percent"] > 0 and not second["failed"]
    model = json.loads((out / SEED / "round_1" / "greybox.json").read_text())
    assert model["provenance"]["parameters"]["closed_loop_records"] == 1
    best = min(row["rounds"], key=lambda r: (r["aborted"], r["sse_measured"], r["round"]))
    assert row["chosen_round"] == best["round"]
    assert row["real_samples"]["runs"] == 3 * 600


def test_round_0_is_the_open_loop_agent_and_the_fresh_run_the_kept_one(run: Run) -> None:
    out, _ = run
    (row,) = _doc(out)["kinds"]["greybox+robust"]
    q = {name: np.load(out / path / "qtables.npz")["q"] for name, path in (
        ("open", "agents/greybox+robust"), ("round0", f"{SEED}/round_0"),
        ("kept", f"{SEED}/round_{row['chosen_round']}"), ("fresh", f"{SEED}/fresh"))}
    assert np.array_equal(q["open"], q["round0"])  # the design is deterministic in its model and seed
    assert np.array_equal(q["kept"], q["fresh"])
