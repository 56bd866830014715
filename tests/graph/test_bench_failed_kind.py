"""bench.py with a model kind the identifier could not fit (issue 32): its agents are not run and
are reported failed with the reason; every other kind still runs."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

from msd_bench.app.identification import write_fits
from msd_bench.graph.bench import stage_agents, unmade_agents

AGENTS = ["glm", "greybox", "greybox+improved", "dyna-q"]
REASON = "model produced a non-finite position"


def _cfg(tmp_path: Path) -> SimpleNamespace:
    (tmp_path / "models").mkdir()
    write_fits(tmp_path / "models", {"glm": {"sim_fit": 80.0}}, {"greybox": REASON})
    return SimpleNamespace(run_dir=tmp_path, via_ros=False, plant_ns=None, run=SimpleNamespace(agents=AGENTS))


class _Server:
    """Stands for the agent process: each job 'runs' by writing its result file."""

    def __init__(self, run_dir: Path) -> None:
        self.run_dir, self.submitted = run_dir, []

    def ready(self) -> _Server:
        return self

    def submit(self, args, name):
        kind = name.removeprefix("agent-")
        self.submitted.append(kind)
        (self.run_dir / "agents" / kind).mkdir(parents=True)
        (self.run_dir / "agents" / kind / "result.json").write_text("{}")
        return SimpleNamespace(name=name, wait=lambda timeout: 0, lines=[])

    def close(self) -> None:
        pass


def test_the_failed_models_agents_are_named_with_the_reason(tmp_path, monkeypatch):
    cfg = _cfg(tmp_path)
    assert json.loads((tmp_path / "models" / "fits.json").read_text())["failed"] == {"greybox": REASON}
    assert unmade_agents(cfg) == {k: f"its model greybox could not be identified: {REASON}"
                                  for k in ("greybox", "greybox+improved")}
    monkeypatch.setattr("msd_bench.graph.bench.agent_args", lambda cfg, kind: [kind])
    said: list[str] = []
    server = _Server(tmp_path)
    stage_agents(cfg, None, said.append, lambda *a: None, server)
    assert server.submitted == ["glm", "dyna-q"]  # the others still run
    assert f"agent greybox not run: its model greybox could not be identified: {REASON}" in said
