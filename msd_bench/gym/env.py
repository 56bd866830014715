"""``MsdBench-v0``: the paper's set-point task as a Gymnasium environment.

Task (paper §4): from rest at the origin, bring the mass to a set-point and
hold it there; one step is one 10 ms sample, an episode is 3,000 steps (30 s)
and ends by truncation only (a time limit, never a terminal state).

Actions. By default ``Discrete(5)``: the paper's forces {-F, -F/2, 0, F/2, F}
(index 2 is 0 N; F = 10 N). With ``continuous=True`` a ``Box([-F], [F])``
force in N; a value outside it is clipped to ±F (the plant saturates there
anyway), a non-finite one is a one-line :class:`InvalidInputError`.

Observation, what an agent on the bench may know, as float64
``[y_k, y_k - y_{k-1}, target, u_{k-1}]``: the measured position (m; through
the optional sensor model, so noisy and quantised if asked), its last
difference (m per sample; 0 on the first step), the set-point (m) and the
last force applied (N). Never the true velocity: a rig has no velocity
sensor. The position is clipped to the stroke widened by ten noise standard
deviations and one quantisation step (as an ADC's range clips), so the
observation always lies in its space.

Reward: the paper's eq. 19 exactly as the learners compute it,
``A · (g / (1 + E_{k+1}) − ζ (E_{k+1} − E_k) / E_max)`` with ``E = |x − target|``
the *true* error (the learners score the truth too: sensor noise perturbs
what the agent sees, not what it is paid), computed by the compiled
:func:`msd_bench.core.learning.q_kernels.reward` of the config's packed learner.
The shaping penalty η φ(s, a) is not part of it: φ is defined on the
Q-table's state bins, which an environment does not have.

Set-point: drawn per episode uniformly in the config's
[target_low, target_high] (±2 m, as the paper's training) from the
environment's seeded generator, unless ``target`` is fixed or
``reset(options={"target": t})`` sets it for one episode.

Backends (:mod:`msd_bench.gym.backends`): the emulated NL-MSD in-process
(default, ``preset`` names its parameter set), any model artifact
(``model="models/plm.json"`` or a :class:`StepModel`), or a plant-like node
over ROS 2 (``ros_namespace="/msd"``): lock-step by default, real time with
``ros_lockstep=False`` (then an episode starts wherever the node came to rest,
see :mod:`msd_bench.gym.ros_backend`). ``ros_interface`` (a
:class:`msd_msgs_py.interface.PlantInterface`) drives a node with the
ros2_control face (real time only; docs/ros2-control.md §Face).
"""

from __future__ import annotations

import math
import os
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError, InvalidInputError, MsdBenchError
from msd_bench.core.learning.qconfig import QConfig, packed
from msd_bench.core.physics.model import StepModel
from msd_bench.core.physics.sensor import SensorModel
from msd_bench.gym.backends import Backend, model_backend
from msd_msgs_py.interface import MSD_INTERFACE, PlantInterface

FloatArray = NDArray[np.float64]

EPISODE_STEPS = QConfig().steps
"""Paper episode length: 3,000 samples of 10 ms."""


