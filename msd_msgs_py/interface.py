"""Plant interfaces: which face a plant-like node shows on the wire (docs/ros2-control.md §Face).

The bench speaks to a plant through one of two faces, chosen once per run and
handed to every node that talks to the plant (as ROS parameters, :func:`ros_args`):

* ``msd`` — the project's own contract (:mod:`msd_msgs_py.contract`): ``force``
  (``std_msgs/Float64``), ``joint_states`` with one joint ``msd_slider`` whose
  effort is the force held over the next sample, ``position``, ``reset``;
* ``ros2_control`` — what a forward effort controller and a joint state broadcaster
  show: commands on ``<controller>/commands`` (``std_msgs/Float64MultiArray``, one
  value per joint in the controller's ``joints`` order), ``joint_states`` with any
  number of joints in any order, effort as the hardware measures it, no
  ``position`` and no ``reset``.

Why objects and not a second code path: every part (recorder, excitation,
identifier, agents, check-rig, the rig and supervisor nodes, the Gymnasium backend)
asks the same object for its topic names and for what differs — building and
reading a command for our joint, which joints the state carries, whether
``position`` and ``reset`` exist — so a new face is one subclass of
:class:`PlantInterface` and one entry in :data:`FACES`, and no caller branches on
which face it holds (``tests/msgs/test_face_switches.py``). Pure Python (bag tooling
imports it without ROS); the rclpy message builders are in :mod:`msd_msgs_py.ros`.
"""

from __future__ import annotations

import argparse
import math
import re
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

from msd_bench.core.errors import InterfaceError
from msd_msgs_py.contract import FORCE, JOINT_NAME, JOINT_STATES, POSITION, RESET, TopicSpec

MSD = "msd"
"""The project's own contract."""
ROS2_CONTROL = "ros2_control"
"""A forward effort controller plus a joint state broadcaster."""

COMMANDED = "commanded"
"""``effort`` is the force the node applies over the next sample (our contract)."""
MEASURED = "measured"
"""``effort`` is what the actuator reports: lagged, noisy; the input is rebuilt from the commands."""
EFFORT_KINDS = (COMMANDED, MEASURED)

DEFAULT_CONTROLLER = "effort_controller"
"""Controller name of the ros2_control face when none is given."""
DEFAULT_ROS2_CONTROL_JOINT = "slider_to_cart"
"""Our joint's name on the ros2_control face when none is given."""
COMMANDS_TYPE = "std_msgs/msg/Float64MultiArray"
"""Message type of a forward command controller's ``commands`` topic."""

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*")
"""A relative ROS name: what a controller name may be (``effort_controller``, ``arm/effort``)."""
_JOINT = re.compile(r"[^\s,\[\]'\"]+")
"""A joint name: anything URDF allows that survives a comma list and a ``-p name:=[a,b]``."""


@dataclass(frozen=True)
class InterfaceParams:
    """The interface as ROS parameters (one per field; empty means the face's default)."""

    interface: str = MSD
    """Face of the plant-like node: ``msd`` (our contract) or ``ros2_control``."""
    controller: str = ""
    """ros2_control: the forward effort controller; commands go to ``<controller>/commands``
    (default ``effort_controller``)."""
    joint: str = ""
    """Our joint's name in ``joint_states`` (default ``msd_slider``; ``slider_to_cart`` for
    ros2_control)."""
    controller_joints: tuple[str, ...] = ()
    """ros2_control: the controller's ``joints`` list, which fixes the order of the command
    vector (default: just ``joint``)."""
    effort: str = ""
    """What ``effort`` in joint_states is: ``commanded`` (held over the next sample; default for msd)
    or ``measured`` (the actuator's report; default for ros2_control)."""

    def resolve(self) -> PlantInterface:
        """The complete description, its face's defaults filled in (one-line InterfaceError if not)."""
        return face_class(self.interface).resolve(self)


def _text(value: str | tuple[str, ...], listed: str) -> str:
    """An option's value as text: a string as it is, a list of names comma-joined into ``listed``."""
    return value if isinstance(value, str) else listed.format(",".join(value))


@dataclass(frozen=True)
class JointSample:
    """Our joint's entry in one JointState; NaN where the message carries no value."""

    position: float
    velocity: float
    effort: float


