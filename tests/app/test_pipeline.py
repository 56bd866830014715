"""The in-process paper pipeline on tiny budgets: config checks, determinism, row bookkeeping.

Budgets are cut (few seeds, short episodes and records, NLARX iterations scaled
down) so the whole file runs in seconds; what is asserted is bookkeeping that
must hold at any budget: one row per requested kind, n, sample counts, real
interactions, seeds of the records, and that the same config gives the same run.
"""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.app.agents import AGENT_KINDS
from msd_bench.app.config import RunConfig as PaperConfig
from msd_bench.app.pipeline import make_records, run_paper
from msd_bench.app.plan import record_seeds
from msd_bench.core.errors import ConfigError, MsdBenchError
from msd_bench.core.evaluation.metrics import compute
from msd_bench.core.evaluation.results import METRIC_KEYS, by_kind
from msd_bench.core.identification.plm import PLM_BIASES

TINY = PaperConfig(
    seeds=2,
    id_seeds=2,
    agents=("glm", "plm", "nlarx-paper", "dyna-q", "plant"),
    episodes=4,
    steps=400,
    dyna_episodes=2,
    planning_steps=5,
    samples=1500,
    val_samples=600,
    validation_steps=800,
    window=200,
    nlarx_scale=0.02,
)
"""Every surrogate family plus both on-plant learners, two identification seeds."""


def _same_metrics(a, b) -> bool:
    """Every metric equal bit for bit, NaN (a settling time that never happens) equal to NaN."""
    return all(np.array_equal(a[k], b[k], equal_nan=True) for k in METRIC_KEYS)


@pytest.fixture(scope="module")
def tiny_run():
    return run_paper(TINY)


# --- configuration ---------------------------------------------------------------------------


def test_unknown_agent_kind_is_named_and_every_choice_listed():
    with pytest.raises(ConfigError) as err:
        PaperConfig(agents=("plm", "plm-turbo"))
    msg = str(err.value)
    assert "'plm-turbo'" in msg and "\n" not in msg
    for kind in AGENT_KINDS:
        assert kind in msg


@pytest.mark.parametrize("field", ["seeds", "id_seeds", "episodes", "steps", "dyna_episodes",
                                   "samples", "val_samples", "validation_steps", "window"])
def test_zero_budget_is_refused_naming_the_field(field):
    with pytest.raises(ConfigError, match=rf"^{field} must be >= 1, got 0$"):
        PaperConfig(**{field: 0})


def test_window_longer_than_validation_is_refused():
    with pytest.raises(ConfigError, match="window"):
        PaperConfig(validation_steps=300, window=301)
    assert PaperConfig(validation_steps=300, window=300).window == 300  # equal is allowed


@pytest.mark.parametrize("scale", [0.0, -1.0, 10.5])
def test_nlarx_scale_outside_its_range_is_refused(scale):
    with pytest.raises(ConfigError, match="nlarx_scale"):
        PaperConfig(nlarx_scale=scale)


def test_config_errors_are_user_errors():
    """The CLI turns MsdBenchError into one line and exit 2; ConfigError must be one of them."""
    with pytest.raises(MsdBenchError):
        PaperConfig(seeds=0)


def test_surrogates_needed_follow_the_requested_kinds_in_a_fixed_order():
    cfg = PaperConfig(agents=("nlarx-improved+improved", "plant", "glm", "plm+improved"))
    assert cfg.surrogates_needed() == ["glm", "plm", "nlarx-improved"]
    assert PaperConfig(agents=("greybox+improved", "glm")).surrogates_needed() == ["glm", "greybox"]
    assert PaperConfig(agents=("dyna-q", "plant")).surrogates_needed() == []


def test_learning_seeds_start_at_first_seed_and_never_repeat_across_id_seeds():
    cfg = PaperConfig(seeds=3, first_seed=7, id_seeds=2, id_first_seed=4)
    assert cfg.learning_seeds(0) == [7, 8, 9]
    assert cfg.learning_seeds(1) == [10, 11, 12]
    assert cfg.id_seed_values() == [4, 5]


# --- records -----------------------------------------------------------------------------------


