"""``--ray-address`` is probed, bounded, before ``--out`` is written; the address joined is the one given."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from msd_bench.app.executor import ExecutorOptions, join_as_given
from msd_bench.app.ray_probe import probe_ray_address
from msd_bench.cli import main as cli_main
from msd_bench.core.errors import ConfigError
from tests.app.test_sweep_executors import EFFICIENCY


def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture
def silent_listener() -> Iterator[int]:
    """A TCP listener that accepts and never speaks: not a Ray head."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    stop = threading.Event()

    def accept() -> None:
        held = []
        srv.settimeout(0.2)
        while not stop.is_set():
            try:
                held.append(srv.accept()[0])
            except OSError:
                continue
        for c in held:
            c.close()

    t = threading.Thread(target=accept, daemon=True)
    t.start()
    yield int(srv.getsockname()[1])
    stop.set()
    t.join()
    srv.close()


def test_an_unreachable_address_is_one_line_and_out_is_not_written(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    addr = f"127.0.0.1:{_closed_port()}"
    out = tmp_path / "x"
    assert cli_main([*EFFICIENCY, "--executor", "ray", "--ray-address", addr, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"--ray-address {addr}: nothing answers there" in err
    assert not out.exists()


def test_a_listener_that_is_not_ray_is_refused_within_the_bound(silent_listener: int) -> None:
    started = time.monotonic()
    with pytest.raises(ConfigError, match=rf"^--ray-address 127.0.0.1:{silent_listener}: "):
        probe_ray_address(f"127.0.0.1:{silent_listener}", timeout=4.0)
    assert time.monotonic() - started < 60  # bounded (not Ray's minutes of "Failed to get cluster ID")


@pytest.mark.parametrize("addr", ["127.0.0.1", "host:port", "127.0.0.1:70000"])
def test_a_malformed_address_is_one_line(addr: str) -> None:
    with pytest.raises(ConfigError, match="expected host:port, ray://host:port or auto"):
        probe_ray_address(addr)


def test_ray_is_asked_to_join_the_address_as_given() -> None:
    seen: list[Any] = []

    def rewrite(addr: Any, temp_dir: Any = None) -> str:
        return "192.0.2.2:6379"  # what Ray 2.60 does with a loopback host

    services = SimpleNamespace(canonicalize_bootstrap_address=rewrite)
    fake = SimpleNamespace(_private=SimpleNamespace(services=services))
    with join_as_given(fake, "127.0.0.1:6379"):
        seen.append(services.canonicalize_bootstrap_address("127.0.0.1:6379"))
        seen.append(services.canonicalize_bootstrap_address("auto"))
    assert seen == ["127.0.0.1:6379", "192.0.2.2:6379"]
    assert services.canonicalize_bootstrap_address is rewrite


@pytest.mark.parametrize(("kw", "message"), [
    ({"workers": 10**20}, r"--workers 100000000000000000000 is more than 1024"),
    ({"retries": 10**20}, r"--retries 100000000000000000000 is more than 100"),
])
def test_workers_and_retries_have_stated_bounds(kw: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        ExecutorOptions(**kw)