@dataclass(frozen=True)
class PlantInterface(ABC):
    """One face of a plant-like node, complete: what every part that talks to a plant asks of it.

    A face is a subclass (:class:`MsdFace`, :class:`Ros2ControlFace`) registered in :data:`FACES`;
    build one with :class:`InterfaceParams` or :func:`make`. What differs between faces — the
    command topic and how a command is built and read, whether ``position`` and ``reset`` exist,
    which joints the state carries, which options travel with it — is answered by the subclass,
    so no caller branches on which face it holds.
    """

    kind: str = field(init=False)
    """The face's registry name (:attr:`NAME`), set by the face: a field so that a configuration holding
    a face stores which one (``run.json``); never branch on it, ask the face."""
    joint: str
    """Our joint's name in joint_states."""
    controller: str = ""
    """ros2_control: the forward effort controller's name ("" for msd)."""
    controller_joints: tuple[str, ...] = field(default=())
    """ros2_control: order of the command vector (our joint among them); () for msd."""
    effort: str = COMMANDED
    """``commanded`` or ``measured`` (see :data:`EFFORT_KINDS`)."""

    NAME: ClassVar[str] = ""
    """The face's registry name (``msd``, ``ros2_control``)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", self.NAME)
        if self.effort not in EFFORT_KINDS:
            raise InterfaceError(f"effort must be one of {', '.join(EFFORT_KINDS)}, got {self.effort!r}")
        for name in (self.joint, *self.controller_joints):
            if not _JOINT.fullmatch(name):
                raise InterfaceError(f"joint name {name!r} is empty or holds a space, comma, bracket "
                                     "or quote")
        self._check()

    # --- what each face says for itself -----------------------------------------------------

    @classmethod
    @abstractmethod
    def resolve(cls, params: InterfaceParams) -> PlantInterface:
        """This face from loose parameters, its defaults filled in."""

    @abstractmethod
    def _check(self) -> None:
        """Face-specific consistency (one-line InterfaceError)."""

    @property
    @abstractmethod
    def command(self) -> TopicSpec:
        """The command topic."""

    @property
    @abstractmethod
    def position(self) -> TopicSpec | None:
        """The ``position`` topic, or None on a face without it."""

    @property
    @abstractmethod
    def reset(self) -> TopicSpec | None:
        """The ``reset`` topic, or None on a face without it."""

    @property
    @abstractmethod
    def contract_rows(self) -> bool:
        """True when the state topic holds the contract's own rows (one joint, effort the held command),
        which the plain bag reader reads as they are."""

    @abstractmethod
    def command_values(self, u: float) -> list[float]:
        """The command's payload for force ``u`` on our joint (other joints get 0.0: the bench drives
        one joint and must not push the others)."""

    @abstractmethod
    def command_data(self, u: float) -> float | list[float]:
        """The ``data`` field of the command message for force ``u`` (a scalar or one value per joint)."""

    @abstractmethod
    def command_force(self, values: Sequence[float]) -> float | None:
        """Our joint's force in a command payload; None when the plant would ignore it."""

    @abstractmethod
    def report_note(self) -> str | None:
        """What a reader of a run's Table 1 must know about this face (None for our own contract)."""

    @abstractmethod
    def state_names(self, extra: Sequence[str]) -> list[str]:
        """The joint names a node showing this face publishes in joint_states, ``extra`` joints (a larger
        robot's, at rest) before ours where the face carries several."""

    @abstractmethod
    def _unnamed_is_ours(self, names: Sequence[str]) -> bool:
        """Whether a state whose names lack our joint still carries it (in slot 0)."""

    @abstractmethod
    def _extra_args(self) -> list[tuple[str, str | tuple[str, ...]]]:
        """The face's own options beyond interface, joint and effort: (name, value) pairs."""

    # --- shared by every face ---------------------------------------------------------------

    @property
    def state(self) -> TopicSpec:
        """The joint-state topic (``joint_states`` on both faces)."""
        return JOINT_STATES

    @property
    def effort_is_commanded(self) -> bool:
        """True when the state's effort is the held command, i.e. an identification input as is."""
        return self.effort == COMMANDED

    @property
    def joint_index(self) -> int:
        """Our joint's slot in the command vector (0 for a scalar command)."""
        return self.controller_joints.index(self.joint) if self.controller_joints else 0

    def pick(self, names: Sequence[str], position: Sequence[float], velocity: Sequence[float],
             effort: Sequence[float]) -> JointSample:
        """Our joint's position, velocity and effort in one JointState's arrays.

        Picked by name (a face may take an unnamed single joint as ours: the msd face, for
        rigs recorded before joint names mattered). Missing velocity or effort arrays (allowed by
        JointState) give NaN; a missing position is an error.
        """
        names = list(names)
        if self.joint in names:
            idx = names.index(self.joint)
        elif self._unnamed_is_ours(names):
            idx = 0
        else:
            raise InterfaceError(f"joint {self.joint!r} is not in joint_states (has {names or 'no names'})")
        if len(position) <= idx:
            raise InterfaceError(f"joint_states carries no position for joint {self.joint!r}")

        def entry(values: Sequence[float]) -> float:
            return float(values[idx]) if len(values) > idx else math.nan

        return JointSample(float(position[idx]), entry(velocity), entry(effort))

    def params(self) -> InterfaceParams:
        """The same description as ROS parameters (explicit values, no defaults left)."""
        return InterfaceParams(self.kind, self.controller, self.joint, self.controller_joints, self.effort)

    def _options(self) -> list[tuple[str, str | tuple[str, ...]]]:
        return [("interface", self.kind), ("joint", self.joint), ("effort", self.effort), *self._extra_args()]

    def ros_args(self) -> list[str]:
        """``-p`` arguments that make a node's :func:`declare_interface` build this description."""
        return [a for name, value in self._options() for a in ("-p", f"{name}:={_text(value, '[{}]')}")]

    def cli_args(self) -> list[str]:
        """Command-line options that rebuild this description (:func:`from_cli`)."""
        return [a for name, value in self._options()
                for a in (f"--{name.replace('_', '-')}", _text(value, "{}"))]

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready description (stored with bags and identification results)."""
        return {"interface": self.kind, "joint": self.joint, "controller": self.controller,
                "controller_joints": list(self.controller_joints), "effort": self.effort,
                "command_topic": self.command.name, "command_type": self.command.ros_type}

    def describe(self, namespace: str) -> str:
        """One line naming the face and its topics under ``namespace``."""
        topics = f"commands {self.command.resolve(namespace)}, state {self.state.resolve(namespace)}"
        return f"interface {self.kind} ({topics}; joint {self.joint}, effort {self.effort})"


@dataclass(frozen=True)
class MsdFace(PlantInterface):
    """The project's own contract: ``force`` (``Float64``), one joint, ``position`` and ``reset``."""

    NAME: ClassVar[str] = MSD

    @classmethod
    def resolve(cls, params: InterfaceParams) -> PlantInterface:
        if params.controller or params.controller_joints:
            raise InterfaceError("controller and controller_joints are ros2_control options; "
                                 "give --interface ros2_control too")
        return cls(joint=params.joint or JOINT_NAME, effort=params.effort or COMMANDED)

    def _check(self) -> None:
        if self.controller or self.controller_joints:
            raise InterfaceError("the msd interface has no controller; use --interface ros2_control")

    @property
    def command(self) -> TopicSpec:
        return FORCE

    @property
    def position(self) -> TopicSpec | None:
        return POSITION

    @property
    def reset(self) -> TopicSpec | None:
        return RESET

    @property
    def contract_rows(self) -> bool:
        return self.effort_is_commanded

    def command_values(self, u: float) -> list[float]:
        return [float(u)]

    def command_data(self, u: float) -> float | list[float]:
        return float(u)

    def command_force(self, values: Sequence[float]) -> float | None:
        return float(values[0]) if len(values) == 1 else None

    def report_note(self) -> str | None:
        return None

    def state_names(self, extra: Sequence[str]) -> list[str]:
        return [JOINT_NAME]  # the contract's one joint; extra joints are a broadcaster's

    def _unnamed_is_ours(self, names: Sequence[str]) -> bool:
        return len(names) <= 1

    def _extra_args(self) -> list[tuple[str, str | tuple[str, ...]]]:
        return []


