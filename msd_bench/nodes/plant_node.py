"""The plant-like node: any :class:`StepModel` behind the topic contract (docs/design.md §Contract).

The same class serves the emulated NL-MSD (:func:`true_plant_spec`) and, later,
every identified surrogate: it only steps ``model`` and translates messages.

Sample alignment (both modes). Each step k the node

1. takes the force ``u_k`` (saturated to ±F),
2. advances the model and publishes ``position`` = ``x_{k+1}`` (the newest
   state) — first, because a lock-step client is waiting for it;
3. publishes ``joint_states`` row k: stamp ``t_k``, position ``x_k``, velocity
   ``v_k`` and effort ``u_k`` — the force actually applied over [t_k, t_k+1),
   so a bag row is exactly ``plant.simulate``'s ``(x[k], v[k], u_applied[k])``
   — and, in lock-step only, ``/clock`` = ``(k+1)·dt`` if the node owns
   the clock (``publish_clock``: true for the emulated plant, false by default
   for a surrogate, so a graph has one /clock publisher).

Real-time: a thread of the node's own (:class:`DeadlineThread`) sleeps to
absolute monotonic deadlines 1/dt apart and runs the step with the latest
command (zero-order hold) and publishes from there (:class:`DeadlinePacer`: a
stall is caught up by a burst, so the mean rate stays 1/dt); the executor only
serves subscriptions, services and the 1 Hz timers, so its wake-ups no longer
decide when a sample goes out (its Python still shares the GIL). Stamps are the
scheduled sample times (ROS time at start + k·dt). A lock orders the thread's
steps with the executor's command and reset callbacks: a command is applied
from the next step on. The thread stops in :meth:`close` / ``destroy_node`` and
when the context shuts down (a signal). A watchdog uses 0 N once the last
command is older than ``watchdog_timeout``. A non-finite command is rejected
(counted, throttled warning) and the last safe force is kept.

Lock-step: one step per received command, stamps ``k·dt``; deterministic. A
non-finite command is rejected and does *not* step (sim time never advances on
garbage; a client that waits for the sample times out and sees the warning).
A closed-loop client sends ``u_k`` and waits for ``position`` (``x_{k+1}``).

``reset`` (std_msgs/Empty) returns the model to rest at sample 0, force 0. In
lock-step the node acknowledges a reset by publishing ``position`` = x_0: a
client sends ``reset``, waits for that one position, then sends ``u_0`` — the
reset and force topics are not ordered with respect to each other, so without
the acknowledgement a command could overtake the reset.

Sensor (``sensor_noise``/``sensor_quant`` > 0): a real rig reports what its
encoder reads, not the state, so ``joint_states.position`` and ``position``
carry the position measured through core's :class:`SensorModel` (one draw per
sample: x_{k+1} is measured once, published on ``position`` and reused as row
k+1), and ``joint_states.velocity`` is core's backward-difference estimate from
those measured positions (0 at sample 0). The state itself — what the model
steps — is never touched. The noise-free row goes to ``truth/joint_states``
(scoring only: identification never reads it), published only while a sensor
is active so a rig-like graph without one has no such topic. The generator is
seeded once from ``sensor_seed`` and runs on across resets, so a node's noise
is a function of its seed and of the commands it has stepped.
"""

from __future__ import annotations

import gc
import math
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import ParameterDescriptor, ParameterType
from rclpy.clock import Clock, ClockType  # type: ignore[attr-defined]  # re-exported at run time
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.task import Future
from std_msgs.msg import Empty, Float64, String

from msd_bench.core.errors import MsdBenchError
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.physics.plant import PRESETS, PlantParams, preset
from msd_bench.core.physics.sensor import SensorModel, VelocityEstimator, sensor_rng
from msd_bench.core.safety.supervisor import MAX_LATCH_TEXT, LogThrottle, parse_latch
from msd_bench.io.reports.live_server import OFF, LiveServer, start_live
from msd_bench.nodes import plant_claim
from msd_bench.nodes.health import StallTracker, diagnostic_array
from msd_bench.nodes.params import (
    declare_from_dataclass,
    keep_own_clock,
    reject_unknown_parameters,
    rig_plant,
)
from msd_bench.nodes.spin import DeadlinePacer, DeadlineThread, stops_deferred
from msd_msgs_py.contract import (
    CLOCK,
    DIAGNOSTICS,
    ESTOP,
    ESTOP_CLEAR,
    FORCE,
    JOINT_STATES,
    LOCKSTEP_COMMAND_DEPTH,
    PLANT_CLAIM,
    PLANT_NAMESPACE,
    POSITION,
    REFERENCE,
    RESET,
    TRUTH_JOINT_STATES,
)
from msd_msgs_py.ros import clock, float64, joint_state, msg_class, qos


