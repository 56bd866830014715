"""Deep RL through ``MsdBench-v0``: DQN and PPO (Stable-Baselines3) as controller designs.

Training (:mod:`.train`) is the only part that needs torch and SB3; what it
returns is plain numpy weights (:class:`.mlp.Net`), so the compiled batch
rollout (:mod:`.rollout`), the stepwise controller and the artifact
(:mod:`msd_bench.io.storage.deeprl_artifact`) load and run without either.
"""
