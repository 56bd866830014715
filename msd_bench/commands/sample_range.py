"""``A:B`` sample ranges as the commands take them (``--train``, ``--validation``, ``--range``).

One parser, so every command reads a range the same way and says the same
line when it is wrong: an empty side is the record's start or end, B is
excluded, and a range shorter than what the command needs is refused.
"""

from __future__ import annotations

from msd_bench.core.errors import InvalidInputError


def sample_range(text: str, opt: str, n: int, *, min_samples: int = 1) -> tuple[int, int]:
    """``A:B`` as indices with 0 <= A < B <= n and B - A >= min_samples, or a one-line error.

    An empty ``text`` is the whole record; ``:B`` starts at 0 and ``A:`` ends at n.
    """
    if not text:
        a, b = 0, n
    else:
        try:
            a, b = (int(v) if v.strip() else d for v, d in zip(text.split(":"), (0, n), strict=True))
        except ValueError:
            raise InvalidInputError(f"--{opt} must be A:B (sample indices), got {text!r}") from None
    if not 0 <= a < b <= n:
        raise InvalidInputError(f"--{opt} {a}:{b} is out of bounds: the record has {n} samples (0:{n})")
    if b - a < min_samples:
        raise InvalidInputError(f"--{opt} {a}:{b} holds {b - a} samples; it needs at least {min_samples}")
    return a, b


__all__ = ["sample_range"]