class GraphConflictError(MsdBenchError):
    """Another node already serves the topics this node would publish."""


EXIT_CONFLICT = 2
"""Exit status of a plant-like node that gave its namespace to an earlier one."""
EXIT_TICK_FAILED = 1
"""Exit status of a real-time node whose sample thread raised (the traceback is printed)."""


@dataclass(frozen=True)
class PlantNodeConfig:
    """How a plant-like node runs (not what it simulates)."""

    lockstep: bool = False
    """Advance one step per received command (and publish /clock if ``publish_clock``), instead of
    the 100 Hz sample thread."""
    publish_clock: bool = True
    """Lock-step only: publish sim time on /clock. One node of a graph owns /clock: the emulated plant
    by default; surrogate nodes default to false (two publishers would make sim time jump)."""
    watchdog_timeout: float = field(default=0.5, metadata={"range": (0.001, 60.0)})
    """Real-time only: seconds without a command after which the applied force drops to 0 N."""
    duplicate_check: float = field(default=4.0, metadata={"range": (0.0, 30.0)})
    """Seconds to listen for an earlier plant-like node's claim on the namespace before serving
    (claims are also re-checked every second afterwards); 0 serves at once."""
    sensor_noise: float = field(default=0.0, metadata={"range": (0.0, 1.0)})
    """Standard deviation (m) of the Gaussian noise on the published position; 0 = none. With a
    sensor, joint_states carries measured positions, an estimated velocity, and the truth goes to
    truth/joint_states (scoring only)."""
    sensor_quant: float = field(default=0.0, metadata={"range": (0.0, 1.0)})
    """Quantisation step (m) of the published position, applied after the noise; 0 = none."""
    sensor_seed: int = field(default=0, metadata={"range": (0, 2**31 - 1)})
    """Seed of the sensor noise generator (read once at start-up; resets do not re-seed it)."""
    live_port: int = field(default=OFF, metadata={"range": (OFF, 65535)})
    """Serve the live view (a Foxglove WebSocket server on 127.0.0.1, docs/live.md) on this port: the
    plant's rows decimated to 50 Hz of wall time and the set-point; 0 picks a free port (logged);
    -1 (default) serves none."""

    def __post_init__(self) -> None:
        SensorModel(self.sensor_noise, self.sensor_quant)  # a bad sensor is one ConfigError line

    @property
    def sensor(self) -> SensorModel | None:
        """The sensor the node measures through (None: positions published as they are)."""
        sensor = SensorModel(self.sensor_noise, self.sensor_quant)
        return None if sensor.is_ideal else sensor


@dataclass(frozen=True)
class ModelSpec:
    """The model a plant-like node serves, with the two facts the kernel does not carry."""

    model: StepModel
    """Stepped once per sample."""
    dt: float
    """Sample time in s (the real-time timer period and the lock-step clock increment)."""
    force_limit: float
    """Commands are saturated to ±force_limit before they act (the plant's F)."""


def true_plant_spec(preset_name: str = "default", **overrides: float) -> ModelSpec:
    """The emulated NL-MSD of a named preset with fields overridden."""
    params = preset(preset_name, **overrides)
    return ModelSpec(plant_model(params), params.dt, params.F)


PLANT_RANGES: dict[str, tuple[float, float]] = {
    "m": (1e-3, 1e3),
    "k": (0.0, 1e3),
    "F": (1e-3, 1e4),
    "dt": (1e-4, 1.0),
}
"""Bounds ``ros2 param describe`` shows for the plant's mass (kg), spring gain (N), force limit (N)
and sample time (s): wide enough for any rig, narrow enough to catch a unit slip."""