@dataclass(frozen=True)
class Ros2ControlFace(PlantInterface):
    """A forward effort controller and a joint state broadcaster: ``<controller>/commands``
    (``Float64MultiArray``, one value per controller joint), several joints, no ``position``, no
    ``reset`` (ros2_control cannot teleport)."""

    NAME: ClassVar[str] = ROS2_CONTROL

    @classmethod
    def resolve(cls, params: InterfaceParams) -> PlantInterface:
        joint = params.joint or DEFAULT_ROS2_CONTROL_JOINT
        return cls(joint=joint, controller=params.controller or DEFAULT_CONTROLLER,
                   controller_joints=tuple(params.controller_joints) or (joint,),
                   effort=params.effort or MEASURED)

    def _check(self) -> None:
        if not _NAME.fullmatch(self.controller):
            raise InterfaceError(f"controller {self.controller!r} is not a relative ROS name "
                                 "(letters, digits, _ and /, e.g. effort_controller)")
        if len(set(self.controller_joints)) != len(self.controller_joints):
            raise InterfaceError(f"controller joints {list(self.controller_joints)} name a joint twice")
        if self.joint not in self.controller_joints:
            raise InterfaceError(f"joint {self.joint!r} is not among the controller joints "
                                 f"{list(self.controller_joints)}")

    @property
    def command(self) -> TopicSpec:
        return TopicSpec(f"{self.controller}/commands", COMMANDS_TYPE, FORCE.depth,
                         f"effort commands of {self.controller}, N, one per joint in "
                         f"{list(self.controller_joints)} order")

    @property
    def position(self) -> TopicSpec | None:
        return None

    @property
    def reset(self) -> TopicSpec | None:
        return None

    @property
    def contract_rows(self) -> bool:
        return False  # several joints in any order: picked by name, never read as the contract's rows

    def command_values(self, u: float) -> list[float]:
        values = [0.0] * len(self.controller_joints)
        values[self.joint_index] = float(u)
        return values

    def command_data(self, u: float) -> float | list[float]:
        return self.command_values(u)

    def command_force(self, values: Sequence[float]) -> float | None:
        """A forward command controller drops a command whose length differs from its joint count
        (it logs an error and keeps the last one), so such a command changes nothing the rig applies."""
        if len(values) != len(self.controller_joints):
            return None
        return float(values[self.joint_index])

    def report_note(self) -> str | None:
        return (f"Through the {self.kind} face: commands on `{self.command.name}` for joint `{self.joint}`, "
                f"effort {self.effort} (docs/ros2-control.md).")

    def state_names(self, extra: Sequence[str]) -> list[str]:
        return [*extra, self.joint]

    def _unnamed_is_ours(self, names: Sequence[str]) -> bool:
        return False

    def _extra_args(self) -> list[tuple[str, str | tuple[str, ...]]]:
        return [("controller", self.controller), ("controller_joints", self.controller_joints)]


