"""A held stage's bags read as bench.py reads them give the records ``msd-bench rigs`` plays.

Under a rig description that states a hold loop (docs/rig-description.md §Format), the rig's drive
adds the loop's force to every command, so a bag's effort is the loop's force plus the signal. The bag
route takes the loop back out (:func:`msd_bench.io.bags.bag_records.load_records` with ``hold``): its
records must be the in-process ones (:func:`msd_bench.core.rigs.rig_play.records_of` under the same
loop) bit for bit, and without the loop the bag's input would be the loop-laden effort.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from msd_bench.app.plan import paper_plan
from msd_bench.core.rigs import families
from msd_bench.core.rigs.rest import RestConfig
from msd_bench.core.rigs.rig import Rig
from msd_bench.core.rigs.rig_play import PlayedExperiment, play_plan, records_of
from msd_bench.io.bags.bag_records import explicit_roles, load_records
from msd_bench.io.bags.bag_writer import write_experiment

MEMBER = families.draw("stage", 3)
"""A design stage (500 Hz or 1 kHz, its stated hold loop)."""


def _bag(path: Path, p: PlayedExperiment, dt: float) -> str:
    """``p`` as the rig's msd face records it: each row's effort (the loop's included) and measured x."""
    t_ns = np.arange(p.effort.size, dtype=np.int64) * round(dt * 1e9)
    write_experiment(path, t_ns, p.effort, p.measured, p.velocity, params={})
    return str(path)


@pytest.fixture(scope="module")
def played() -> list[PlayedExperiment]:
    """The broad training and validation records of the stage, played under its hold loop."""
    sc = MEMBER.scales()
    plan = [i for i in paper_plan(0, sc.samples(600), sc.samples(1000), 0, scales=sc) if i.bias is None]
    rig = Rig(MEMBER.params, MEMBER.imperfections, seed=3)
    return play_plan(rig, plan, RestConfig().scaled(sc), MEMBER.hold)


def test_the_bag_route_takes_the_loop_out_as_the_in_process_route_does(
        tmp_path: Path, played: list[PlayedExperiment]) -> None:
    dt, hold = MEMBER.params.dt, MEMBER.hold
    assert hold is not None
    train, val = (_bag(tmp_path / p.name, p, dt) for p in played)
    roles = explicit_roles([], train, val, 0)
    got = load_records(roles, False, dt=dt, force_limit=MEMBER.params.F, hold=hold)
    want = records_of(played, dt, hold)
    for mine, theirs in ((got.broad_train, want.broad_train), (got.broad_val, want.broad_val)):
        np.testing.assert_array_equal(mine.experiments[0].u, theirs.experiments[0].u)
        np.testing.assert_array_equal(mine.experiments[0].y, theirs.experiments[0].y)
    bare = load_records(roles, False, dt=dt, force_limit=MEMBER.params.F)
    loop = bare.broad_train.experiments[0].u - got.broad_train.experiments[0].u
    assert float(np.max(np.abs(loop))) > 0.05 * MEMBER.params.F  # the loop's force was in the effort
