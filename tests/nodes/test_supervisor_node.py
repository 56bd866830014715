"""The supervisor node between a client and a lock-step plant: parity with the in-process
supervisor bit for bit, and the e-stop over ROS (0 N at the plant from the next sample)."""

from __future__ import annotations

import time

import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, Float64, String

from msd_bench.app.serve_protocol import parse_event
from msd_bench.core.physics.plant import PRESETS
from msd_bench.core.safety.adversaries import adversary, run_on_plant
from msd_bench.core.safety.supervisor import SupervisorOptions
from msd_bench.nodes.plant_node import PlantNode, PlantNodeConfig, true_plant_spec
from msd_bench.nodes.rig_node import RigNode
from msd_bench.nodes.supervisor_node import NODE_NAME, SupervisorNode
from msd_msgs_py.contract import ESTOP, ESTOP_CLEAR, FORCE, JOINT_STATES, POSITION, REFERENCE
from msd_msgs_py.interface import make
from msd_msgs_py.ros import command, float64, msg_class, qos
from tests.nodes.conftest import spin_for, spin_until

pytestmark = pytest.mark.ros

PLANT = PRESETS["default"]


class Controller:
    """A client pointed at the supervisor's namespace, as a controller would be."""

    def __init__(self, ctx, executor) -> None:
        self.node = Node("controller", namespace="/supervised", context=ctx)
        self.force = self.node.create_publisher(Float64, FORCE.name, qos(FORCE))
        self.estop = self.node.create_publisher(Empty, ESTOP.name, qos(ESTOP))
        self.clear = self.node.create_publisher(String, ESTOP_CLEAR.name, qos(ESTOP_CLEAR))
        self.positions: list[float] = []
        self.rows: list[JointState] = []
        self.node.create_subscription(Float64, POSITION.name, lambda m: self.positions.append(m.data),
                                      qos(POSITION))
        self.node.create_subscription(JointState, JOINT_STATES.name, self.rows.append, qos(JOINT_STATES))
        self.executor = executor
        executor.add_node(self.node)

    def send_and_wait(self, u: float) -> None:
        n, n_rows = len(self.positions), len(self.rows)
        self.force.publish(float64(u))
        assert spin_until(self.executor, lambda: len(self.positions) > n and len(self.rows) > n_rows,
                          timeout=20.0)


def start(ctx, executor) -> tuple[SupervisorNode, Controller]:
    plant = PlantNode(true_plant_spec(), config=PlantNodeConfig(lockstep=True, duplicate_check=0.0),
                      context=ctx)
    sup = SupervisorNode(context=ctx, parameter_overrides=[Parameter("lockstep", value=True)])
    executor.add_node(plant)
    executor.add_node(sup)
    client = Controller(ctx, executor)
    pubs = [client.force, client.estop, sup._pub_cmd, sup._pub_pos, sup._pub_state, sup._pub_estop,
            plant._pub_js, plant._pub_x]
    assert spin_until(executor, lambda: all(p.get_subscription_count() > 0 for p in pubs), timeout=20.0)
    return sup, client


def test_the_node_filters_as_the_in_process_supervisor_does(ctx, executor):
    n = 120  # always +F: the filter brakes it from sample 35 on, then hands back and brakes again
    adv = adversary("always_plus", PLANT, n)
    ref = run_on_plant(PLANT, SupervisorOptions().limits(PLANT), adv, np.zeros((1, n)))
    assert np.count_nonzero(ref.reason) > 0
    sup, client = start(ctx, executor)
    for u in ref.command[0]:
        client.send_and_wait(float(u))
    assert len(client.rows) == n
    assert np.array_equal([r.effort[0] for r in client.rows], ref.force[0])
    assert np.array_equal([r.position[0] for r in client.rows], ref.x[0])
    assert sup.status()["override_envelope"] == np.count_nonzero(ref.reason[0] == 1)


