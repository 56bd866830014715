"""What a run on a rig is scored by, and what a rig can be given: shared by every row of ``msd-bench rigs``.

Why a module: the open-loop rows (``app/rigs.py``) and the refined ones
(``app/rig_refine.py``) score and parse alike, and neither may import the other.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from msd_bench.app.scoring import metric_row
from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation.results import SUCCESS_SSE
from msd_bench.core.evaluation.scenarios import Scenario, parse
from msd_bench.core.rigs.hold import BARE, Operation

if TYPE_CHECKING:
    import numpy as np

    from msd_bench.app.config import RunConfig
    from msd_bench.core.physics.plant import PlantParams
    from msd_bench.core.rigs.rest import RestConfig
    from msd_bench.core.rigs.rig import Rig
    from msd_bench.core.rigs.rig_loop import RigRun
    from msd_bench.core.rigs.scales import Scales
    from msd_bench.core.safety.supervisor import Limits
    from msd_bench.designs import Policy, Settings

RIG_KEYS = ("setpoint", "disturbance")
"""What a rig scenario may set."""


def rig_scenario(sid: str) -> Scenario:
    """A scenario a rig can be given: a set-point and/or a load, nothing the rig has of its own."""
    sc = parse(sid)
    keys = {item.partition("=")[0].strip() for item in sid.split(",")}
    if sc.id == "nominal" or not keys <= set(RIG_KEYS):
        raise ConfigError(f"rig scenario {sid!r}: only {' and '.join(RIG_KEYS)} can be given to a rig "
                          "(its noise, delay, friction and parameters are its own)")
    return sc



def rig_settings(run: RunConfig, params: PlantParams, scales: Scales, every: int = 1) -> Settings:
    """What a design takes from a run on a rig: the run's budgets (in the rig's scales already), the
    rig's sample time, force limit and stroke, its time unit and its samples per decision (``every``);
    on the default family's rigs exactly what :func:`msd_bench.app.job.agent_params` gives (same dt,
    F and stroke)."""
    from dataclasses import replace

    from msd_bench.app.job import agent_params
    from msd_bench.designs.protocol import settings_from

    return replace(settings_from(agent_params(run)), dt=params.dt, force=params.F, stroke=params.L,
                   pace=scales.pace, decision_samples=every)


def rig_limits(run: RunConfig, scales: Scales) -> Limits | None:
    """The supervisor's limits on a rig when the run is supervised (else None): the default options in
    the rig's scales, resolved against the nominal plant in the rig's units (all a rig's supervisor is
    told: not the rig's drawn values)."""
    if not run.supervisor:
        return None
    from msd_bench.core.safety.supervisor import SupervisorOptions

    if scales.is_default:
        return run.supervisor_limits
    return SupervisorOptions().scaled(scales).limits(scales.plant(run.plant))


def paper_risk(risk: dict[str, Any], scales: Scales) -> dict[str, Any]:
    """A run's risk record in the paper's units (lengths / length, speeds / speed, times / pace), so the
    risk of rigs in other units pools with the default family's; itself on the paper's scales. Why:
    a family's peak |x| pooled in each rig's own metres would compare a 0.25 m stage with a 100 m
    runway."""
    if scales.is_default:
        return risk
    speed = scales.speed(1.0)
    return {**risk, "peak_x": risk["peak_x"] / scales.length, "peak_v": risk["peak_v"] / speed,
            "time_at_stop": risk["time_at_stop"] / scales.pace,
            "time_outside": risk["time_outside"] / scales.pace}


def run_member(rig: Rig, policy: Policy, member: int, sc: Scenario, steps: int, rng: np.random.Generator,
               limits: Limits | None, rest: RestConfig | None = None, op: Operation = BARE) -> RigRun:
    """One run of ``policy``'s member ``member`` on the rig under ``sc`` (a set-point and a load), from
    rest as ``rest`` judges it (None: the paper's plant's): a Q-table with its observer through the
    compiled greedy loop, any other policy through its controller, under the rig's operation ``op``
    (a stage's hold loop and decision period). Every row of ``msd-bench rigs`` runs through here,
    open loop or refined."""
    from msd_bench.core.rigs.rig_loop import run_controller_on_rig, run_on_rig
    from msd_bench.designs.qlearning import QPolicy

    load_step = round(sc.disturbance_time / rig.params.dt)
    if isinstance(policy, QPolicy) and policy.observer is not None:
        return run_on_rig(rig, policy.q[member], policy.learner, policy.observer, sc.setpoint, steps, rng,
                          load=sc.disturbance, load_step=load_step, rest_config=rest, limits=limits, op=op)
    return run_controller_on_rig(rig, policy.controller(member, sc.setpoint), sc.setpoint, steps, rng,
                                 load=sc.disturbance, load_step=load_step, rest_config=rest, limits=limits,
                                 op=op)


def scores(r: RigRun, target: float, run: RunConfig, brief: bool = False,
           dt: float | None = None) -> dict[str, Any]:
    """Metrics on the true position (success) and, beside them, on the measured one (times in the rig's
    sample time ``dt``; None: the run's plant's)."""
    dt = run.plant.dt if dt is None else dt
    true = metric_row(r.x, target, dt, run.window)
    seen = metric_row(r.y, target, dt, run.window)
    if brief:
        return {"sse": true["sse"], "success": bool(true["sse"] < SUCCESS_SSE), "sse_measured": seen["sse"]}
    return {"success": bool(true["sse"] < SUCCESS_SSE), **true,
            "sse_measured": seen["sse"], "success_measured": bool(seen["sse"] < SUCCESS_SSE),
            "rest_samples": r.rest.samples, "rest_still": r.rest.still}
