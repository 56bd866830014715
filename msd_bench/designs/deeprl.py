"""Deep RL as designs: ``dqn`` and ``ppo`` (Stable-Baselines3 through ``MsdBench-v0``), opt-in kinds.

``<surrogate>+dqn`` trains on the identified surrogate (model-based: zero real
samples, ``episodes x steps`` environment steps per seed); ``plant+dqn`` on
the plant (model-free: every environment step a real sample, charged in its
facts), at the plant budget ``plant_episodes x steps`` per seed as Dyna-Q: in
``msd-bench paper`` on the plant's own model, in bench.py over the plant
node's topics (:meth:`DeepDesign.stepwise`), the steps the node saw being the
steps charged. Both budgets are the paper's 900,000 by default; the hyper-parameters are the ones chosen
on design seeds (:data:`msd_bench.core.deeprl.hyper.CHOSEN`, docs/deeprl.md
§Hyper-parameters). Training, the compiled rollout and the stepwise
controller live in :mod:`msd_bench.core.deeprl`; the weights are
:mod:`msd_bench.io.storage.deeprl_artifact`'s ``deeprl.json`` + ``deeprl.npz`` beside
``policy.json``. Listed as baselines: reported beside the learners, never in
the default matrix. SB3 and torch load only when a policy is trained.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.deeprl.hyper import PAPER_STEPS
from msd_bench.core.errors import ConfigError
from msd_bench.designs.protocol import Controller, Facts, KindSpec, PolicyBase, Request, Settings
from msd_bench.designs.registry import PLANT, plus_kinds

if TYPE_CHECKING:
    from msd_bench.core.deeprl.mlp import Net
    from msd_bench.core.evaluation.closed_loop import Conditions
    from msd_bench.core.physics.kernels import Kernel
    from msd_bench.core.physics.model import StepModel
    from msd_bench.designs.deeprl_stepwise import DeepStepwise
    from msd_bench.designs.deeprl_train import TrainResult

FloatArray = NDArray[np.float64]
STEM = "deeprl"
"""The weights artifact's stem inside a policy directory."""