def test_an_estop_over_ros_cuts_the_force_at_once_and_needs_its_latch_to_clear(ctx, executor):
    sup, client = start(ctx, executor)
    for _ in range(5):
        client.send_and_wait(5.0)
    client.estop.publish(Empty())
    assert spin_until(executor, lambda: sup.supervisor.estop_latched)
    for _ in range(2):
        client.send_and_wait(10.0)
    assert [r.effort[0] for r in client.rows] == [5.0] * 5 + [0.0, 0.0]
    assert sup.status()["estop"] == "latched" and sup.status()["aborted"] == "estop"
    client.clear.publish(String(data="7"))  # not the latch: ignored
    client.estop.publish(Empty())
    assert spin_until(executor, lambda: sup.supervisor.estop_latches == 2)
    client.clear.publish(String(data="1"))  # the earlier latch: clears nothing
    client.send_and_wait(10.0)
    assert client.rows[-1].effort[0] == 0.0 and sup.supervisor.estop_latched
    client.clear.publish(String(data="2"))
    assert spin_until(executor, lambda: not sup.supervisor.estop_latched)
    client.send_and_wait(10.0)
    assert client.rows[-1].effort[0] == 0.0  # the aborted run stays aborted until a reset


def test_an_estop_latches_at_the_drive_in_the_msd_face(ctx, executor):
    """Through the supervisor the plant's own latch is set too: 0 N there whatever arrives, and a
    reset does not clear it; its clear names the plant's latch count."""
    sup, client = start(ctx, executor)
    plant = next(n for n in executor.get_nodes() if isinstance(n, PlantNode))
    direct = plant.create_publisher(Float64, FORCE.name, qos(FORCE))  # a controller bypassing the supervisor
    client.send_and_wait(10.0)
    client.estop.publish(Empty())
    assert spin_until(executor, lambda: plant.estop_latched and sup.supervisor.estop_latched)
    n = len(client.rows)
    direct.publish(float64(10.0))
    assert spin_until(executor, lambda: len(client.rows) > n)
    assert [r.effort[0] for r in client.rows] == [10.0, 0.0]
    assert plant.estop_stamp == client.rows[1].header.stamp.nanosec + client.rows[1].header.stamp.sec * 10**9
    clear = plant.create_publisher(String, ESTOP_CLEAR.name, qos(ESTOP_CLEAR))
    clear.publish(String(data="1"))
    assert spin_until(executor, lambda: not plant.estop_latched)


def test_an_estop_cuts_the_drive_in_the_ros2_control_face(ctx, executor):
    """Real-time rig behind the supervisor, both on the ros2_control face: from the first row the
    rig steps after the latch its applied force is exactly 0 N (the drive cut: no lag left), while
    the controller keeps commanding 10 N."""
    face = [Parameter("interface", value="ros2_control")]
    rig = RigNode(context=ctx, parameter_overrides=[*face, Parameter("duplicate_check", value=0.0)])
    sup = SupervisorNode(context=ctx, parameter_overrides=[*face, Parameter("plant_ns", value="/rig")])
    executor.add_node(rig)
    executor.add_node(sup)
    iface = make("ros2_control")
    node = Node("controller", namespace="/supervised", context=ctx)
    pub = node.create_publisher(msg_class(iface.command), iface.command.name, qos(iface.command))
    estop = node.create_publisher(Empty, ESTOP.name, qos(ESTOP))
    rows: list[JointState] = []
    node.create_subscription(JointState, JOINT_STATES.name, rows.append, qos(JOINT_STATES))
    node.create_timer(0.01, lambda: pub.publish(command(iface, 10.0)))
    executor.add_node(node)

    def effort(r: JointState) -> float:
        return iface.pick(r.name, r.position, r.velocity, r.effort).effort

    assert spin_until(executor, lambda: any(effort(r) > 5.0 for r in rows), timeout=20.0)
    estop.publish(Empty())
    assert spin_until(executor, lambda: rig.estop_stamp is not None, timeout=10.0)
    stamp = rig.estop_stamp
    assert spin_until(executor, lambda: sum(_ns(r) >= stamp for r in rows) >= 20, timeout=20.0)
    before = [effort(r) for r in rows if _ns(r) < stamp]
    after = [effort(r) for r in rows if _ns(r) >= stamp]
    assert before[-1] > 5.0 and after[:20] == [0.0] * 20
    assert sup.status()["aborted"] == "estop" and rig.estop_latched


def _ns(r: JointState) -> int:
    return r.header.stamp.sec * 10**9 + r.header.stamp.nanosec


