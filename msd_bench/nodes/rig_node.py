"""The rig emulator node: :class:`PlantNode` serving :class:`msd_bench.core.rigs.rig.Rig` (docs/rig.md).

It speaks the plant's topic contract under ``/rig`` — ``force`` in,
``joint_states`` (joint ``msd_slider``, stamped), ``position`` and
``/diagnostics`` out, the ``plant_claim`` duplicate check — and behaves like
hardware: real time only (no lock-step, never ``/clock``) and **no** ``reset``
subscription (a rig cannot teleport; bringing it to rest is the bench's job).

What it inherits unchanged from the plant node: the 100 Hz sample thread
sleeping to absolute deadlines (:class:`~msd_bench.nodes.spin.DeadlineThread`,
so the mean rate is exactly 1/dt; the jitter delay below is slept there too),
zero-order hold of the latest command, saturation to ±F (counted), rejection of
non-finite commands (counted, throttled warning, the last safe force kept), the
watchdog, the counters and diagnostics.

What it changes, per sample (:meth:`RigNode._tick`): the command goes through
the rig's actuator (delay, lag) and friction; ``joint_states`` carries the
measured position, the velocity estimated from measured positions and, as
``effort``, the force the actuator actually applies over the sample (after
saturation, delay and lag; friction is not part of it). The message is
published after a random jitter delay, stamped with the acquisition time. A
watchdog trip disables the drive at once (delay line and lag emptied), as a
drive's own watchdog does. ``truth/joint_states`` (true position and velocity)
exists only with ``publish_truth`` (tests and scoring; a real rig has none).

``population_seed`` picks a member of the rig population
(:mod:`msd_bench.core.rigs.population`), of the family ``family``
(:mod:`msd_bench.core.rigs.families`; ``default`` unless given): its plant and
imperfections become the parameters' defaults, so explicit parameters still
win; the start-up line prints the served rig with every parameter. A member
whose value lies outside a parameter's usual range (a ``scaled`` rig's force)
widens that range to hold it.

With ``-p interface:=ros2_control`` it shows the face of a forward effort
controller and a joint state broadcaster instead (docs/ros2-control.md §Face):
commands as ``Float64MultiArray`` on ``<controller>/commands`` (one value per
controller joint; a command of the wrong length is refused and counted),
``joint_states`` with ``extra_joints`` listed before ours (``slider_to_cart``
by default), effort = the actuator's force as above (lagged: what the
hardware measures), and no ``position`` topic.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field, replace
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor, ParameterType
from rclpy._rclpy_pybind11 import RCLError
from rclpy.publisher import Publisher
from std_msgs.msg import Float64

from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.plant import PRESETS, PlantParams
from msd_bench.core.rigs import families
from msd_bench.core.rigs.hold import HoldLoop
from msd_bench.core.rigs.population import EMULATOR_SEED, MAX_SEED, RigSpec
from msd_bench.core.rigs.rig import Rig, RigImperfections
from msd_bench.core.rigs.rig_play import HeldDrive
from msd_bench.io.reports.live_server import OFF
from msd_bench.nodes.interface_params import declare_interface
from msd_bench.nodes.params import declare_from_dataclass, params_file_rig, rig_plant
from msd_bench.nodes.plant_node import (
    PLANT_RANGES,
    ModelSpec,
    PlantNode,
    PlantNodeConfig,
    declare_plant_params,
    plant_model_spec,
)
from msd_bench.nodes.spin import stops_deferred
from msd_msgs_py.contract import TRUTH_JOINT_STATES
from msd_msgs_py.ros import command_force, float64, joint_states, msg_class, qos


@dataclass(frozen=True)
class DriveHold:
    """The position loop the rig's drive holds it under, as a stage's drive runs one (docs/rig-families.md
    §stage): its force, from the measured position, is added to every command at every sample
    (:class:`~msd_bench.core.rigs.rig_play.HeldDrive`, as a plan is played in-process), so the commands
    the bench sends are the force beyond the loop's. A member of a family that states a loop holds it by
    default; stiffness and damping 0 run the rig bare."""

    hold_stiffness: float = field(default=0.0, metadata={"range": (0.0, 1e9)})
    """N/m on the measured position's error (0 with ``hold_damping`` 0: no loop)."""
    hold_damping: float = field(default=0.0, metadata={"range": (0.0, 1e9)})
    """N·s/m on the velocity estimated from the measured positions."""
    hold_position: float = field(default=0.0, metadata={"range": (-1e6, 1e6)})
    """The position held, m."""

    def loop(self) -> HoldLoop | None:
        """The loop, or None on a bare rig."""
        return HoldLoop.from_gains(self.hold_stiffness, self.hold_damping, self.hold_position)

    @classmethod
    def of(cls, loop: HoldLoop | None) -> DriveHold:
        """The parameters' defaults for a member's ``loop``."""
        return cls() if loop is None else cls(loop.stiffness, loop.damping, loop.held)


