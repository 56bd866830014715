"""bench.py end to end with a tiny budget: real node processes, real bags, a real report."""

from __future__ import annotations

import html
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from msd_bench.app.agents import learner_from_meta
from msd_bench.core.evaluation.metrics import compute
from msd_bench.core.learning.qconfig import encoding, improved_config
from msd_bench.core.learning.qtrain import greedy_rollouts
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.io.bags.reader import bag_info, read_experiment
from msd_bench.io.storage import artifacts
from tests.browser.cdp import CHROMIUM, Browser, drawn_images, table1_rows

pytestmark = pytest.mark.e2e
REPO = Path(__file__).resolve().parents[2]
AGENTS = ("glm", "plm+improved", "nlarx-improved+robust", "dyna-q", "plant")
SEEDS = 2
STEPS = 600


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess[str]]:
    out = tmp_path_factory.mktemp("bench") / "run"
    argv = [sys.executable, "launch_scripts/bench.py", "--out", str(out), "--seeds", str(SEEDS),
            "--agents", ",".join(AGENTS), "--episodes", "5", "--dyna-episodes", "1",
            "--samples", "600", "--val-samples", "400", "--nlarx-scale", "0.05",
            "--validation-steps", str(STEPS), "--domain-id", os.environ["ROS_DOMAIN_ID"]]
    proc = subprocess.run(argv, cwd=REPO, capture_output=True, text=True, timeout=600)
    return out, proc


def test_exits_cleanly_and_prints_the_table(run):
    out, proc = run
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr
    assert "| Agent |" in proc.stdout and "PLM (improved agent)" in proc.stdout
    assert f"report: {out / 'report'}" in proc.stderr


def test_dyna_q_learns_on_the_plant_while_the_surrogates_are_identified(run):
    """The model-free kind is submitted before the identifier starts (stages overlap on two cores)."""
    _, proc = run
    early = proc.stderr.find("dyna-q: learning on the plant while the surrogates are identified")
    assert 0 <= early < proc.stderr.find("identifying surrogates (identifier node)")


def test_agents_start_as_soon_as_their_surrogate_is_identified(run):
    """The GLM's agent is submitted while the NLARX is still being fitted (the identifier's summary,
    printed once it has exited, comes later)."""
    _, proc = run
    glm = proc.stderr.find("glm identified: glm start on the plant")
    nlarx = proc.stderr.find("nlarx-improved identified: nlarx-improved+robust start on the plant")
    assert 0 <= glm < nlarx < proc.stderr.find("nlarx-improved: fit ")


def test_excitation_bags_hold_the_played_experiments(run):
    out, _ = run
    names = sorted(p.name for p in (out / "excitation").iterdir())
    assert len(names) == 12 and "bias_m10" in names and "val_broad" in names
    exp, params = read_experiment(out / "excitation" / "bias_p5")
    assert params["role"] == "train" and params["bias"] == 5.0
    assert len(exp) == 600 + params["prbs"]["settle"]
    assert exp.y[0] == 0.0  # each experiment starts from rest


def test_models_carry_provenance_of_the_bags(run):
    out, _ = run
    doc = json.loads((out / "models" / "plm.json").read_text())
    sources = {Path(s["path"]).name: s["sha256"] for s in doc["provenance"]["sources"]}
    assert sources["bias_m10"] == artifacts.sha256_path(out / "excitation" / "bias_m10")
    fits = json.loads((out / "models" / "fits.json").read_text())
    assert set(fits) == {"glm", "plm", "nlarx-improved"}


@pytest.mark.parametrize("kind", ["glm", "nlarx-improved+robust"])
def test_validation_bags_match_the_core_greedy_run(run, kind):
    """Over the plant node's topics, each table runs exactly as in-process — the robust agent's
    observer (which predicts with the surrogate it trained on) included."""
    out, _ = run
    arrays, meta = artifacts.load_qtables(out / "agents" / kind / "qtables.npz")
    learner = learner_from_meta(meta)
    trained_on = artifacts.load_model(out / "models" / f"{kind.split('+')[0]}.json")
    x_ref, u_ref = greedy_rollouts(plant_model(PlantParams()), arrays["q"], learner, 1.0, STEPS,
                                   observer=trained_on)
    for i, seed in enumerate(meta["seeds"]):
        exp, _ = read_experiment(out / "agents" / kind / "validation" / f"seed_{seed}")
        assert np.array_equal(exp.y, x_ref[i]) and np.array_equal(exp.u, u_ref[i])
    arrays, _ = artifacts.load_qtables(out / "agents" / "plm+improved" / "qtables.npz")
    assert arrays["q"].shape == (SEEDS, encoding(improved_config()).n_states, 5)


