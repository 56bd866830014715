"""Real-time bags are cut on the first played sample, found from the recorded commands, on both faces.

Each bag is written as a real-time recording of our bench looks (issue 21): it
opens with the previous experiment's last command still acting until the
watchdog (a *stale tail*, 23 samples at -4 N), then a long rest of zero force
(900 samples, with the excitation's zero commands every other sample), then
the played signal, then a hold-and-watchdog tail. The old rule (the first
non-zero effort) cut on the stale tail; the cut must land on the first played
sample instead, and a cut that cannot be told is refused naming the bag.
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest

from msd_bench.core.identification import excitation as exc
from msd_bench.core.physics.plant import PlantParams, simulate
from msd_bench.core.rigs.actuation import held_commands
from msd_bench.graph.record import recorded_topics
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_interface import read_interface_experiment
from msd_bench.io.bags.bag_records import BagRole, load_records
from msd_bench.io.bags.bag_writer import write_interface_experiment
from msd_bench.io.bags.played import confirm_by_effort, locate_from_bag, locate_from_effort
from msd_msgs_py.interface import MSD_INTERFACE, make

DT_NS = 10_000_000
T0 = 1_700_000_000 * 10**9
STALE, REST, TAIL = 23, 900, 30
R2C = make("ros2_control", controller_joints=["pole", "slider_to_cart"])
CFG = exc.PrbsConfig(bias=-5.0, n_samples=600, settle=40)


def _params(cfg: exc.PrbsConfig = CFG, seed: int = 3) -> dict:  # type: ignore[type-arg]
    return {"signal": "prbs", "seed": seed, "prbs": asdict(cfg), "role": "train", "bias": cfg.bias}


def _timeline(played: np.ndarray, seed: int = 0) -> dict[str, np.ndarray]:
    """Rows and commands of a real-time recording that plays ``played`` after a stale tail and a rest."""
    rng = np.random.default_rng(seed)
    n, first = played.size, STALE + REST
    applied = np.concatenate([np.full(STALE, -4.0), np.zeros(REST), played,
                              np.full(TAIL // 2, played[-1]), np.zeros(TAIL - TAIL // 2)])
    t = T0 + np.arange(applied.size, dtype=np.int64) * DT_NS
    rest_k = np.arange(STALE + 10, first - 30, 2)  # the rest's zero commands, then the settle's silence
    play_k = np.arange(first, first + n)
    cmd_k = np.concatenate([rest_k, play_k])
    x, v, _ = simulate(applied, PlantParams())
    return {
        "t": t, "x": x, "v": v, "applied": applied, "first": np.asarray(first),
        "cmd_u": np.concatenate([np.zeros(rest_k.size), played]),
        "cmd_log": t[cmd_k] - 4_000_000 + rng.integers(0, 2_000_000, cmd_k.size),  # before row k
        "state_log": t + 1_500_000 + rng.integers(0, 2_000_000, t.size),  # after t_k
    }


def _bag(path: Path, played: np.ndarray, iface=MSD_INTERFACE, effort=None, params=None,  # type: ignore[no-untyped-def]
         **kw) -> tuple[Path, dict[str, np.ndarray]]:
    rec = _timeline(played)
    if "cmd_u" in kw:
        rec["cmd_u"] = kw.pop("cmd_u")
    ns = "/rig"
    bag = write_interface_experiment(
        path, rec["t"], rec["x"], rec["v"], rec["applied"] if effort is None else effort(rec), iface=iface,
        command_ns=rec["cmd_log"][-rec["cmd_u"].size:], command_u=rec["cmd_u"],
        params=_params() if params is None else params, namespace=ns,
        other_joints=["pole"] if iface is R2C else [], state_log_ns=rec["state_log"], **kw)
    return bag, rec


def _lagged(rec: dict[str, np.ndarray]) -> np.ndarray:
    """A ros2_control drive's measured effort: one sample late, a 20 ms lag, 0.05 N of noise."""
    u, out, state = rec["applied"], np.zeros_like(rec["applied"]), 0.0
    decay = np.exp(-0.5)
    for k in range(1, u.size):
        state = u[k - 1] + (state - u[k - 1]) * decay
        out[k] = state
    return out + np.random.default_rng(1).normal(0.0, 0.05, u.size)


