"""What the live view costs (docs/live.md §Decimation).

* ``row_us``: microseconds per :meth:`LiveServer.plant` call in this process,
  with no viewer subscribed and with one (``--rows`` calls, best of three);
  ``viewer_rows_per_s``: rows the viewer received per second during the burst
  (the decimation caps it at 50);
* ``lockstep``: a lock-step plant process driven one command at a time
  (:class:`msd_bench.gym.ros_backend.RosBackend`), steps/s with ``live_port``
  off and on with a viewer subscribed, in ``--rounds`` interleaved pairs (the
  median ratio ``on_over_off`` is what a viewer costs the plant).

* ``--bench-run DIR``: instead, a real ``bench.py --live 0 --stages record`` (two broad records of
  3,000/1,000 samples) watched by the tests' Foxglove client from the moment the server is up:
  messages per channel, the progress messages, and how many of the rows received equal the row
  of the same stamp in one of the bags the run recorded.

    .venv/bin/python benchmarks/bench_live.py [--rows 200000] [--steps 3000] [--rounds 3]
    .venv/bin/python benchmarks/bench_live.py --bench-run /tmp/live-run

Prints JSON. No floor: the numbers are reported in docs/live.md.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import sys
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from websockets.exceptions import ConnectionClosed
from websockets.sync.client import ClientConnection, connect

from msd_bench.io.reports.live_server import SUBPROTOCOL, LiveServer


def _subscribe_all(ws: ClientConnection) -> None:
    ws.recv(30)  # serverInfo
    adv = json.loads(ws.recv(30))
    subs = [{"id": i + 1, "channelId": c["id"]} for i, c in enumerate(adv["channels"])]
    ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))


def _drain(ws: ClientConnection, count: list[int], stop: threading.Event) -> None:
    while not stop.is_set():
        try:
            ws.recv(0.2)
            count[0] += 1
        except TimeoutError:
            continue
        except ConnectionClosed:  # closed under us: the round is over
            return


def row_cost(rows: int) -> dict[str, Any]:
    server = LiveServer(0, "bench-live")

    def burst() -> float:
        t0 = time.perf_counter()
        for k in range(rows):
            server.plant(k * 10_000_000, 0.1, 0.2, 0.3)
        return (time.perf_counter() - t0) / rows * 1e6

    idle = min(burst() for _ in range(3))
    with connect(server.url, subprotocols=[SUBPROTOCOL]) as ws:  # type: ignore[list-item]
        _subscribe_all(ws)
        while not server.watched:
            time.sleep(0.001)
        count, stop = [0], threading.Event()
        reader = threading.Thread(target=_drain, args=(ws, count, stop), daemon=True)
        reader.start()
        t0 = time.monotonic()
        watched = min(burst() for _ in range(3))
        elapsed = time.monotonic() - t0
        time.sleep(0.3)
        stop.set()
        reader.join()
    server.close()
    return {"row_us_no_viewer": round(idle, 2), "row_us_one_viewer": round(watched, 2),
            "viewer_rows_per_s": round(count[0] / elapsed, 1)}


def lockstep_rate(steps: int, live: bool) -> float:
    from msd_bench.graph import launch
    from msd_bench.gym.ros_backend import RosBackend

    args = ["-p", "lockstep:=true", "-p", "duplicate_check:=0.0"] + (["-p", "live_port:=0"] if live else [])
    with launch.process_group() as procs:
        plant = procs.start("plant.py", args)
        line = plant.wait_for_line(r"live view on ws://|ready \(", 120.0)
        plant.wait_for_line(r"ready \(", 120.0)
        ws = None
        if live:
            ws = connect(re.search(r"ws://[\d.:]+", line).group(0),  # type: ignore[union-attr]
                         subprotocols=[SUBPROTOCOL]).__enter__()  # type: ignore[list-item]
            _subscribe_all(ws)
            count, stop = [0], threading.Event()
            threading.Thread(target=_drain, args=(ws, count, stop), daemon=True).start()
        backend = RosBackend("/msd")
        try:
            backend.reset()
            for _ in range(200):  # warm-up
                backend.step(1.0)
            t0 = time.perf_counter()
            for k in range(steps):
                backend.step(5.0 if (k // 50) % 2 else -5.0)
            rate = steps / (time.perf_counter() - t0)
        finally:
            backend.close()
            if ws is not None:
                stop.set()
                ws.close()
    return rate


def watch_bench_run(out: Path) -> dict[str, Any]:
    """A bench.py --live run watched from outside; its rows compared with its own bags."""
    import subprocess

    from websockets.exceptions import ConnectionClosed

    from msd_bench.io.bags.reader import read_samples
    from msd_bench.io.reports import live_server as live
    from tests.graph.foxglove_client import FoxgloveClient, Received

    topics = [live.PLANT_TOPIC, live.SETPOINT_TOPIC, live.PROGRESS_TOPIC, live.LOG_TOPIC]
    repo = Path(__file__).resolve().parents[1]
    argv = ["launch_scripts/bench.py", "--live", "0", "--stages", "record", "--agents", "glm",
            "--samples", "3000", "--val-samples", "1000", "--out", str(out)]
    proc = subprocess.Popen([sys.executable, *argv], cwd=repo, stderr=subprocess.PIPE,
                            stdout=subprocess.DEVNULL, text=True)
    assert proc.stderr is not None
    url = None
    for line in proc.stderr:  # the server is up before the run directory line
        m = re.search(r"live view on (ws://[\d.:]+)", line)
        if m:
            url = m.group(1)
            break
    assert url is not None, "bench.py printed no live view line"
    threading.Thread(target=proc.stderr.read, daemon=True).start()
    client = FoxgloveClient(url)
    client.wait_for_channels(topics)
    client.subscribe(topics)
    got: list[Received] = []
    while True:
        try:
            r = client.receive(0.5)
        except ConnectionClosed:  # the run ended: its server stopped
            break
        if r is not None:
            got.append(r)
        elif proc.poll() is not None:
            break
    proc.wait()
    bags = [read_samples(out / "excitation" / n).rows for n in ("broad", "val_broad")]
    by_stamp = [{int(s): (x, e) for s, x, e in zip(b.stamps, b.x, b.effort, strict=True)} for b in bags]
    rows = [r.value for r in got if r.topic == live.PLANT_TOPIC]
    equal = sum(any(d.get(m.timestamp.seconds * 10**9 + m.timestamp.nanos) ==
                    (m.joints[0].position, m.joints[0].effort) for d in by_stamp) for m in rows)
    return {"exit": proc.returncode, "messages": {t: sum(r.topic == t for r in got) for t in topics},
            "progress": [r.value for r in got if r.topic == live.PROGRESS_TOPIC],
            "rows": len(rows), "rows_equal_to_a_bag_row": equal}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--rows", type=int, default=200_000)
    p.add_argument("--steps", type=int, default=3000)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--bench-run", type=Path, metavar="DIR", help="watch a real bench.py --live run into DIR")
    a = p.parse_args()
    if a.bench_run is not None:
        print(json.dumps(watch_bench_run(a.bench_run), indent=1))
        return 0
    out: dict[str, Any] = row_cost(a.rows)
    pairs = [(lockstep_rate(a.steps, False), lockstep_rate(a.steps, True)) for _ in range(a.rounds)]
    out["lockstep_steps_per_s_off"] = [round(off) for off, _ in pairs]
    out["lockstep_steps_per_s_on"] = [round(on) for _, on in pairs]
    out["on_over_off"] = round(statistics.median(on / off for off, on in pairs), 3)
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