FACES: dict[str, type[PlantInterface]] = {face.NAME: face for face in (MsdFace, Ros2ControlFace)}
"""Every face by name: the one registry a new face is added to (a subclass and one entry here)."""
INTERFACE_KINDS = tuple(FACES)
"""The faces' names, in the order the options list them."""


def face_class(name: str) -> type[PlantInterface]:
    """The face called ``name``; an unknown one is one InterfaceError line naming the choices."""
    try:
        return FACES[name]
    except KeyError:
        raise InterfaceError(f"interface must be one of {', '.join(FACES)}, got {name!r}") from None


MSD_INTERFACE: PlantInterface = MsdFace(JOINT_NAME)
"""Today's contract: the default of every node and command."""


def make(interface: str = MSD, *, controller: str = "", joint: str = "",
         controller_joints: Sequence[str] = (), effort: str = "") -> PlantInterface:
    """The interface from loose values, defaults filled in (the CLI's and the tests' way in)."""
    return InterfaceParams(interface, controller, joint, tuple(controller_joints), effort).resolve()


def add_cli_options(parser: argparse.ArgumentParser) -> None:
    """Add ``--interface``, ``--controller``, ``--joint``, ``--controller-joints``, ``--effort``."""
    group = parser.add_argument_group("plant interface (docs/ros2-control.md)")
    group.add_argument("--interface", default=MSD, help="face of the plant: msd (default) or ros2_control")
    group.add_argument("--controller", default="",
                       help=f"ros2_control: forward effort controller (default {DEFAULT_CONTROLLER})")
    group.add_argument("--joint", default="",
                       help=f"our joint in joint_states (default {JOINT_NAME}, "
                            f"or {DEFAULT_ROS2_CONTROL_JOINT} for ros2_control)")
    group.add_argument("--controller-joints", default="", metavar="A,B",
                       help="ros2_control: the controller's joints in order (default: just --joint)")
    group.add_argument("--effort", default="", choices=("", *EFFORT_KINDS),
                       help="joint_states effort is the commanded force (msd default) "
                            "or the measured one (ros2_control default)")


def from_cli(args: argparse.Namespace) -> PlantInterface:
    """The interface from options added by :func:`add_cli_options`."""
    given = str(args.controller_joints)
    joints = tuple(j.strip() for j in given.split(",")) if given else ()
    if any(not j for j in joints):
        raise InterfaceError(f"--controller-joints {args.controller_joints!r} has an empty name")
    return make(args.interface, controller=args.controller, joint=args.joint,
                controller_joints=joints, effort=args.effort)