RIG_NAMESPACE = "/rig"
"""Default namespace of the rig emulator."""
RIG_PRESET = "rig"
"""Default plant preset of the rig emulator (core/physics/plant.py PRESETS)."""


@dataclass(frozen=True)
class RigNodeConfig:
    """How the rig emulator runs (its imperfections are :class:`RigImperfections`)."""

    watchdog_timeout: float = field(default=0.5, metadata={"range": (0.001, 60.0)})
    """Seconds without a valid command after which the drive is disabled (0 N at once, nothing
    left in flight)."""
    duplicate_check: float = field(default=4.0, metadata={"range": (0.0, 30.0)})
    """Seconds to listen for an earlier plant-like node's claim on the namespace before serving
    (claims are also re-checked every second afterwards); 0 serves at once."""
    seed: int = field(default=0, metadata={"range": (0, 2**31 - 1)})
    """Seed of the sensor-noise and publish-jitter generators (two independent streams)."""
    population_seed: int = field(default=EMULATOR_SEED, metadata={"range": (0, MAX_SEED)})
    """Which member of the rig population to serve (docs/rig.md §Population): its plant and
    imperfections become the defaults, explicit parameters still win; 0 = the emulator's own
    defaults."""
    family: str = families.DEFAULT_FAMILY
    """The rig family ``population_seed`` is drawn from (docs/rig-families.md); an unknown name is one
    line naming the families."""
    publish_truth: bool = False
    """Also publish the true position and velocity on truth/joint_states (tests and scoring only:
    a real rig has no truth)."""
    extra_joints: tuple[str, ...] = ("pole_joint",)
    """ros2_control face only: joints listed before ours in joint_states (at rest, no effort), as a
    joint state broadcaster of a larger robot would, so clients must pick our joint by name."""
    live_port: int = field(default=OFF, metadata={"range": (OFF, 65535)})
    """Serve the live view (a Foxglove WebSocket server on 127.0.0.1, docs/live.md) on this port: the
    rig's measured rows decimated to 50 Hz and the set-point; 0 picks a free port; -1 serves none."""


def holding(ranges: dict[str, tuple[float, float]], member: object) -> dict[str, tuple[float, float]]:
    """``ranges`` widened, where the served member's value of a field lies outside, to hold it."""
    out = {}
    for name, (lo, hi) in ranges.items():
        value = getattr(member, name, None)
        out[name] = (lo, hi) if value is None else (type(lo)(min(lo, value)), type(hi)(max(hi, value)))
    return out