def _behind_supervisor(ctx, executor, *params: Parameter):
    """A supervisor in front of a fake msd-face plant under /fake (its newest position published by
    the test, the forces it is sent collected) and a controller, every endpoint matched."""
    sup = SupervisorNode(context=ctx, parameter_overrides=[Parameter("plant_ns", value="/fake"), *params])
    executor.add_node(sup)
    node = Node("fake_plant", namespace="/fake", context=ctx)
    executor.add_node(node)
    state = node.create_publisher(Float64, POSITION.name, qos(POSITION))  # the msd face's newest state
    sent: list[float] = []
    node.create_subscription(Float64, FORCE.name, lambda m: sent.append(m.data), qos(FORCE))
    client = Controller(ctx, executor)
    assert spin_until(executor, lambda: state.get_subscription_count() > 0
                      and client.force.get_subscription_count() > 0
                      and sup._pub_cmd.get_subscription_count() > 0, timeout=20.0)
    return sup, state, sent, client


def test_a_stale_state_ends_the_run_with_zero_force(ctx, executor):
    """Real time: a command arriving when the newest state is older than stale_timeout is
    answered with 0 N and the run is aborted as stale (more waiting only makes it staler)."""
    sup, state, sent, client = _behind_supervisor(ctx, executor)
    state.publish(float64(0.5))
    assert spin_until(executor, lambda: sup._t_state is not None, timeout=20.0)
    client.force.publish(float64(5.0))
    assert spin_until(executor, lambda: len(sent) == 1, timeout=20.0)
    assert sent == [5.0] or sup.supervisor.aborted == "stale"  # fresh (or already stale on a slow host)
    spin_for(executor, 3 * sup.supervisor.limits.stale_timeout)  # the watch may hold 0 N meanwhile
    n = len(sent)
    client.force.publish(float64(5.0))
    assert spin_until(executor, lambda: len(sent) > n, timeout=20.0)
    assert sent[-1] == 0.0 and sup.supervisor.aborted == "stale"
    assert sup.status()["override_stale"] >= 1


def events(text: str, name: str) -> list[dict]:
    found = (parse_event(line, NODE_NAME) for line in text.splitlines())
    return [e for e in found if e is not None and e["event"] == name]


def test_a_plant_that_falls_silent_gets_zero_force_and_ends_the_run_as_stale(ctx, executor, capsys):
    """Real time, no command at all after the plant's last state (an agent waits on the next one):
    the node's own watch sends 0 N, and the run in progress ends as one ``run`` event, aborted stale."""
    sup, state, sent, client = _behind_supervisor(ctx, executor, Parameter("run_steps", value=500))
    reference = client.node.create_publisher(Float64, REFERENCE.name, qos(REFERENCE))
    assert spin_until(executor, lambda: reference.get_subscription_count() > 0, timeout=20.0)
    reference.publish(float64(1.0))
    assert spin_until(executor, lambda: sup.runs.in_run, timeout=20.0)
    capsys.readouterr()
    state.publish(float64(0.5))  # the plant's last word
    assert spin_until(executor, lambda: sup._t_state is not None, timeout=20.0)
    assert spin_until(executor, lambda: not sup.runs.in_run, timeout=60.0)
    assert 0.0 in sent
    runs = events(capsys.readouterr().out, "run")
    assert len(runs) == 1 and runs[0]["aborted"] == "stale" and not runs[0]["complete"]
    assert runs[0]["samples"] == 1


def test_a_silent_plant_commanded_by_another_node_gets_nothing_from_the_supervisor(ctx, executor):
    """Real time, no run and no command through the node (the bench's recordings play straight to
    the plant while the supervisor waits for validation): the plant falls silent, and the watch
    writes nothing on the plant's command topic, where a 0 N would land in the experiment. Once a
    controller commands through the node, the same silence is held at 0 N."""
    sup, state, sent, client = _behind_supervisor(ctx, executor)
    state.publish(float64(0.5))  # the plant's last word
    assert spin_until(executor, lambda: sup._t_state is not None, timeout=20.0)
    limit = sup.supervisor.limits.stale_timeout
    assert spin_until(executor, lambda: time.monotonic() - sup._t_state > 4 * limit, timeout=20.0)
    spin_for(executor, 2 * limit)  # the watch has looked at the silence several times
    assert sent == [] and not sup._holding
    client.force.publish(float64(5.0))
    assert spin_until(executor, lambda: len(sent) >= 1, timeout=20.0)
    state.publish(float64(0.5))
    assert spin_until(executor, lambda: sup._holding or sup.supervisor.aborted == "stale", timeout=20.0)
    assert sent[-1] == 0.0


