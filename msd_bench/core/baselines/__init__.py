"""Classical baselines designed from identified models: PID, LQR and finite-alphabet MPC.

The first question a control engineer asks of a learned controller is whether
it beats the PID they would have tuned on the identified model. Each design
here is pure science (no rclpy): a deterministic ``design`` from a
:class:`~msd_bench.core.physics.model.StepModel`, a compiled batch rollout with the
semantics of :func:`msd_bench.core.evaluation.closed_loop.greedy_under`, and a stepwise
controller for an agent node. :mod:`.designs` holds the table and the common
calls; docs/baselines.md says what each design is and what was chosen.
"""
