"""Every compiled kernel's parameter layout: its count rule and each slot's bounds.

Why a module of its own (out of :mod:`msd_bench.core.identification.model_kinds`, which re-exports
every name): :class:`msd_bench.core.physics.model.StepModel` checks each parameter vector
against its layout, and the registry's fitters build StepModels, so with the
layouts in the registry the model and the registry imported each other (a circle
through the fitters, docs/design.md §Layers). This module imports nothing of the
project but the errors, so it loads no numba either.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError

COEF_MAX = 1e9
"""Largest magnitude of any model coefficient: honest fits stay below 100 (tests/data/pinned,
docs/results); beyond 1e9 one double-precision step is rounding noise, so it is a broken file."""

STROKE_MAX = 1e6
"""Largest stroke L, m, a model may project on (every fit uses the rig's L, 5 m)."""

RIG_DELAY_MAX = 5
"""Longest input delay (samples) of a greybox-rig model (``kernels.RIG_DELAY_MAX``, restated here
so listing kinds does not load numba; a test pins the two equal)."""

RK4_SUBSTEPS_MAX = 64
"""Most RK4 substeps per sample of an rk4 model (``kernels.RK4_SUBSTEPS_MAX``, restated like
:data:`RIG_DELAY_MAX`)."""

NLARX_MAX_UNITS = 1024
"""Most sigmoid units an NLARX model may state (the fitter's default is 10): bounds the length
of the parameter vector the kernel walks."""


@dataclass(frozen=True)
class Slot:
    """One parameter of a kernel layout and the closed range it must lie in."""

    name: str
    """Its name in the layout (:mod:`msd_bench.core.physics.kernels` docstring)."""
    lo: float = -COEF_MAX
    """Lower bound."""
    hi: float = COEF_MAX
    """Upper bound (inclusive)."""
    positive: bool = False
    """The lower bound is excluded: the kernel divides by it or it is a physical size."""
    integer: bool = False
    """Must be a whole number (a count)."""

    def admits(self, value: float) -> bool:
        """Whether ``value`` is in range (NaN is in no range)."""
        above = value > self.lo if self.positive else value >= self.lo
        return bool(above and value <= self.hi and (not self.integer or float(value).is_integer()))

    def describe(self) -> str:
        """The range as the error message states it."""
        kind = "an integer " if self.integer else ""
        return f"{kind}in {'(' if self.positive else '['}{self.lo:g}, {self.hi:g}]"


def _pos(name: str, hi: float = COEF_MAX) -> Slot:
    return Slot(name, 0.0, hi, positive=True)


def _coefs(*names: str) -> tuple[Slot, ...]:
    return tuple(Slot(n) for n in names)


@dataclass(frozen=True)
class KernelLayout:
    """A compiled kernel's parameter vector: its layout, its count rule and the bounds of each slot.

    Why here and not in the kernel: the compiled code indexes the vector
    without checks (a short vector is read past its end, a huge unit count
    walks the heap). :class:`msd_bench.core.physics.model.StepModel` checks every
    vector against its layout before a kernel sees it, whoever built it.

    Count rule: ``head`` slots, then ``blocks`` repetitions of ``block`` (the
    count is fixed when ``blocks_slot`` is empty, else the value of that head
    slot, which must lie in ``blocks``), then optionally ``tail`` (all or none).
    """

    kernel: str
    """Kernel kind name (:data:`msd_bench.core.physics.kernels.KIND_NAMES`)."""
    head: tuple[Slot, ...]
    """Leading slots, always present."""
    block: tuple[Slot, ...] = ()
    """A repeated group (a PLM local model, an NLARX unit)."""
    blocks: tuple[int, int] = (0, 0)
    """Allowed number of repetitions of ``block``, inclusive."""
    blocks_slot: str = ""
    """Head slot that states the repetition count ("" : the count is ``blocks[0]``)."""
    tail: tuple[Slot, ...] = ()
    """Optional trailing slots, present all together or not at all."""
    tail_increasing: bool = False
    """The tail must be strictly increasing (the PLM's scheduling centres)."""

    @property
    def max_size(self) -> int:
        """Longest valid vector: anything longer is refused before it is looked at."""
        return len(self.head) + len(self.block) * self.blocks[1] + len(self.tail)

    def names(self) -> str:
        """The layout as a one-line string, for error messages."""
        parts = [s.name for s in self.head]
        if self.block:
            count = self.blocks_slot or str(self.blocks[0])
            parts.append(f"{count} x ({', '.join(s.name for s in self.block)})")
        if self.tail:
            parts.append(f"[{', '.join(s.name for s in self.tail)}]")
        return f"[{', '.join(parts)}]"

    def count_rule(self) -> str:
        """How many parameters the layout has, for error messages."""
        if self.blocks_slot:
            lo, hi = self.blocks
            return (f"{len(self.head)} + {len(self.block)} x {self.blocks_slot} "
                    f"({self.blocks_slot} in [{lo}, {hi}])")
        return " or ".join(map(str, self.sizes(self.blocks[0])))

    def sizes(self, n_blocks: int) -> tuple[int, ...]:
        """Valid lengths for ``n_blocks`` repetitions (with and without the optional tail)."""
        base = len(self.head) + len(self.block) * n_blocks
        return (base, base + len(self.tail)) if self.tail else (base,)


KERNEL_LAYOUTS: dict[str, KernelLayout] = {
    k.kernel: k
    for k in (
        KernelLayout("plant", (_pos("m"), _pos("c"), _pos("k"), _pos("g"), _pos("h"),
                               _pos("L", STROKE_MAX), _pos("F"), _pos("dt", 1e3))),
        KernelLayout("linear", (_pos("L", STROKE_MAX), *_coefs("n1", "n2", "d1", "d2", "u0", "y0"))),
        KernelLayout("plm", (_pos("L", STROKE_MAX),), _coefs("n1", "n2", "d1", "d2", "u0", "y0"),
                     blocks=(5, 5), tail=_coefs("c1", "c2", "c3", "c4", "c5"), tail_increasing=True),
        KernelLayout("nlarx", (_pos("L", STROKE_MAX), Slot("S", 1, NLARX_MAX_UNITS, integer=True),
                               _pos("x_scale"), _pos("u_scale"), *_coefs("c0", "w1", "w2", "w3", "w4")),
                     _coefs("alpha", "b1", "b2", "b3", "b4", "b0"), blocks=(1, NLARX_MAX_UNITS),
                     blocks_slot="S"),
        KernelLayout("greybox-rig", (_pos("m"), _pos("c"), _pos("k"), _pos("g"), _pos("h"),
                                     _pos("L", STROKE_MAX), _pos("F"), _pos("dt", 1e3),
                                     Slot("friction", 0.0, COEF_MAX), Slot("tau", 0.0, 1e3),
                                     Slot("delay", 0, RIG_DELAY_MAX, integer=True))),
        KernelLayout("rk4", (_pos("m"), *_coefs("c", "k1", "k2", "k3"), _pos("L", STROKE_MAX), _pos("F"),
                             _pos("dt", 1e3), Slot("ks"), Slot("gs", 0.0, COEF_MAX),
                             Slot("fc", 0.0, COEF_MAX), _pos("vc"), Slot("f0"),
                             Slot("substeps", 1, RK4_SUBSTEPS_MAX, integer=True),
                             Slot("interp", 0, 1, integer=True))),
    )
}
"""Every compiled kernel's parameter layout, count rule and bounds (plant: all physical
parameters positive, as :class:`msd_bench.core.physics.plant.PlantParams` requires; greybox-rig: the
plant's, then friction and lag >= 0 and a whole delay in [0, RIG_DELAY_MAX]; ARX kinds: a
positive stroke and coefficients within ±:data:`COEF_MAX`; PLM: five local models, optionally
five strictly increasing centres; rk4: a positive mass, stroke, F, dt and Coulomb smoothing
speed, a non-negative sine frequency and Coulomb friction, signed damping, springs and offset,
1 to :data:`RK4_SUBSTEPS_MAX` substeps and a 0/1 input interpolation flag; NLARX: 1 to
:data:`NLARX_MAX_UNITS` units, the count in slot S)."""

KERNELS = tuple(KERNEL_LAYOUTS)
"""Compiled kernel kinds by name (:data:`msd_bench.core.physics.kernels.KIND_NAMES`)."""


def check_params(kernel: str, params: NDArray[np.float64], label: str) -> None:
    """One-line InvalidInputError unless ``params`` fits the layout of ``kernel`` exactly.

    Checked in an order that never indexes past what was verified: the length
    against the layout's maximum first, then the head (which states the NLARX
    unit count), then the count rule, then every remaining slot.
    """
    layout = KERNEL_LAYOUTS[kernel]
    what = f"model {label!r} ({kernel})"
    n = len(params)
    if not len(layout.head) <= n <= layout.max_size:
        raise InvalidInputError(f"{what}: got {n} parameter value(s); its layout {layout.names()} has "
                                f"{layout.count_rule()}")
    _check_slots(what, layout.head, params, 0)
    n_blocks = layout.blocks[0]
    if layout.blocks_slot:
        n_blocks = int(params[[s.name for s in layout.head].index(layout.blocks_slot)])
    sizes = layout.sizes(n_blocks)
    if n not in sizes:
        count = f" for {layout.blocks_slot}={n_blocks}" if layout.blocks_slot else ""
        raise InvalidInputError(f"{what}: layout {layout.names()} needs "
                                f"{' or '.join(map(str, sizes))} parameters{count}, got {n}")
    at = len(layout.head)
    for _ in range(n_blocks):
        _check_slots(what, layout.block, params, at)
        at += len(layout.block)
    if n > at:
        _check_slots(what, layout.tail, params, at)
        tail = [float(v) for v in params[at:]]
        if layout.tail_increasing and any(b <= a for a, b in itertools.pairwise(tail)):
            raise InvalidInputError(f"{what}: {', '.join(s.name for s in layout.tail)} must be strictly "
                                    f"increasing, got {tail}")


def _check_slots(what: str, slots: tuple[Slot, ...], params: NDArray[np.float64], at: int) -> None:
    """Each of ``slots`` against ``params[at:]``: the first value out of its range is named."""
    for i, slot in enumerate(slots, start=at):
        value = float(params[i])
        if not slot.admits(value):
            raise InvalidInputError(f"{what}: parameter {i} ({slot.name}) = {value!r} must be "
                                    f"{slot.describe()}")