def _role(bag: Path, cfg: exc.PrbsConfig = CFG) -> BagRole:
    return BagRole(bag, "train", cfg.bias, cfg.settle, _params(cfg))


def _three(bag: Path, cfg: exc.PrbsConfig = CFG) -> list[BagRole]:
    """The bag as a bias record and, to make the records complete, as both broad records."""
    return [_role(bag, cfg), BagRole(bag, "train", None, 0, _params(cfg)),
            BagRole(bag, "validation", None, 0, _params(cfg))]


def _played(cfg: exc.PrbsConfig = CFG, seed: int = 3) -> np.ndarray:
    return np.clip(exc.prbs(cfg, seed), -10.0, 10.0)


@pytest.mark.parametrize("iface,effort", [(MSD_INTERFACE, None), (R2C, _lagged)], ids=["msd", "ros2_control"])
def test_the_cut_lands_on_the_first_played_sample(tmp_path: Path, iface, effort) -> None:  # type: ignore[no-untyped-def]
    played = _played()
    bag, rec = _bag(tmp_path / "b", played, iface, effort)
    cut = locate_from_bag(bag, iface, "/rig", played, 10.0)
    first = STALE + REST
    assert cut is not None and (cut.start, cut.stop, cut.found_by) == (first, first + played.size, "commands")
    if iface is MSD_INTERFACE:  # the effort over the cut is what the commands held there (exactly)
        confirmed = confirm_by_effort(bag, cut, rec["applied"][cut.rows], 0.01)
        assert confirmed.match == pytest.approx(100.0)
    sources: list = []  # type: ignore[type-arg]
    records = load_records(_three(bag), False, "/rig", iface=iface, sources=sources, force_input="held")
    exp = records.bias_train[CFG.bias].experiments[0]
    first = STALE + REST + CFG.settle
    assert np.array_equal(exp.u, played[CFG.settle:])  # what the excitation played after the settle
    assert np.array_equal(exp.y, rec["x"][first:first + exp.u.size])
    if iface is R2C:  # the measured effort is fitted over the played samples only, and agrees
        assert sources[0].agreement.fit_percent > 90.0 and sources[0].agreement.delay_samples == 1


def test_the_stale_tail_broke_the_ros2_control_agreement_before_the_cut(tmp_path: Path) -> None:
    """Why the cut comes first on ros2_control: over the whole bag the stale tail is unexplained.

    The record at bias 0 N toggles by 1 N, so 23 samples of -4 N no command asked for outweigh it
    (the fit fell to 43 % on the rig); over the played samples the commands explain the effort.
    """
    cfg = exc.PrbsConfig(bias=0.0, n_samples=600, settle=40)
    bag, _ = _bag(tmp_path / "b", _played(cfg), R2C, _lagged, params=_params(cfg))
    with pytest.raises(BagError, match="do not explain the measured effort"):
        read_interface_experiment(bag, R2C, "/rig")
    cut = locate_from_bag(bag, R2C, "/rig", _played(cfg), 10.0)
    assert cut is not None
    _, _, src = read_interface_experiment(bag, R2C, "/rig", played=cut.rows)
    assert src.agreement is not None and src.agreement.fit_percent > 90.0


def test_a_bag_without_commands_is_cut_by_its_effort(tmp_path: Path) -> None:
    """An msd bag recorded before the commands were (joint_states only): the effort's best match."""
    played = _played()
    plain = _plain(tmp_path / "plain", played, _params())
    assert locate_from_bag(plain, MSD_INTERFACE, "/rig", played, 10.0) is None  # no commands recorded
    records = load_records(_three(plain), False, "/rig")
    assert np.array_equal(records.bias_train[CFG.bias].experiments[0].u, played[CFG.settle:])


def _plain(path: Path, played: np.ndarray, params: dict, applied: np.ndarray | None = None) -> Path:  # type: ignore[type-arg]
    """A real-time msd bag with joint_states only (no command topic), as recorded before this fix."""
    rec = _timeline(played)
    return write_interface_experiment(
        path, rec["t"], rec["x"], rec["v"], rec["applied"] if applied is None else applied,
        iface=MSD_INTERFACE, command_ns=np.zeros(0, dtype=np.int64), command_u=np.zeros(0), params=params,
        namespace="/rig", state_log_ns=rec["state_log"])