def test_report_agrees_with_the_agents(run):
    out, _ = run
    table = json.loads((out / "report" / "table1.json").read_text())
    assert table["schema"] == "msd-bench/table1" and table["run"]["mode"] == "ros-graph"
    rows = {a["kind"]: a for a in table["agents"]}
    assert set(rows) == set(AGENTS)
    assert rows["dyna-q"]["real_interactions"] == SEEDS * 1 * 3000
    assert "reduced budget" in rows["dyna-q"]["notes"]
    assert rows["plm+improved"]["identification_samples"] == 5 * 600
    for kind in AGENTS:
        result = json.loads((out / "agents" / kind / "result.json").read_text())
        for seed_row in result["per_seed"]:
            exp, _ = read_experiment(out / "agents" / kind / "validation" / f"seed_{seed_row['seed']}")
            assert seed_row["sse"] == compute(exp.y, 1.0, 0.01, 500).sse
        assert [r["sse"] for r in rows[kind]["per_seed"]] == [r["sse"] for r in result["per_seed"]]
    figures = {p.name for p in (out / "report" / "figures").iterdir()}
    assert {"step_responses.png", "fit_plm.png", "qtable_glm.png"} <= figures
    timings = json.loads((out / "run.json").read_text())["timings"]
    assert {"record", "identify", "agents", "report"} <= set(timings)


def test_validation_bag_is_a_complete_rosbag2(run):
    out, _ = run
    info = bag_info(out / "agents" / "plant" / "validation" / "seed_0")
    assert info.topics["/msd/joint_states"][1] == STEPS
    assert info.topics["/msd/reference"] == ("std_msgs/msg/Float64", 1)  # the set-point, at t_0


def test_robustness_of_every_agent_kind_is_reported(run):
    out, proc = run
    doc = json.loads((out / "report" / "robustness.json").read_text())
    cells = {a["kind"]: a["cells"] for a in doc["agents"]}
    assert set(cells) == set(AGENTS) and "delay=1" in doc["scenarios"]
    nominal = cells["glm"]["nominal"]
    result = json.loads((out / "agents" / "glm" / "result.json").read_text())
    assert nominal["n"] == SEEDS
    assert nominal["sse"] == [r["sse"] for r in result["per_seed"]]  # same tables, same plant
    assert "Robustness" in proc.stdout


def test_every_node_ran_from_its_job_file(run):
    """bench.py wrote one job file per node process, and the identifier fitted with what it said."""
    out, proc = run
    assert proc.returncode == 0, proc.stderr[-3000:]
    jobs = {p.name for p in (out / "jobs").iterdir()}
    experiments = sorted(p.name for p in (out / "excitation").iterdir())
    assert jobs == {"identifier.json", *(f"agent-{k}.json" for k in AGENTS),
                    *(f"{node}-{e}.json" for e in experiments for node in ("excitation", "recorder"))}
    job = json.loads((out / "jobs" / "identifier.json").read_text())["params"]
    used = json.loads((out / "models" / "glm.json").read_text())["provenance"]["parameters"]
    assert {k: used[k] for k in job} == job
    for e in experiments:  # the record stage's nodes played and stored what their files said
        played = json.loads((out / "jobs" / f"excitation-{e}.json").read_text())["params"]
        stored = json.loads((out / "jobs" / f"recorder-{e}.json").read_text())["params"]
        _, params = read_experiment(out / "excitation" / e)
        assert stored["bag_path"] == str(out / "excitation" / e)
        assert json.loads(stored["params_json"]) == params
        kind, signal = played["signal"], params[played["signal"]]
        assert {k: played[f"{kind}.{k}"] for k in signal} == signal and played["seed"] == params["seed"]
        assert played["dt"] == PlantParams().dt and played["wait_recorder"] == stored["bag_path"]


def test_the_run_is_on_one_self_contained_page(run):
    """bench.py writes report/index.html like the in-process commands: every kind's row, every figure
    embedded, nothing fetched from anywhere (the browser tier checks a paper run's page in Chromium)."""
    out, _ = run
    page = (out / "report" / "index.html").read_text()
    table = json.loads((out / "report" / "table1.json").read_text())
    assert all(html.escape(a["label"]) in page for a in table["agents"])
    figures = list((out / "report" / "figures").glob("*.png"))
    assert figures and page.count('src="data:image/png;base64,') == len(figures)
    assert "<script" not in page and "http://" not in page.replace("http://www.w3.org", "")
    assert "https://" not in page and "default-src 'none'" in page


@pytest.mark.browser
def test_the_page_draws_in_chromium(run):
    """The browser tier's check of bench.py's page, on this module's run (one run, not two): every
    figure drawn, a Table 1 row per agent kind, nothing fetched, no console error."""
    if not CHROMIUM.exists():
        pytest.skip(f"browser tier skipped: {CHROMIUM} not found; apt-get install -y chromium")
    out, proc = run
    assert proc.returncode == 0, proc.stderr[-3000:]
    with Browser() as browser:
        images = drawn_images(browser, out / "report" / "index.html")
        rows = table1_rows(browser)
    assert rows == len(json.loads((out / "report" / "table1.json").read_text())["agents"]) == len(AGENTS)
    assert images == len(list((out / "report" / "figures").glob("*.png"))) > 0