@pytest.mark.parametrize("id_seed", [0, 1, 2, 17, 399])
def test_training_and_validation_records_never_share_a_seed(id_seed):
    train, val = record_seeds(id_seed)
    assert train != val
    # make_records uses seed + bias index (0..4) and seed + 7: the two ranges must not meet.
    used_train = {train + i for i in range(len(PLM_BIASES))} | {train + 7}
    used_val = {val + i for i in range(len(PLM_BIASES))} | {val + 7}
    assert used_train.isdisjoint(used_val)


def test_records_of_one_id_seed_use_distinct_excitations(tiny_run):
    rec = tiny_run.records[0]
    train_seeds = [r.meta["seed"] for r in rec.bias_train.values()] + [rec.broad_train.meta["seed"]]
    val_seeds = [r.meta["seed"] for r in rec.bias_val.values()] + [rec.broad_val.meta["seed"]]
    assert set(train_seeds).isdisjoint(val_seeds)
    assert sorted(rec.bias_train) == sorted(PLM_BIASES)
    n = min(TINY.val_samples, TINY.samples)
    assert not np.array_equal(rec.broad_train.experiments[0].u[:n], rec.broad_val.experiments[0].u[:n])
    assert rec.broad_train.n_samples == TINY.samples and rec.broad_val.n_samples == TINY.val_samples


def test_id_seeds_re_record(tiny_run):
    a, b = tiny_run.records[0].broad_train, tiny_run.records[1].broad_train
    assert a.meta["seed"] != b.meta["seed"]
    assert not np.array_equal(a.experiments[0].u, b.experiments[0].u)


def test_make_records_is_deterministic():
    cfg = PaperConfig(samples=1200, val_samples=500)
    a, b = make_records(cfg, 3), make_records(cfg, 3)
    assert np.array_equal(a.broad_val.experiments[0].y, b.broad_val.experiments[0].y)
    for bias in PLM_BIASES:
        assert np.array_equal(a.bias_train[bias].experiments[0].y, b.bias_train[bias].experiments[0].y)


# --- results -----------------------------------------------------------------------------------


def test_one_row_per_requested_kind_in_order(tiny_run):
    assert [r.kind for r in tiny_run.results] == list(TINY.agents)
    for r in tiny_run.results:
        assert r.label == AGENT_KINDS[r.kind].label
        assert r.surrogate == AGENT_KINDS[r.kind].surrogate


def test_surrogate_rows_hold_seeds_times_id_seeds(tiny_run):
    rows = by_kind(tiny_run.results)
    for kind in ("glm", "plm", "nlarx-paper"):
        r = rows[kind]
        assert r.n == TINY.seeds * TINY.id_seeds
        pairs = [(s["id_seed"], s["seed"]) for s in r.per_seed]
        assert pairs == [(i, s) for i in range(TINY.id_seeds) for s in TINY.learning_seeds(i)]
        assert len(r.fit_by_id_seed) == TINY.id_seeds


def test_on_plant_rows_do_not_repeat_per_id_seed(tiny_run):
    """The plant does not depend on the identification seed: its learners run once per seed."""
    rows = by_kind(tiny_run.results)
    for kind in ("dyna-q", "plant"):
        assert [(s["id_seed"], s["seed"]) for s in rows[kind].per_seed] == [
            (0, s) for s in TINY.learning_seeds()]


def test_identification_samples_per_family(tiny_run):
    rows = by_kind(tiny_run.results)
    assert rows["plm"].identification_samples == 5 * TINY.samples
    assert rows["glm"].identification_samples == TINY.samples
    assert rows["nlarx-paper"].identification_samples == TINY.samples


def test_agents_on_the_plant_report_no_fit(tiny_run):
    rows = by_kind(tiny_run.results)
    for kind in ("plant", "dyna-q"):
        r = rows[kind]
        assert r.fit_sim is None and r.fit_one_step is None
        assert r.identification_samples == 0 and r.fit_by_id_seed == ()
    for kind in ("glm", "plm", "nlarx-paper"):
        r = rows[kind]
        assert r.fit_sim is not None and np.isfinite(r.fit_sim)
        assert r.fit_sim == pytest.approx(np.mean([f["fit_sim_percent"] for f in r.fit_by_id_seed]))