def test_an_effort_that_repeats_the_signal_is_ambiguous(tmp_path: Path) -> None:
    """Without commands, a signal found twice in the effort is refused, naming the bag."""
    played = _played()
    rec = _timeline(played)
    twice = rec["applied"].copy()
    twice[:played.size] = played  # the same signal once more where the rest was
    bag = _plain(tmp_path / "twice", played, _params(), twice)
    with pytest.raises(BagError, match=r"twice: the played signal matches the recorded effort from sample 0 "
                                       r"and from sample 923 alike: the cut is ambiguous"):
        load_records([_role(bag)], False, "/rig")


def test_lost_commands_make_the_cut_ambiguous_and_name_the_bag(tmp_path: Path) -> None:
    played = _played()
    rec = _timeline(played)
    keep = np.ones(rec["cmd_u"].size, dtype=bool)
    keep[-300:-290] = False  # ten of the played commands never reached the recorder
    bag = write_interface_experiment(
        tmp_path / "lost", rec["t"], rec["x"], rec["v"], rec["applied"], iface=MSD_INTERFACE,
        command_ns=rec["cmd_log"][keep], command_u=rec["cmd_u"][keep], params=_params(), namespace="/rig",
        state_log_ns=rec["state_log"])
    with pytest.raises(BagError, match=r"lost: the last 640 commands on /rig/force are not the played signal"
                                       r".*ambiguous") as err:
        load_records([_role(bag)], False, "/rig")
    assert str(bag) in str(err.value) and "\n" not in str(err.value)


def test_a_constant_signal_is_located_by_its_commands_only(tmp_path: Path) -> None:
    """Nothing in a constant effort tells one sample from the next: without commands it is refused."""
    cfg = exc.StepsConfig(levels=(3.0,), dwell=300)
    params = {"signal": "steps", "seed": 0, "steps": {**asdict(cfg), "levels": [3.0]}, "role": "train"}
    played = exc.steps(cfg)
    bag, _ = _bag(tmp_path / "const", played, params=params)
    cut = locate_from_bag(bag, MSD_INTERFACE, "/rig", played, 10.0)
    assert cut is not None and cut.start == STALE + REST
    plain = _plain(tmp_path / "const_plain", played, params)  # the held tail repeats the last 3 N
    with pytest.raises(BagError, match=r"const_plain: the played signal matches the recorded effort from "
                                       r"sample \d+ and from sample \d+ alike: the cut is ambiguous"):
        load_records([BagRole(plain, "train", None, 0, params)], False, "/rig")


def test_an_effort_that_does_not_follow_the_cut_is_refused(tmp_path: Path) -> None:
    """Commands logged on another clock than the rows (here 3 s early): the cut from them is wrong,
    and the effort over it does not follow them."""
    played = _played()
    rec = _timeline(played)
    bag = write_interface_experiment(
        tmp_path / "skewed", rec["t"], rec["x"], rec["v"], rec["applied"], iface=MSD_INTERFACE,
        command_ns=rec["cmd_log"] - 3_000_000_000, command_u=rec["cmd_u"], params=_params(),
        namespace="/rig", state_log_ns=rec["state_log"])
    with pytest.raises(BagError, match=r"skewed: over the cut from the commands on /rig/force the recorded "
                                       r"effort does not follow them \(fit -?\d+\.\d % < 50 %\)"):
        load_records([_role(bag)], False, "/rig")


