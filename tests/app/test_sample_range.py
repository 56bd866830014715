"""One ``A:B`` parser for every command's sample range: the same reading and the same lines."""

from __future__ import annotations

import pytest

from msd_bench.commands.sample_range import sample_range
from msd_bench.core.errors import InvalidInputError


@pytest.mark.parametrize(("text", "expected"), [
    ("", (0, 100)), ("10:20", (10, 20)), (":30", (0, 30)), ("70:", (70, 100)), (" 5 : 9 ", (5, 9)),
])
def test_a_range_reads_with_open_ends(text: str, expected: tuple[int, int]) -> None:
    assert sample_range(text, "range", 100) == expected


@pytest.mark.parametrize(("text", "line"), [
    ("a:b", "--train must be A:B (sample indices), got 'a:b'"),
    ("1:2:3", "--train must be A:B"),
    ("5", "--train must be A:B"),
    ("0:101", "--train 0:101 is out of bounds: the record has 100 samples (0:100)"),
    ("20:10", "--train 20:10 is out of bounds"),
    ("-1:10", "--train -1:10 is out of bounds"),
    ("10:12", "--train 10:12 holds 2 samples; it needs at least 3"),
])
def test_a_bad_range_is_one_line_naming_the_option(text: str, line: str) -> None:
    with pytest.raises(InvalidInputError) as exc:
        sample_range(text, "train", 100, min_samples=3)
    assert line in str(exc.value) and "\n" not in str(exc.value)
