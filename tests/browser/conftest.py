"""The browser tier's shared headless Chromium, one per test module."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.browser.cdp import CHROMIUM, Browser


@pytest.fixture(scope="module")
def browser() -> Iterator[Browser]:
    if not CHROMIUM.exists():  # the modules skip themselves first, with one line; this is a guard
        pytest.skip(f"{CHROMIUM} not found")
    with Browser() as b:
        yield b