def test_a_reference_starts_a_run_reported_as_one_event_and_an_estop_aborts_it(ctx, executor, capsys):
    """``run_steps`` mode (bench.py's): each reference starts a run of that many state samples, which
    ends as one ``run`` event with its overrides (the in-process filter's) and its abort; commands
    outside a run are counted apart, and closing the node reports its totals."""
    n = 60  # always +F: overridden from sample 35 on
    adv = adversary("always_plus", PLANT, n)
    ref = run_on_plant(PLANT, SupervisorOptions().limits(PLANT), adv, np.zeros((1, n)))
    plant = PlantNode(true_plant_spec(), config=PlantNodeConfig(lockstep=True, duplicate_check=0.0),
                      context=ctx)
    sup = SupervisorNode(context=ctx, parameter_overrides=[Parameter("lockstep", value=True),
                                                           Parameter("run_steps", value=n)])
    executor.add_node(plant)
    executor.add_node(sup)
    client = Controller(ctx, executor)
    reference = client.node.create_publisher(Float64, REFERENCE.name, qos(REFERENCE))
    pubs = [client.force, client.estop, reference, sup._pub_cmd, sup._pub_pos, sup._pub_state, plant._pub_x]
    assert spin_until(executor, lambda: all(p.get_subscription_count() > 0 for p in pubs), timeout=20.0)
    client.send_and_wait(0.0)  # before any run: counted outside
    reference.publish(float64(1.0))
    assert spin_until(executor, lambda: sup.runs.in_run, timeout=10.0)
    capsys.readouterr()
    for u in ref.command[0]:  # the run starts at rest at x = 0, as the in-process one does
        client.send_and_wait(float(u))
    first = events(capsys.readouterr().out, "run")
    assert len(first) == 1 and not sup.runs.in_run
    assert first[0]["steps"] == n and first[0]["samples"] == n and first[0]["complete"]
    assert first[0]["overrides"]["envelope"] == np.count_nonzero(ref.reason[0] == 1) > 0
    assert first[0]["aborted"] is None
    reference.publish(float64(0.5))
    assert spin_until(executor, lambda: sup.runs.in_run, timeout=10.0)
    client.send_and_wait(5.0)
    client.estop.publish(Empty())
    assert spin_until(executor, lambda: sup.supervisor.estop_latched, timeout=10.0)
    for _ in range(n - 1):
        client.send_and_wait(5.0)
    second = events(capsys.readouterr().out, "run")
    assert len(second) == 1 and second[0]["aborted"] == "estop" and second[0]["reference"] == 0.5
    assert second[0]["overrides"]["estop"] == n - 1
    sup.close()
    done = events(capsys.readouterr().out, "supervisor_done")
    assert len(done) == 1 and done[0]["runs"] == 2 and done[0]["aborted_runs"] == 1
    assert done[0]["outside_steps"] == 1 and done[0]["estop_latches"] == 1


def test_a_flood_of_wrong_clears_clears_nothing_and_is_logged_once_a_second(ctx, executor):
    """'01' for latch 1 clears nothing, and 300 wrong clears are a few counted lines, not 300."""
    sup, client = start(ctx, executor)
    client.estop.publish(Empty())
    assert spin_until(executor, lambda: sup.supervisor.estop_latched)
    said: list[int] = []
    note = sup._wrong_clears.note
    sup._wrong_clears.note = lambda now: said.append(note(now)) or said[-1]  # type: ignore[method-assign]
    started = time.monotonic()
    for i in range(300):  # one at a time: the topic's depth is 10
        client.clear.publish(String(data="01"))
        assert spin_until(executor, lambda i=i: len(said) > i)
    seconds = time.monotonic() - started
    lines = [c for c in said if c]
    assert sup.supervisor.estop_latched
    assert len(lines) <= seconds + 1 and sum(lines) + sup._wrong_clears.pending == 300
    client.clear.publish(String(data="1"))
    assert spin_until(executor, lambda: not sup.supervisor.estop_latched)
