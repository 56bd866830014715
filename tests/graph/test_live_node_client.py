"""Foxglove's own client reads the live view: @foxglove/ws-protocol (the protocol's reference client,
which Lichtblick and older Foxglove apps speak) from npm, under Node from Debian's packages.

``tests/node_client/watch.mjs`` connects ``FoxgloveClient`` to a real ``bench.py --live`` run,
subscribes to the plant's joint states and decodes them with the protobuf schema the server
advertises; every row must be a row of the same stamp in the bags the run recorded. The layout's
channels must be among those advertised. docs/live.md §Connect (its part on Foxglove's own client)
says what it proves.
Tier ``node`` (``.ci/run`` installs Node and the client); skipped with one line without them.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import pytest

from msd_bench.io.bags.reader import read_samples

pytestmark = pytest.mark.node

ROOT = Path(__file__).resolve().parents[2]
CLIENT = ROOT / "tests" / "node_client"
BOTH = "foxglove.websocket.v1,foxglove.sdk.v1"
"""What the client's WebSocket offers: the protocol's old name and the SDK's (the same protocol)."""


@pytest.fixture(scope="module")
def node() -> str:
    exe = shutil.which("node")
    if exe is None:
        pytest.skip("no node: apt-get install -y nodejs npm (as .ci/run does)")
    if not (CLIENT / "node_modules" / "@foxglove" / "ws-protocol").exists():
        pytest.skip("no @foxglove/ws-protocol: npm install --prefix tests/node_client (as .ci/run does)")
    return exe


def _watch(node: str, url: str, protocols: str) -> subprocess.Popen[str]:
    return subprocess.Popen([node, str(CLIENT / "watch.mjs"), url, protocols], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, stdin=subprocess.DEVNULL)


def _lines(proc: subprocess.Popen[str], timeout: float) -> list[dict[str, Any]]:
    out, err = proc.communicate(timeout=timeout)
    assert proc.returncode in (0, 3), err
    return [json.loads(line) for line in out.splitlines() if line.startswith("{")]


def test_the_reference_client_reads_a_bench_runs_rows_and_the_layouts_channels(node: str,
                                                                              tmp_path: Path) -> None:
    out = tmp_path / "run"
    argv = ["launch_scripts/bench.py", "--live", "0", "--stages", "record", "--agents", "glm",
            "--samples", "1500", "--val-samples", "500", "--live-wait", "240", "--out", str(out)]
    bench = subprocess.Popen([sys.executable, *argv], cwd=ROOT, stderr=subprocess.PIPE, text=True,
                             stdout=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
    assert bench.stderr is not None
    url = None
    for line in bench.stderr:  # the server is up before the run; the run waits for a subscriber
        if m := re.search(r"live view on (ws://127\.0\.0\.1:\d+)", line):
            url = m.group(1)
            break
    assert url is not None, "bench.py printed no live view line"
    rest = threading.Thread(target=bench.stderr.read, daemon=True)
    rest.start()
    try:
        old = _lines(_watch(node, url, "foxglove.websocket.v1"), 60)  # the old name alone: refused
        got = _lines(_watch(node, url, BOTH), 300)  # ends when bench.py's server closes
        assert bench.wait(timeout=300) == 0
    finally:
        if bench.poll() is None:
            bench.kill()
            bench.wait()
        rest.join(timeout=30)
        bench.stderr.close()
    assert old == [{"error": "HTTP 400"}]
    assert got[0] == {"subprotocol": "foxglove.sdk.v1"}
    channels = {c["topic"]: c for c in got[1]["channels"]}
    assert channels["/plant/joint_states"]["schemaName"] == "foxglove.JointStates"
    layout = set(re.findall(r'"(/(?:plant|bench)/[a-z_]+)', (ROOT / "docs" / "live-layout.json").read_text()))
    assert layout and layout <= set(channels)
    rows = [r["row"] for r in got if "row" in r]
    bags = [read_samples(out / "excitation" / n).rows for n in ("broad", "val_broad")]
    by_stamp = [{int(s): (x, e) for s, x, e in zip(b.stamps.tolist(), b.x.tolist(), b.effort.tolist(),
                                                   strict=True)} for b in bags]
    assert len(rows) >= 2
    for stamp, x, _, u in rows:  # the bags keep position and effort (velocity is not recorded)
        assert any(d.get(int(stamp)) == (x, u) for d in by_stamp), (stamp, x, u)