def declare_true_plant(node: Node, default_preset: str = "default") -> ModelSpec:
    """Read ``preset`` and the :class:`PlantParams` fields (defaults from the preset) as parameters."""
    return plant_model_spec(declare_plant_params(node, default_preset))


def plant_model_spec(params: PlantParams) -> ModelSpec:
    """The :class:`ModelSpec` of the NL-MSD with ``params``."""
    return ModelSpec(plant_model(params), params.dt, params.F)


def declare_plant_params(node: Node, default_preset: str = "default") -> PlantParams:
    """``preset`` (default ``default_preset``) and the :class:`PlantParams` fields as parameters."""
    desc = ParameterDescriptor(
        name="preset", type=ParameterType.PARAMETER_STRING, read_only=True,
        description=f"Named plant parameter set the fields default to, read once at start-up: "
                    f"{', '.join(sorted(PRESETS))}.",
    )
    name: str = node.declare_parameter("preset", default_preset, desc).value
    defaults = rig_plant(preset(str(name)))  # a rig file's stroke, force limit and rate
    return declare_from_dataclass(node, PlantParams, defaults=defaults, ranges=PLANT_RANGES)


class PlantNode(Node):
    """Serve a :class:`StepModel` on ``position``/``joint_states``/``force``/``reset``.

    Subclasses (the rig emulator, :mod:`.rig_node`) change what one sample does
    through three hooks: :meth:`_declare_config`, :meth:`_tick` and
    ``SERVES_RESET``.
    """

    SERVES_RESET = True
    """Subscribe to ``reset``: False for a node that cannot teleport (a rig)."""

    def __init__(
        self,
        spec: ModelSpec | Any,
        *,
        config: PlantNodeConfig | None = None,
        node_name: str = "plant",
        namespace: str = PLANT_NAMESPACE,
        clock_owner: bool = True,
        **node_kwargs: Any,
    ) -> None:
        """``spec`` is a :class:`ModelSpec` or a callable ``(node) -> ModelSpec`` reading parameters.

        ``clock_owner``: the default of ``publish_clock`` (the plant owns sim time, a surrogate not).
        """
        super().__init__(node_name, namespace=namespace, **node_kwargs)
        self._clock_owner = clock_owner
        self.config = config or self._declare_config()
        self.spec: ModelSpec = spec if isinstance(spec, ModelSpec) else spec(self)
        self._is_plant = self.spec.model.kind == kernels.KIND_PLANT
        self._dt_ns = round(self.spec.dt * 1e9)
        self.counters = {"steps": 0, "rejected": 0, "saturated": 0, "watchdog": 0}
        self._lock = threading.Lock()
        """Held by each real-time step and by the command and reset callbacks (two threads)."""
        self._ticker: DeadlineThread | None = None
        reject_unknown_parameters(self)
        keep_own_clock(self)  # use_sim_time refused, at start and by ros2 param set (nodes/params.py)
        self._live = self._start_live()  # before the slow start-up: a port in use stops it at once
        self.done: Future[int] = Future()
        """Completes with :data:`EXIT_CONFLICT` when an earlier plant claims the namespace."""
        self._claim_namespace()
        with stops_deferred():  # compile before the first tick; a stop waits until it is done
            self.spec.model.step(self.spec.model.initial_state(), 0.0)
        self._pub_js: Publisher[Any] = self.create_publisher(
            msg_class(JOINT_STATES), JOINT_STATES.name, qos(JOINT_STATES)
        )
        self._pub_x: Publisher[Any] | None = self._position_publisher()
        self._pub_clock: Publisher[Any] | None = (
            self.create_publisher(msg_class(CLOCK), CLOCK.name, qos(CLOCK))
            if self.config.lockstep and self.config.publish_clock else None
        )
        self._init_sensor()
        self._subscribe_commands()
        if self.SERVES_RESET:
            self.create_subscription(Empty, RESET.name, self._on_reset_msg, qos(RESET))
        self._on_reset(None)
        self._init_estop()
        self._pacer = DeadlinePacer(self.spec.dt, lead=0.0)  # the sample thread sleeps to each deadline
        self._reanchors_seen = 0
        self._ros0 = self.get_clock().now().nanoseconds
        self._mono0_ns = time.monotonic_ns()
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(plant_claim.HEARTBEAT_S, self._on_heartbeat, clock=steady)
        self._stalls = StallTracker(self.spec.dt)
        self._pub_diag: Publisher[DiagnosticArray] = self.create_publisher(
            DiagnosticArray, DIAGNOSTICS.name, qos(DIAGNOSTICS))
        self._last_counters = dict(self.counters)
        self.create_timer(1.0, self._on_diagnostics, clock=steady)
        if not self.config.lockstep:
            self._ticker = DeadlineThread(self._pacer, self._on_due, alive=self.context.ok,
                                          on_error=self._on_tick_error, name=f"{node_name} samples")
            self._start_timer = self.create_timer(0.0, self._start_ticker, clock=steady)
        mode = "lock-step" if self.config.lockstep else f"real-time {1 / self.spec.dt:g} Hz"
        self.get_logger().info(f"plant-like node {self.spec.model.name or 'model'} ready ({mode}"
                               f"{', ' + self._sensor_text() if self._sensor else ''})")

    @property
    def events_executor(self) -> bool:
        """Lock-step: one exchange per command, so run on the events executor (:mod:`.spin`); real-time
        keeps rclpy's default executor (its samples come from the node's own sample thread)."""
        return self.config.lockstep

    def _declare_config(self) -> PlantNodeConfig:
        """Declare the node's own parameters and return how it runs."""
        defaults = PlantNodeConfig(publish_clock=self._clock_owner)  # a surrogate leaves /clock to the plant
        return declare_from_dataclass(self, PlantNodeConfig, defaults=defaults)

    def _position_publisher(self) -> Publisher[Any] | None:
        """The ``position`` publisher (None on a face without one: the rig's ros2_control face)."""
        return self.create_publisher(Float64, POSITION.name, qos(POSITION))

    def _subscribe_commands(self) -> None:
        """Take force commands on ``force`` (the rig's ros2_control face takes them elsewhere).

        In lock-step every command is a step, and an open-loop excitation keeps several in flight
        (:class:`msd_bench.nodes.excitation_node.ExcitationNodeConfig`), so the history holds them all."""
        depth = LOCKSTEP_COMMAND_DEPTH if self.config.lockstep else FORCE.depth
        self.create_subscription(Float64, FORCE.name, self._on_force, qos(FORCE, depth))

    def _init_sensor(self) -> None:
        """The sensor, its generator and velocity estimator, and the truth topic (only with a sensor)."""
        self._sensor = self.config.sensor
        self._rng = sensor_rng(self.config.sensor_seed)
        self._velocity_estimate = VelocityEstimator(self.spec.dt)
        self._pub_truth: Publisher[Any] | None = None
        if self._sensor is not None:
            self._pub_truth = self.create_publisher(
                msg_class(TRUTH_JOINT_STATES), TRUTH_JOINT_STATES.name, qos(TRUTH_JOINT_STATES))

    def _sensor_text(self) -> str:
        s = self._sensor
        return "ideal sensor" if s is None else (
            f"sensor noise {s.noise_std:g} m, quantisation {s.quant:g} m, seed {self.config.sensor_seed}")

    def _measure(self, x: float) -> float:
        """What the sensor reads at true position ``x`` (``x`` itself without a sensor)."""
        return float(x) if self._sensor is None else self._sensor.measure_one(x, self._rng)

    @property
    def k(self) -> int:
        """Index of the next sample to be published (0 after a reset)."""
        return self._k

    def _claim_namespace(self) -> None:
        """One plant per namespace (two would interleave samples): see :mod:`.plant_claim`.

        Announce a claim, then listen for ``duplicate_check`` seconds before
        serving; an earlier live claim stops this node here (GraphConflictError)
        or, if one turns up later, at the next heartbeat (:meth:`_on_heartbeat`).
        """
        self._claim = plant_claim.new_claim(self.get_fully_qualified_name())
        self._claims = plant_claim.ClaimBook(self._claim, self.config.duplicate_check)
        self._pub_claim = self.create_publisher(String, PLANT_CLAIM.name, qos(PLANT_CLAIM))
        listen = qos(PLANT_CLAIM)
        listen.depth = 32  # one latched claim per rival writer, several may arrive in one spin
        self.create_subscription(String, PLANT_CLAIM.name, self._on_claim, listen)
        self._pub_claim.publish(String(data=self._claims.message()))
        if self.config.duplicate_check <= 0:
            return  # the window starts at the first spin (_on_claim, _on_heartbeat)
        executor = SingleThreadedExecutor(context=self.context)
        executor.add_node(self)
        self._claims.begin_listening()
        try:
            deadline = time.monotonic() + self.config.duplicate_check
            while time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)
                rival = self._earlier_rival()
                if rival is not None:
                    raise GraphConflictError(self._conflict_text(rival) + "; refusing to start")
        finally:
            executor.remove_node(self)
            executor.shutdown()

    def _start_live(self) -> LiveServer | None:
        """The live view of ``live_port`` (None when off): the set-point comes from ``reference``."""
        live = start_live(self.config.live_port, self.get_fully_qualified_name())
        if live is not None:
            self.create_subscription(Float64, REFERENCE.name, lambda m: live.setpoint(m.data), qos(REFERENCE))
            self.get_logger().info(f"live view on {live.url} (docs/live.md)")
        return live

    def _on_claim(self, msg: String) -> None:
        self._claims.begin_listening()
        self._claims.hear(msg.data)

    def _earlier_rival(self) -> plant_claim.Claim | None:
        return self._claims.rival()

    def _conflict_text(self, rival: plant_claim.Claim) -> str:
        topic = JOINT_STATES.resolve(self.get_namespace())
        return f"{topic} already has a publisher ({rival.describe(self._claim)})"

    def _on_heartbeat(self) -> None:
        """Re-send the claim; yield to a rival heard during start-up; report, never yield to, later ones."""
        if self.done.done():
            return
        self._claims.begin_listening()
        self._pub_claim.publish(String(data=self._claims.message()))
        rival = self._earlier_rival()
        if rival is not None:
            print(f"error: {self._conflict_text(rival)}; shutting down", file=sys.stderr, flush=True)
            self.done.set_result(EXIT_CONFLICT)
        for late in self._claims.ignored():
            text = plant_claim.ignored_text(late, self._claim, self._claims.listen_from_ns)
            self.get_logger().warning(text)

    def destroy_node(self) -> None:
        """Stop the sample thread, then release the claim (a node destroyed a moment ago is never
        taken for a live one)."""
        self._stop_ticker()
        live = getattr(self, "_live", None)
        if live is not None:
            live.close()
        claim = getattr(self, "_claim", None)
        if claim is not None:
            plant_claim.release(claim)
        super().destroy_node()

    def _on_reset(self, _msg: Empty | None) -> None:
        self._state = self.spec.model.initial_state()
        self._y = self._measure(float(self._state[0]))
        self._velocity_estimate.reset()
        self._k = 0
        self._u = 0.0
        self._t_cmd: float | None = None

    def _on_reset_msg(self, msg: Empty) -> None:
        with self._lock:
            self._on_reset(msg)
            if self.config.lockstep and self._pub_x is not None:
                self._pub_x.publish(float64(self._y))

    def _init_estop(self) -> None:
        """The drive's e-stop latch (docs/faults.md §Trust boundary): anyone latches it on ``estop``;
        only ``estop_clear`` naming the latch count clears it; a reset never does."""
        self.estop_latches = 0
        self.estop_latched = False
        self._wrong_clears = LogThrottle(1.0)  # one line a second, with a count, however many arrive
        self.estop_stamp: int | None = None
        """Stamp (ns) of the first row stepped after the latest latch: from it on every row is 0 N."""
        self.create_subscription(Empty, ESTOP.name, self._on_estop, qos(ESTOP))
        self.create_subscription(String, ESTOP_CLEAR.name, self._on_estop_clear, qos(ESTOP_CLEAR))

    def _on_estop(self, _msg: Empty) -> None:
        with self._lock:
            self.estop_latches += 1
            self.estop_latched = True
            self.estop_stamp = None
            self._u, self._t_cmd = 0.0, None
            self._cut_drive()
        self.get_logger().warning(f"e-stop latched (latch {self.estop_latches}) at sample {self._k}: 0 N")

    def _on_estop_clear(self, msg: String) -> None:
        latch = parse_latch(msg.data[:MAX_LATCH_TEXT + 64])
        with self._lock:
            cleared = self.estop_latched and latch == self.estop_latches
            self.estop_latched = self.estop_latched and not cleared
        if cleared:
            self.get_logger().info(f"e-stop clear {msg.data[:MAX_LATCH_TEXT]!r}: cleared")
        elif count := self._wrong_clears.note(time.monotonic()):
            more = f", and {count - 1} more wrong clears in the last second" if count > 1 else ""
            self.get_logger().info(f"e-stop clear {msg.data[:MAX_LATCH_TEXT]!r}: ignored "
                                   f"(latch {self.estop_latches}{more})")

    def _note_estop(self, stamp: int) -> None:
        """Remember the first row stepped under the latest e-stop latch (what a test checks)."""
        if self.estop_latched and self.estop_stamp is None:
            self.estop_stamp = stamp

    def _cut_drive(self) -> None:
        """Disable the drive at once (the ideal plant holds no force in flight; a rig empties its)."""

    def _accept(self, u: float) -> float | None:
        """The force to apply, or None if the command must be rejected (0 N while the e-stop holds)."""
        if not math.isfinite(u):
            self.counters["rejected"] += 1
            self.get_logger().warning(
                f"rejected non-finite force command {u} ({self.counters['rejected']} so far)",
                throttle_duration_sec=1.0,
            )
            return None
        if self.estop_latched:
            return 0.0
        limit = self.spec.force_limit
        if abs(u) > limit:
            self.counters["saturated"] += 1
            return math.copysign(limit, u)
        return u

    def _on_force(self, msg: Float64) -> None:
        with self._lock:
            u = self._accept(msg.data)
            if u is None:
                return
            if self.config.lockstep:
                self._step(u, self._k * self._dt_ns)
            else:
                self._u = u
                self._t_cmd = time.monotonic()

    def _on_due(self, now_ns: int, due_ns: list[int]) -> None:
        """Sample thread: run every step whose slot has begun (one, or a burst after a stall)."""
        with self._lock:
            for t_sched_ns in due_ns:
                self._tick(t_sched_ns)
        self._report_stall(now_ns * 1e-9, len(due_ns))

    def _report_stall(self, now: float, caught_up: int) -> None:
        """Log a gap between wake-ups longer than two samples (after the samples went out)."""
        gap = self._stalls.tick(now)
        if gap is not None:
            lost = self._pacer.reanchors > self._reanchors_seen
            self._reanchors_seen = self._pacer.reanchors
            what = "stamps skip the gap (re-anchored)" if lost else f"caught up {caught_up} samples"
            text = f"stall: no timer tick for {gap:.3f} s; {what}"
            if gap > 0.1 or lost:  # long stalls always; short ones (load jitter) once a second
                self.get_logger().warning(text)
            else:
                self.get_logger().warning(text, throttle_duration_sec=1.0)

    def _on_tick_error(self, _exc: BaseException) -> None:
        """The sample thread raised (traceback printed): end the node's spin with a failure status."""
        if not self.done.done():
            self.done.set_result(EXIT_TICK_FAILED)

    def _start_ticker(self) -> None:
        """First spin of the executor: start the sample thread (a node built but never spun — or
        still finishing its start-up — publishes nothing, as with the timer it replaces).

        A full garbage collection first: start-up (numba, rclpy) leaves enough debt that the
        first automatic one is a full pass over ~150,000 objects (~150 ms here) a few seconds
        into the run, i.e. a stall. Afterwards a step allocates nothing that outlives it, so
        the collector stays quiet (none in 20 s measured).
        """
        self.destroy_timer(self._start_timer)
        if self._ticker is not None and not self._ticker.started:
            gc.collect()
            self._ticker.start()

    def _stop_ticker(self) -> None:
        """Stop and join the sample thread (idempotent; nothing to do in lock-step)."""
        ticker = getattr(self, "_ticker", None)
        if ticker is not None:
            ticker.stop()

    def _tick(self, t_sched_ns: int) -> None:
        """One real-time sample, scheduled at monotonic time ``t_sched_ns``."""
        self._check_watchdog(t_sched_ns * 1e-9)
        self._step(self._u, self._stamp(t_sched_ns))

    def _stamp(self, t_sched_ns: int) -> int:
        """ROS time (ns) of the sample scheduled at monotonic ``t_sched_ns``: start + k·dt, exactly."""
        return self._ros0 + t_sched_ns - self._mono0_ns

    def _on_diagnostics(self) -> None:
        """Publish the node's health on /diagnostics (1 Hz)."""
        c = self.counters
        fresh = {k: c[k] - self._last_counters.get(k, 0) for k in c}
        self._last_counters = dict(c)
        watchdog = "n/a (lock-step)" if self.config.lockstep else (
            "tripped" if c["watchdog"] and self._t_cmd is None else "armed" if self._t_cmd is not None
            else "idle")
        values = {
            "mode": "lock-step" if self.config.lockstep else f"real-time {1 / self.spec.dt:g} Hz",
            "sample": self._k, **c, "reanchors": self._pacer.reanchors, "watchdog_state": watchdog,
            "stalls": self._stalls.count, "last_stall_s": self._stalls.last_s,
            "longest_stall_s": self._stalls.longest_s, "force_applied": self._u,
            "sensor": self._sensor_text(),
            "estop": "latched" if self.estop_latched else "clear", "estop_latches": self.estop_latches,
        }
        if self._live is not None:
            with self._lock:  # the sample thread offers rows to the same decimator
                self._live.flush()  # the newest row it held back: the last state always shows
        warnings = [f"{n} {k} in the last second" for k, n in fresh.items() if n and k != "steps"]
        self._pub_diag.publish(diagnostic_array(
            self.get_clock().now().to_msg(), f"{self.get_fully_qualified_name()}: plant-like node",
            self.spec.model.name or "model", values, warnings))

    def _check_watchdog(self, t: float) -> None:
        if self._t_cmd is not None and t - self._t_cmd > self.config.watchdog_timeout:
            self.counters["watchdog"] += 1
            self.get_logger().warning(
                f"no force command for {self.config.watchdog_timeout} s: applying 0 N"
            )
            self._u, self._t_cmd = 0.0, None

    def _velocity(self) -> float:
        s = self._state
        return float(s[1]) if self._is_plant else float(s[0] - s[1]) / self.spec.dt

    def _step(self, u: float, stamp: int) -> None:
        """Advance, publish x_{k+1} on ``position``, then row k (x_k, v_k, u_k) stamped ``stamp``.

        ``position`` goes out first because a lock-step client waits for it
        before it sends the next command: the rows and the clock follow while
        the client is already computing, which shortens every round trip. The
        order of each topic's own messages is unchanged (row k still precedes
        row k+1, which is published on the next command).

        With a sensor, row k carries the measured y_k and the velocity estimated
        from measured positions, the truth row goes to ``truth/joint_states``, and
        ``position`` is the measured y_{k+1} (which row k+1 then repeats).
        """
        self._note_estop(stamp)
        y, x, v = self._y, float(self._state[0]), self._velocity()
        v_row = v if self._pub_truth is None else self._velocity_estimate.update(y)
        x_next = self.spec.model.step(self._state, u)
        self._y = self._measure(x_next)
        self._k += 1
        self.counters["steps"] += 1
        if self._pub_x is not None:
            self._pub_x.publish(float64(self._y))
        self._pub_js.publish(joint_state(stamp, y, v_row, u))
        if self._pub_truth is not None:
            self._pub_truth.publish(joint_state(stamp, x, v, u))
        if self._pub_clock is not None and self._pub_clock.get_subscription_count() > 0:
            self._pub_clock.publish(clock(self._k * self._dt_ns))  # to no reader it is pure cost
        if self._live is not None:
            self._live.plant(stamp, y, v_row, u)

    def close(self) -> None:
        """Stop the sample thread, then log the counters once, at shutdown."""
        self._stop_ticker()
        c = self.counters
        print(
            f"[{self.get_fully_qualified_name()}] shutdown: steps={c['steps']} "
            f"rejected={c['rejected']} saturated={c['saturated']} watchdog={c['watchdog']} "
            f"reanchors={self._pacer.reanchors}",
            flush=True,
        )