class MsdBenchEnv(gymnasium.Env[FloatArray, Any]):
    """The paper's set-point task on the plant, a surrogate, or a ROS plant-like node."""

    metadata: dict[str, Any] = {"render_modes": []}  # noqa: RUF012 (gymnasium's class attribute)

    def __init__(
        self,
        model: str | os.PathLike[str] | StepModel | None = None,
        *,
        preset: str = "default",
        ros_namespace: str | None = None,
        continuous: bool = False,
        episode_steps: int = EPISODE_STEPS,
        target: float | None = None,
        sensor_noise: float = 0.0,
        sensor_quant: float = 0.0,
        qconfig: QConfig | None = None,
        ros_timeout: float = 5.0,
        ros_lockstep: bool = True,
        ros_interface: PlantInterface = MSD_INTERFACE,
        render_mode: str | None = None,
    ) -> None:
        """See the module docstring; every argument is checked here, with a one-line error."""
        if render_mode is not None:
            raise ConfigError(f"MsdBench-v0 has no render modes, got render_mode={render_mode!r}")
        if model is not None and ros_namespace is not None:
            raise ConfigError("give either model= (in-process) or ros_namespace= (ROS), not both")
        if not (isinstance(episode_steps, int) and episode_steps >= 1):
            raise ConfigError(f"episode_steps must be an int >= 1, got {episode_steps!r}")
        self.cfg = qconfig or QConfig()
        self.sensor = SensorModel(sensor_noise, sensor_quant)
        self.episode_steps = episode_steps
        self._learner = packed(self.cfg)
        self.backend: Backend = self._backend(model, preset, ros_namespace, ros_timeout, ros_lockstep,
                                              ros_interface)
        self.dt = self.backend.dt
        try:
            self._fixed_target = None if target is None else self._check_target(target, "target")
            self._check_target(self.cfg.target_low, "qconfig.target_low")
            self._check_target(self.cfg.target_high, "qconfig.target_high")
        except ConfigError:
            self.backend.close()  # a ROS backend holds a context and a node: never leak them
            raise
        self.forces = self.cfg.actions()
        f = self.cfg.force
        self.action_space: spaces.Space[Any] = (
            spaces.Box(-f, f, shape=(1,), dtype=np.float64) if continuous else spaces.Discrete(5))
        self.continuous = continuous
        self._y_bound = self.backend.x_max + 10.0 * self.sensor.noise_std + self.sensor.quant
        xm = self.backend.x_max
        self.observation_space = spaces.Box(
            low=np.array([-self._y_bound, -2 * self._y_bound, -xm, -f]),
            high=np.array([self._y_bound, 2 * self._y_bound, xm, f]), dtype=np.float64)
        self._k = 0
        self._x = 0.0
        self._y = 0.0
        self._dy = 0.0
        self._u = 0.0
        self._target = 0.0

    def _backend(self, model: str | os.PathLike[str] | StepModel | None, preset: str,
                 ros_namespace: str | None, ros_timeout: float, ros_lockstep: bool,
                 ros_interface: PlantInterface = MSD_INTERFACE) -> Backend:
        if ros_namespace is None:
            return model_backend(model, preset)
        from msd_bench.core.physics.plant import preset as plant_preset
        from msd_bench.gym.ros_backend import RosBackend  # rclpy only when asked for

        params = plant_preset(preset)
        # Discovery takes longer than one lock-step answer: allow it three answer timeouts.
        return RosBackend(ros_namespace, timeout_s=ros_timeout, match_timeout_s=3.0 * ros_timeout,
                          dt=params.dt, x_max=0.5 * params.L, lockstep=ros_lockstep, interface=ros_interface)

    def _check_target(self, t: float, what: str) -> float:
        xm = self.backend.x_max
        if not (isinstance(t, int | float) and math.isfinite(t) and abs(t) <= xm):
            raise ConfigError(f"{what} must be a finite set-point within the stroke ±{xm:g} m, got {t!r}")
        return float(t)

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[FloatArray, dict[str, Any]]:
        """Start an episode at rest; ``options={"target": t}`` fixes this episode's set-point."""
        super().reset(seed=seed)
        if options and "target" in options:
            self._target = self._check_target(options["target"], "options['target']")
        elif self._fixed_target is not None:
            self._target = self._fixed_target
        else:
            self._target = float(self.np_random.uniform(self.cfg.target_low, self.cfg.target_high))
        self._x = self.backend.reset()
        self._y = self._measure(self._x)
        self._dy, self._u, self._k = 0.0, 0.0, 0
        return self._observation(), self._info()

    def step(self, action: Any) -> tuple[FloatArray, float, bool, bool, dict[str, Any]]:
        """Apply one force for one sample; reward eq. 19; truncated after ``episode_steps``."""
        if self._k >= self.episode_steps:
            raise MsdBenchError(f"the episode ended after {self.episode_steps} steps: call reset()")
        u = self._force(action)
        err_prev = abs(self._x - self._target)
        self._x = self.backend.step(u)
        y = self._measure(self._x)
        self._dy, self._y, self._u = y - self._y, y, u
        self._k += 1
        err = abs(self._x - self._target)
        r = self.cfg.reward_gain * float(_reward(self._learner, err, err_prev))
        return self._observation(), r, False, self._k >= self.episode_steps, self._info()

    def _force(self, action: Any) -> float:
        """The force of an action: the alphabet entry, or the clipped continuous value."""
        if self.continuous:
            try:
                a = np.asarray(action, dtype=np.float64).reshape(-1)
            except (TypeError, ValueError):
                a = np.full(2, np.nan)  # not a number at all: the same one-line error below
            if a.size != 1 or not math.isfinite(float(a[0])):
                raise InvalidInputError(f"continuous action must be one finite force in N, got {action!r}")
            return float(np.clip(a[0], -self.cfg.force, self.cfg.force))
        # Whatever Gymnasium's Discrete accepts is an action: a Python int, a NumPy integer scalar,
        # or the 0-d integer array Stable-Baselines3's predict() returns for one observation.
        if not self.action_space.contains(action):
            raise InvalidInputError(f"discrete action must be an integer in 0..{self.forces.size - 1}, "
                                    f"got {action!r}")
        return float(self.forces[int(action)])

    def _measure(self, x: float) -> float:
        if self.sensor.is_ideal:
            return float(np.clip(x, -self._y_bound, self._y_bound))
        y = self.sensor.measure_one(x, self.np_random)
        return float(np.clip(y, -self._y_bound, self._y_bound))

    def _observation(self) -> FloatArray:
        return np.array([self._y, self._dy, self._target, self._u], dtype=np.float64)

    def _info(self) -> dict[str, Any]:
        """Facts a user may log but the agent should not see (the true position above all)."""
        return {"x": self._x, "target": self._target, "force": self._u, "step": self._k}

    def close(self) -> None:
        """Release the backend (the ROS backend's node and context); safe to call twice."""
        self.backend.close()
        super().close()


def _reward(learner: Any, err: float, err_prev: float) -> float:
    """Eq. 19 from the compiled learner's own definition (imported here: numba loads on first use)."""
    from msd_bench.core.learning.q_kernels import reward

    return float(reward(learner, err, err_prev))