class RigNode(PlantNode):
    """The emulated rig: real time, imperfect, no reset."""

    SERVES_RESET = False

    def __init__(self, *, node_name: str = "rig", namespace: str = RIG_NAMESPACE, **node_kwargs: Any) -> None:
        self._params: PlantParams | None = None
        self._dropped = 0
        super().__init__(self._declare_plant, node_name=node_name, namespace=namespace, **node_kwargs)

    def _declare_config(self) -> PlantNodeConfig:
        if "lockstep" in getattr(self, "_parameter_overrides", {}):
            raise ConfigError("the rig emulator runs in real time only (no lock-step, no /clock): "
                              "drop -p lockstep")
        self.rig_config = declare_from_dataclass(self, RigNodeConfig)
        self.member = families.draw(self.rig_config.family, self.rig_config.population_seed)
        rig = params_file_rig()  # a described rig: the member's imperfections in its scales and rate
        imperfections = self.member.imperfections
        if rig is not None:
            imperfections = imperfections.scaled(rig.scales())
        self.imperfections = declare_from_dataclass(
            self, RigImperfections, defaults=imperfections,
            ranges=holding({f.name: f.metadata["range"] for f in dataclasses.fields(RigImperfections)
                            if "range" in f.metadata}, imperfections))
        self.hold = declare_from_dataclass(self, DriveHold, defaults=DriveHold.of(self.member.hold)).loop()
        self.interface = declare_interface(self)
        self._names = self.interface.state_names(self.rig_config.extra_joints)
        if self._names.count(self.interface.joint) > 1:
            raise ConfigError(f"extra_joints must not name our joint {self.interface.joint!r}")
        self._pad = [0.0] * (len(self._names) - 1)  # the other joints, at rest, before ours
        return PlantNodeConfig(
            lockstep=False, watchdog_timeout=self.rig_config.watchdog_timeout,
            duplicate_check=self.rig_config.duplicate_check, sensor_noise=self.imperfections.sensor_noise,
            sensor_quant=self.imperfections.sensor_quant, sensor_seed=self.rig_config.seed,
            live_port=self.rig_config.live_port)

    def _position_publisher(self) -> Publisher[Any] | None:
        """None where the face has no ``position`` topic (ros2_control)."""
        return None if self.interface.position is None else super()._position_publisher()

    def _subscribe_commands(self) -> None:
        """The face's command topic: ``force`` on the msd face; ``<controller>/commands`` (one value per
        joint) on ros2_control. The rig runs in real time only, so the topic's own depth holds."""
        cmd = self.interface.command
        self.create_subscription(msg_class(cmd), cmd.name, self._on_commands, qos(cmd))

    def _on_commands(self, msg: Any) -> None:
        """A forward command controller's input: our joint's value, or nothing if the length is wrong."""
        u = command_force(self.interface, msg)
        if u is None:
            self.counters["rejected"] += 1
            self.get_logger().warning(
                f"rejected a command of {len(msg.data)} values for {len(self.interface.controller_joints)} "
                f"joints {list(self.interface.controller_joints)}", throttle_duration_sec=1.0)
            return
        self._on_force(Float64(data=u))

    def _state_message(self, stamp: int, x: float, v: float, effort: float) -> Any:
        """joint_states as this face shows it: our joint alone, or after the extra joints."""
        return joint_states(stamp, self._names, [*self._pad, x], [*self._pad, v], [*self._pad, effort])

    def _declare_plant(self, _node: Any) -> ModelSpec:
        self._params = self._declare_member_plant()
        self.imperfections.check_against(self._params)
        spec = plant_model_spec(self._params)
        return replace(spec, model=replace(spec.model, name="rig emulator"))  # logs, diagnostics

    def _declare_member_plant(self) -> PlantParams:
        """The plant: the population member's, unless ``preset`` is given (then that preset's);
        each field given explicitly wins either way."""
        if "preset" in self._explicit():
            return declare_plant_params(self, RIG_PRESET)
        self.declare_parameter("preset", RIG_PRESET, ParameterDescriptor(
            name="preset", type=ParameterType.PARAMETER_STRING, read_only=True,
            description="Named plant parameter set the fields default to instead of the population "
                        f"member's, read once at start-up: {', '.join(sorted(PRESETS))}."))
        plant = rig_plant(self.member.params)
        return declare_from_dataclass(self, PlantParams, defaults=plant,
                                      ranges=holding(PLANT_RANGES, plant))

    def _explicit(self) -> set[str]:
        """Names of the parameters given on the command line (or as overrides)."""
        return set(getattr(self, "_parameter_overrides", {}))

    def served(self) -> RigSpec:
        """The rig this node serves: the member with every explicit parameter applied."""
        assert self._params is not None
        return replace(self.member, params=self._params, imperfections=self.imperfections, hold=self.hold)

    def _init_sensor(self) -> None:
        """The core rig (sensor, actuator, friction, jitter) and, if asked, the truth topic."""
        assert self._params is not None  # set by _declare_plant, which the base runs first
        self.rig = Rig(self._params, self.imperfections, self.rig_config.seed)
        with stops_deferred():  # compile the friction step before the first tick
            Rig(self._params, self.imperfections).step(0.0)
        self._sensor = self.imperfections.sensor
        self._pub_truth: Publisher[Any] | None = None
        if self.rig_config.publish_truth:
            self._pub_truth = self.create_publisher(
                msg_class(TRUTH_JOINT_STATES), TRUTH_JOINT_STATES.name, qos(TRUTH_JOINT_STATES))

    def _sensor_text(self) -> str:
        """The served rig on one line (:meth:`RigSpec.line`), what was set explicitly, the noise seed."""
        fields = {f.name for f in (*dataclasses.fields(PlantParams), *dataclasses.fields(RigImperfections))}
        explicit = sorted(self._explicit() & (fields | {"preset"}))
        note = f"population member, explicit {', '.join(explicit)}" if explicit else "population member"
        return f"{self.served().line()} ({note}); noise and jitter seed {self.rig_config.seed}"

    def _on_reset(self, _msg: Any) -> None:
        """Start-up only (no reset topic): at rest at the origin, drive off."""
        self.rig.reset()
        self._drive = HeldDrive(self.rig, self.hold)
        self._k = 0
        self._u = 0.0
        self._t_cmd: float | None = None

    def _cut_drive(self) -> None:
        """E-stop: the drive disabled as its watchdog does (delay line and lag emptied)."""
        self.rig.cut()

    def _check_watchdog(self, t: float) -> None:
        trips = self.counters["watchdog"]
        super()._check_watchdog(t)
        if self.counters["watchdog"] != trips:
            self.rig.cut()

    def _dropped_sample(self) -> None:
        """The middleware refused a sample (a reliable reader that stopped reading, on a loaded machine
        at 1 kHz): a rig's driver drops it and keeps its clock; readers see the gap in the stamps.
        Why not end the node, as an exception in the sample thread does: one slow reader would
        otherwise stop the rig under every other reader. A refusal after shutdown still ends it."""
        if not self.context.ok():
            raise RCLError("context shut down")
        self._dropped += 1
        self.get_logger().warning(f"a sample could not be published (a reader is not keeping up); "
                                  f"{self._dropped} dropped so far", throttle_duration_sec=1.0)

    def _tick(self, t_sched_ns: int) -> None:
        """Acquire sample k at ``t_sched_ns``, step the rig, publish after the jitter delay."""
        t_sched = t_sched_ns * 1e-9
        self._check_watchdog(t_sched)
        command = self._drive.command(self._u)  # the loop reads every sample, e-stop or not
        row = self.rig.step(self._u if self.estop_latched else command)  # an e-stop disables the loop too
        stamp = self._stamp(t_sched_ns)
        self._note_estop(stamp)
        wait = t_sched + self.rig.publish_delay() - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        self._k += 1
        self.counters["steps"] += 1
        try:
            if self._pub_x is not None:  # the plant node's order: position, then row
                self._pub_x.publish(float64(row.measured_next))
            self._pub_js.publish(self._state_message(stamp, row.measured, row.velocity, row.effort))
            if self._pub_truth is not None:
                self._pub_truth.publish(self._state_message(stamp, row.x, row.v, row.effort))
        except RCLError:
            self._dropped_sample()
        if self._live is not None:
            self._live.plant(stamp, row.measured, row.velocity, row.effort)


def build_rig() -> RigNode:
    """The node ``launch_scripts/rig.py`` runs."""
    return RigNode()
