"""The PLM's operating points, apart from the code that identifies at them.

Why a module of its own: the experiment plan names them, and the plan is read
at the start of every ``bench.py`` run; importing them from :mod:`.plm`
pulled in SciPy's optimiser and python-control (1.7 s) before the first
node process could start.
"""

from __future__ import annotations

PLM_BIASES = (-10.0, -5.0, 0.0, 5.0, 10.0)
"""The paper's bias forces, N, in the order of the memberships f1..f5."""