@dataclass(frozen=True)
class DeepPolicy(PolicyBase):
    """One greedy network per learning seed; member j runs on rollout row j."""

    net: Net
    meta: dict[str, Any] = field(compare=False)
    """Algorithm, hyper-parameters, budget, SB3 and torch versions (the artifact's provenance)."""

    def _forces(self) -> FloatArray:
        from msd_bench.core.learning.qconfig import QConfig

        return QConfig().actions()

    def rollout(self, plant: Kernel, cond: Conditions, noise: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The compiled batch rollout; no ADC clip (the stepwise controller has none either: a rig's
        converter clips its own readings, and the environment's clip lies ten noise deviations out)."""
        from msd_bench.core.deeprl.rollout import greedy_under

        if noise.shape[0] != len(self.members):
            raise ConfigError(f"{self.kind}: {len(self.members)} members need as many noise rows, "
                              f"got {noise.shape[0]}")
        xs, us = greedy_under(plant, self.net, self._forces(), cond, noise, np.inf)
        return xs, us

    def controller(self, member: int, target: float) -> Controller:
        from msd_bench.core.deeprl.rollout import NetworkController

        return NetworkController(self.net, self._forces(), member, target)

    def save(self, directory: Path, provenance: dict[str, Any], root: Path, overwrite: bool) -> list[Path]:
        from msd_bench.io.storage.deeprl_artifact import paths, save_policy

        meta_path, npz_path = paths(directory / STEM)
        if overwrite:  # a rerun into the same run directory replaces only our own two files
            for p in (meta_path, npz_path):
                if p.is_file() and not p.is_symlink():
                    p.unlink()
        save_policy(directory / STEM, self.net, {**self.meta, "kind": self.kind, "seeds": list(self.members)},
                    root=root)
        body = {"algo": self.meta.get("algo")}
        return [npz_path, meta_path,
                self.write_policy(directory, provenance, root, overwrite, {"weights": meta_path.name}, body)]


@dataclass(frozen=True)
class DeepDesign:
    """A registry entry over one SB3 algorithm: its surrogate kinds, or (``plant``) its on-plant kind.

    Why two entries per algorithm: whether a kind learns over the plant node is a
    fact of its design (``model_free``, as Dyna-Q's), and bench.py decides from it
    to start the kind on the plant before identification, with the plant budget
    and no model file. ``plant+dqn`` is made by ``plant-dqn``, ``greybox+dqn`` by ``dqn``.
    """

    name: str
    summary: str
    label: str
    algo: str
    """The SB3 algorithm (``dqn``, ``ppo``)."""
    plant: bool = False
    """Its one kind learns on the true plant (``plant+<algo>``), every step a real sample."""
    baseline: bool = True
    deterministic: bool = False

    @property
    def model_free(self) -> bool:
        """The on-plant entry learns by its own steps on the plant's topics (bench.py: the plant node)."""
        return self.plant

    def kinds(self, surfaces: Sequence[tuple[str, str]]) -> list[KindSpec]:
        if self.plant:
            return [KindSpec(f"{PLANT}+{self.algo}", f"on the true plant ({self.label})", PLANT)]
        return [KindSpec(s.kind, s.label, s.surrogate)
                for s in plus_kinds(self.algo, self.label, False, surfaces)]

    def budget(self, s: Settings) -> int:
        """Environment steps per seed: on the plant the plant budget (``--dyna-episodes`` x ``--steps``,
        real samples, as Dyna-Q's), on a surrogate ``--episodes`` x ``--steps``."""
        return (s.plant_episodes if self.plant else s.episodes) * s.steps

    def budget_note(self, s: Settings) -> str:
        if self.plant:
            return (f"{self.algo}: {self.budget(s):,} real steps per seed on the plant (in bench.py steps of "
                    f"the plant node; the paper's budget is {PAPER_STEPS:,})")
        return f"{self.algo}: {self.budget(s):,} environment steps per seed"

    def _policy(self, req: Request, results: Sequence[TrainResult], real: int) -> DeepPolicy:
        from msd_bench.core.deeprl import mlp

        r0 = results[0]
        meta = {"algo": self.algo, "hyper": r0.hyper.as_dict(), "steps": self.budget(req.settings),
                "stable_baselines3": r0.sb3_version, "torch": r0.torch_version}
        return DeepPolicy(req.spec.kind, req.seeds, Facts(self.name, True, False, int(real)),
                          mlp.stack([r.net for r in results]), meta)

    def make(self, req: Request) -> DeepPolicy:
        from msd_bench.core.deeprl.hyper import CHOSEN
        from msd_bench.designs.deeprl_train import train

        if req.model is None:
            raise ConfigError(f"{req.spec.kind}: deep RL trains in-process on a model (or the plant's own)")
        st = req.settings
        results = [train(req.model, CHOSEN[self.algo], s, self.budget(st), st.steps) for s in req.seeds]
        return self._policy(req, results, sum(r.steps for r in results) if self.plant else 0)

    def stepwise(self, req: Request) -> DeepStepwise | None:
        """On the plant: one SB3 learner per seed over the plant node's topics, ``plant_episodes``
        episodes of ``steps`` each (the stated budget), every step charged. Else None (in-process)."""
        if not self.plant:
            return None
        from msd_bench.core.deeprl.hyper import CHOSEN
        from msd_bench.core.physics.plant import PlantParams
        from msd_bench.designs.deeprl_stepwise import DeepLearner, DeepStepwise

        s = req.settings
        x_max = 0.5 * PlantParams().L  # the observation bounds of MsdBench-v0 on the plant, as in-process
        learners = [DeepLearner(CHOSEN[self.algo], seed, self.budget(s), s.dt, x_max, s.steps)
                    for seed in req.seeds]
        return DeepStepwise(True, s.plant_episodes, s.steps, learners,
                            lambda results, real: self._policy(req, results, real))

    def load(self, doc: dict[str, Any], directory: Path, model: StepModel | None) -> DeepPolicy:
        """The networks back from ``deeprl.json``/``.npz``; members and kind must agree with them."""
        from msd_bench.io.storage import artifacts
        from msd_bench.io.storage.deeprl_artifact import load_policy

        name = artifacts.policy_file(doc, "weights", directory)
        if name != f"{STEM}.json":
            raise artifacts.ArtifactError(f"{directory}: policy weights must be {STEM}.json, "
                                          f"got {name[:60]!r}")
        net, meta = load_policy(directory / STEM)
        members = artifacts.policy_members(doc, directory)
        if list(members) != meta.get("seeds") or meta.get("kind") != doc["kind"]:
            raise artifacts.ArtifactError(f"{directory}: {STEM}.json is not the weights of this policy "
                                          "(kind or members differ)")
        facts = Facts(self.name, True, False, artifacts.policy_real(doc, directory))
        return DeepPolicy(str(doc["kind"]), members, facts, net, meta)


_DQN = "DQN (Stable-Baselines3) through MsdBench-v0; the greedy Q-network over the 5 forces"
_PPO = "PPO (Stable-Baselines3) through MsdBench-v0; the greedy actor over the 5 forces"
DESIGNS = (
    DeepDesign("dqn", _DQN, "DQN baseline", "dqn"),
    DeepDesign("ppo", _PPO, "PPO baseline", "ppo"),
    DeepDesign("plant-dqn", _DQN + ", trained on the plant", "DQN baseline", "dqn", plant=True),
    DeepDesign("plant-ppo", _PPO + ", trained on the plant", "PPO baseline", "ppo", plant=True),
)
"""The deep-RL entries of the registry."""


def nets_policy(kind: str, net: Net, seeds: Sequence[int], real_interactions: int = 0) -> DeepPolicy:
    """Trained networks (one per learning seed, stacked) as a policy of ``kind`` (``plant+dqn``, ...).

    Why: scripts/deeprl_runs.py trains networks itself (its grid and budgets) and then scores them
    through :func:`msd_bench.core.evaluation.robustness.evaluate_policy`, the one evaluator, as every
    kind is; the rollout is the policy's (no ADC clip: see :meth:`DeepPolicy.rollout`).
    """
    from msd_bench.core.errors import InvalidInputError
    from msd_bench.designs.registry import agent_kind

    design = agent_kind(kind).design
    if not isinstance(design, DeepDesign):
        raise ConfigError(f"{kind} is not a deep-RL kind")
    if len(seeds) != net.w1.shape[0]:
        raise InvalidInputError(f"need one learning seed per policy, got {len(seeds)} for {net.w1.shape[0]}")
    facts = Facts(design.name, True, False, int(real_interactions))
    return DeepPolicy(kind, tuple(int(s) for s in seeds), facts, net, {"algo": design.algo})