def test_real_interactions_count_plant_steps_only(tiny_run):
    rows = by_kind(tiny_run.results)
    assert rows["dyna-q"].real_interactions == TINY.seeds * TINY.dyna_episodes * TINY.steps
    assert rows["plant"].real_interactions == TINY.seeds * TINY.episodes * TINY.steps
    for kind in ("glm", "plm", "nlarx-paper"):
        assert rows[kind].real_interactions == 0


def test_reduced_dyna_budget_is_noted(tiny_run):
    rows = by_kind(tiny_run.results)
    note = rows["dyna-q"].notes
    assert "reduced budget" in note and str(TINY.dyna_episodes) in note
    assert all(rows[k].notes == "" for k in ("glm", "plm", "nlarx-paper", "plant"))


def test_paper_dyna_budget_has_no_note():
    """300 Dyna-Q episodes is the paper's budget (episodes kept 10 steps long to stay fast)."""
    cfg = PaperConfig(seeds=1, agents=("dyna-q",), steps=10, dyna_episodes=300, planning_steps=1,
                      validation_steps=200, window=50)
    (row,) = run_paper(cfg).results
    assert row.notes == ""
    assert row.real_interactions == 300 * 10


def test_per_seed_metrics_match_the_stored_responses(tiny_run):
    for r in tiny_run.results:
        x = tiny_run.responses[r.kind]
        assert x.shape == (r.n, TINY.validation_steps)
        for xi, row in zip(x, r.per_seed, strict=True):
            m = compute(xi, TINY.target, TINY.plant.dt, TINY.window)
            expected = {"mae": m.mae, "std": m.std, "po": m.po, "ts": m.ts2, "ts5": m.ts5, "sse": m.sse}
            assert _same_metrics(row, expected)
            assert row["success"] == (m.sse < 5.0)


def test_qtables_have_one_table_per_row(tiny_run):
    for r in tiny_run.results:
        policies = tiny_run.policies[r.kind].values()
        assert sum(p.q.shape[0] for p in policies) == r.n
        for p in policies:
            assert p.q.shape[0] == p.first.shape[0] == p.last.shape[0] == len(p.members)
            assert np.array_equal(p.last, p.q)  # the last snapshot is the final table
            assert not np.array_equal(p.first, p.q)  # learning happened after episode 1


def test_models_and_fits_per_id_seed(tiny_run):
    assert sorted(tiny_run.models) == list(range(TINY.id_seeds))
    for i in range(TINY.id_seeds):
        assert sorted(tiny_run.models[i]) == sorted(TINY.surrogates_needed())
        assert sorted(tiny_run.fits[i]) == sorted(TINY.surrogates_needed())


def test_same_config_twice_gives_the_same_run(tiny_run):
    again = run_paper(TINY)
    for a, b in zip(tiny_run.results, again.results, strict=True):
        assert [(s["seed"], s["id_seed"], s["success"]) for s in a.per_seed] == [
            (s["seed"], s["id_seed"], s["success"]) for s in b.per_seed]
        assert all(_same_metrics(x, y) for x, y in zip(a.per_seed, b.per_seed, strict=True))
        assert a.fit_sim == b.fit_sim and a.fit_one_step == b.fit_one_step
    for kind in TINY.agents:
        for id_seed, p in tiny_run.policies[kind].items():
            for key in ("q", "first", "last"):
                assert np.array_equal(getattr(p, key), getattr(again.policies[kind][id_seed], key))
        assert np.array_equal(tiny_run.responses[kind], again.responses[kind])


def test_progress_reports_every_stage_and_ends_done():
    seen: list[tuple[str, int, int]] = []
    cfg = PaperConfig(seeds=1, agents=("glm", "plant"), episodes=2, steps=200, samples=1200,
                      val_samples=500, validation_steps=300, window=100)
    run_paper(cfg, lambda stage, done, total: seen.append((stage, done, total)))
    total = 1 + 1 + 1  # identify, train glm, train plant
    assert seen[-1] == ("done", total, total)
    assert [s for s, _, _ in seen[:-1]] == ["identify (id seed 0)", "train glm (id seed 0)", "train plant"]
    assert [d for _, d, _ in seen] == [0, 1, 2, 3]
