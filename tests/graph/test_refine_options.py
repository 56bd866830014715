"""``bench.py --refine R``: its options, refused in one line before anything is written, and its table.

The stage itself runs against a rig node in real time: ``tests/e2e/test_bench_refine.py`` (realtime tier).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from msd_bench.graph.main import config, main, parse
from msd_bench.graph.refine import kinds, summary, table


@pytest.mark.parametrize(("argv", "says"), [
    (["--refine", "1"], "--refine tries the agents on a plant node in real time: give --plant-ns"),
    (["--plant-ns", "/rig", "--refine", "11"], "--refine must be in 0..10, got 11"),
    (["--plant-ns", "/rig", "--refine", "1", "--refine-weight", "0"], "--refine-weight must be in 1..10"),
    (["--plant-ns", "/rig", "--refine", "1", "--agents", "dyna-q"],
     "--refine refits the identified model an agent was made on; none of the run's kinds (dyna-q) is made "
     "on one"),
    (["--plant-ns", "/rig", "--refine", "1", "--stages", "record,identify"],
     "--refine runs after the agents stage"),
])
def test_bad_refine_options_are_one_line_and_write_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                           argv: list[str], says: str) -> None:
    out = tmp_path / "run"
    assert main([*argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bench: error: ") and says in err[0], err
    assert not out.exists()


def test_only_kinds_made_on_an_identified_model_are_refined(tmp_path: Path) -> None:
    cfg = config(parse(["--plant-ns", "/rig", "--refine", "2", "--agents",
                        "plm+robust,greybox+robust,glm,plant", "--out", str(tmp_path / "run")]))
    assert (cfg.refine, cfg.refine_weight) == (2, 1)
    assert kinds(cfg, []) == ["plm+robust", "greybox+robust", "glm"]
    assert kinds(cfg, ["glm"]) == ["plm+robust", "greybox+robust"]  # glm's model was not identified


def _seed(seed: int, chosen: int, sses: list[float], fresh: float, failed: str = "") -> dict[str, Any]:
    rounds: list[dict[str, Any]] = [{"round": i, "failed": "", "fit": {}, "sse_measured": s, "aborted": False,
                                     "samples": 600, "success_measured": s < 5.0,
                                     "supervisor": {"overridden": i}} for i, s in enumerate(sses)]
    if failed:
        rounds.append({"round": len(sses), "failed": failed, "fit": {}})
    return {"seed": seed, "chosen_round": chosen, "rounds": rounds,
            "fresh": {"sse_measured": fresh, "success_measured": fresh < 5.0, "supervisor": None}}


def test_the_report_counts_each_round_and_names_a_round_that_made_no_policy() -> None:
    rows = [_seed(0, 1, [9.0, 3.0], 2.5), _seed(1, 0, [4.0], 4.5, failed="refit of greybox: diverged")]
    s = summary(rows)
    keys = ("tries", "successes_measured", "overridden", "kept", "failed")
    got = [tuple(r[k] for k in keys) for r in s["rounds"]]
    assert got == [(2, 1, 0, 1, 0), (1, 1, 1, 1, 1)]
    assert s["fresh_successes_measured"] == 2
    doc = {"rounds": 1, "refine_weight": 1, "supervised": True, "kinds": {"greybox+robust": rows},
           "summary": {"greybox+robust": s}}
    text = table(doc)
    assert "| greybox+robust | 1 | 1 | 1 | 0 | 1 | 1 |" in text
    assert "| greybox+robust | 0 | 1 | 2.50 | yes |" in text
    assert "greybox+robust seed 1 round 1: refit of greybox: diverged" in text
