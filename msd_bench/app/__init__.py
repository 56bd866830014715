"""The application layer: what a run *is*, defined once.

``msd-bench paper`` (in-process), bench.py's stages (node processes) and the
agent node all call this package: the run configuration (:mod:`.config`), the
agent kinds and the learner each one gets (:mod:`.agents`), the experiment plan
(:mod:`.plan`), scoring and Table-1 rows (:mod:`.scoring`), the in-process run
(:mod:`.pipeline`) and its output (:mod:`.output`). It sits above ``core`` and
``io`` and below ``nodes`` and ``graph``; it never imports rclpy.
"""