def test_a_stalled_excitation_is_cut_over_what_the_node_held(tmp_path: Path) -> None:
    """A timer that fell behind (0.3 s before the last 300 commands): the cut runs to the row that held
    the last command, over the samples the node actually applied the signal in."""
    played = _played()
    rec = _timeline(played)
    log = rec["cmd_log"].copy()
    log[-300:] += 30 * DT_NS
    rows = rec["t"].size + 30
    t = T0 + np.arange(rows, dtype=np.int64) * DT_NS
    state_log = t + 1_500_000
    applied = held_commands(state_log, log, rec["cmd_u"], force_limit=10.0)  # what a plant holds
    x, v, _ = simulate(applied, PlantParams())
    bag = write_interface_experiment(
        tmp_path / "stalled", t, x, v, applied, iface=MSD_INTERFACE, command_ns=log, command_u=rec["cmd_u"],
        params=_params(), namespace="/rig", state_log_ns=state_log)
    cut = locate_from_bag(bag, MSD_INTERFACE, "/rig", played, 10.0)
    assert cut is not None and cut.stop - cut.start == played.size + 30
    records = load_records(_three(bag), False, "/rig")
    assert np.array_equal(records.bias_train[CFG.bias].experiments[0].u, applied[cut.rows][CFG.settle:])


def test_the_run_force_limit_saturates_the_rebuilt_signal(tmp_path: Path) -> None:
    """A bias of 10 N toggles to 11 N, which the plant saturates: the cut compares at the run's limit."""
    cfg = exc.PrbsConfig(bias=10.0, n_samples=600, settle=40)
    raw = exc.prbs(cfg, 3)
    played = np.clip(raw, -10.0, 10.0)
    rec = _timeline(played)
    sent = np.concatenate([np.zeros(rec["cmd_u"].size - raw.size), raw])  # the excitation sends 11 N
    bag = write_interface_experiment(
        tmp_path / "sat", rec["t"], rec["x"], rec["v"], rec["applied"], iface=MSD_INTERFACE,
        command_ns=rec["cmd_log"], command_u=sent, params=_params(cfg), namespace="/rig",
        state_log_ns=rec["state_log"])
    records = load_records(_three(bag, cfg), False, "/rig", force_limit=10.0)
    assert np.array_equal(records.bias_train[10.0].experiments[0].u, played[cfg.settle:])
    plain = _plain(tmp_path / "sat_plain", played, _params(cfg))  # no commands: the effort is compared
    records = load_records(_three(plain, cfg), False, "/rig", force_limit=10.0)
    assert np.array_equal(records.bias_train[10.0].experiments[0].u, played[cfg.settle:])
    effort = records.bias_train[10.0].experiments[0].u
    padded = np.concatenate([np.zeros(50), effort])
    at_limit = locate_from_effort(plain, padded, played[cfg.settle:])
    assert at_limit is not None and at_limit.start == 50 and at_limit.match == pytest.approx(100.0)
    unsaturated = locate_from_effort(plain, padded, raw[cfg.settle:])  # 11 N never acted
    assert unsaturated is not None and unsaturated.match < 97.0  # why the run's limit is passed


def test_a_record_without_excitation_names_its_bag_and_record(tmp_path: Path) -> None:
    """What the identifier said on the rig ("record has no excitation") now says which bag and record."""
    played = _played()
    rec = _timeline(played)
    flat = rec["applied"].copy()
    flat[STALE + REST:] = CFG.bias  # the rig applied a constant force whatever was commanded
    bag = write_interface_experiment(
        tmp_path / "flat", rec["t"], rec["x"], rec["v"], flat, iface=MSD_INTERFACE, command_ns=rec["cmd_log"],
        command_u=rec["cmd_u"], params=_params(), namespace="/rig", state_log_ns=rec["state_log"])
    with pytest.raises(BagError, match=r"flat \(train record at bias -5 N\): no excitation: the force is "
                                       r"constant at -5"):
        load_records([_role(bag)], False, "/rig")


def test_real_time_recordings_hold_the_commands_on_every_face() -> None:
    """The msd face records `force` beside joint_states in real time, as ros2_control records its
    commands; a lock-step bag (exactly the played samples) goes without on the msd face."""
    assert [t.name for t in recorded_topics(False, MSD_INTERFACE, lockstep=False)] == [
        "joint_states", "force"]
    assert [t.name for t in recorded_topics(True, MSD_INTERFACE, lockstep=False)] == [
        "joint_states", "truth/joint_states", "force"]
    assert [t.name for t in recorded_topics(False, MSD_INTERFACE, lockstep=True)] == ["joint_states"]
    r2c = make("ros2_control")
    assert [t.name for t in recorded_topics(False, r2c, lockstep=False)] == [
        "joint_states", "effort_controller/commands"]
