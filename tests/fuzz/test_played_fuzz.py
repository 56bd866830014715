"""Property: locating the played samples in any recording gives a cut inside it or one BagError line.

The inputs are what a bag can hold: row and command log times in any order,
efforts and commands of any finite or non-finite value, signals of any length.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.played import PlayedCut, locate_from_commands, locate_from_effort

BAG = Path("/fuzz/bag")
_forces = st.floats(-20.0, 20.0, allow_nan=False) | st.sampled_from([0.0, 5.0, -10.0, 10.0])
_signals = arrays(np.float64, st.integers(1, 40), elements=_forces)
_efforts = arrays(np.float64, st.integers(0, 120), elements=_forces | st.just(np.nan))
_times = arrays(np.int64, st.integers(0, 120), elements=st.integers(0, 2_000_000_000))


def _inside(cut: PlayedCut | None, rows: int, n: int) -> None:
    if cut is not None:
        assert 0 <= cut.start < cut.stop <= rows and cut.stop - cut.start >= n


@given(effort=_efforts, played=_signals)
def test_a_cut_from_the_effort_is_inside_the_recording_or_one_line(effort: np.ndarray,
                                                                   played: np.ndarray) -> None:
    try:
        cut = locate_from_effort(BAG, np.nan_to_num(effort), played)
    except BagError as err:
        assert "\n" not in str(err) and str(BAG) in str(err)
        return
    _inside(cut, effort.size, played.size)


@given(rows=_times, cmd_ns=_times, data=st.data())
def test_a_cut_from_the_commands_is_inside_the_recording_or_one_line(rows: np.ndarray, cmd_ns: np.ndarray,
                                                                     data: st.DataObject) -> None:
    force = data.draw(arrays(np.float64, cmd_ns.size, elements=_forces | st.just(np.nan)))
    played = data.draw(_signals)
    try:
        cut = locate_from_commands(BAG, "/rig/force", np.sort(rows), (cmd_ns, force), played, 10.0)
    except BagError as err:
        assert "\n" not in str(err) and str(BAG) in str(err)
        return
    _inside(cut, rows.size, played.size)
