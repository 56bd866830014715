"""A headless Chromium driven over the DevTools protocol on a pipe: the standard library only.

Why a pipe: ``--remote-debugging-pipe`` speaks the protocol as NUL-separated
JSON on file descriptors 3 (commands in) and 4 (replies and events out), so
the test needs no WebSocket client, opens no port and downloads no browser —
it drives Debian's ``/usr/bin/chromium``. One :class:`Browser` is one fresh
profile (``--user-data-dir`` in a temporary directory) and one page.
"""

from __future__ import annotations

import contextlib
import json
import os
import selectors
import shutil
import subprocess
import tempfile
import time
from pathlib import Path
from types import TracebackType
from typing import Any

CHROMIUM = Path("/usr/bin/chromium")
"""Debian's package (``apt-get install -y chromium``, done by ``.ci/run``)."""

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run", "--disable-extensions",
         "--disable-default-apps", "--mute-audio", "--hide-scrollbars", "--remote-debugging-pipe"]
"""No sandbox (root in a container), nothing the browser would fetch on its own, the protocol on a pipe."""

TIMEOUT_S = 120.0
"""Bound on any one reply: only so a wedged browser fails the test instead of hanging it."""


class Browser:
    """One headless Chromium with one attached page; events are kept in :attr:`events`."""

    def __init__(self, width: int = 1280, height: int = 900) -> None:
        self.profile = Path(tempfile.mkdtemp(prefix="msd-chromium-"))
        cmd_r, self._cmd_w = os.pipe()
        self._out_r, out_w = os.pipe()
        self.proc = subprocess.Popen(
            [str(CHROMIUM), *FLAGS, f"--user-data-dir={self.profile}", f"--window-size={width},{height}",
             "about:blank"],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            pass_fds=(3, 4), preexec_fn=_fds_3_4(cmd_r, out_w))
        os.close(cmd_r)
        os.close(out_w)
        self._buf = b""
        self._next = 0
        self.events: list[dict[str, Any]] = []
        self.session = ""
        target = self.call("Target.createTarget", url="about:blank")["targetId"]
        self.session = self.call("Target.attachToTarget", targetId=target, flatten=True)["sessionId"]
        for domain in ("Page", "Runtime", "Log", "Network"):
            self.call(f"{domain}.enable")

    def call(self, method: str, **params: Any) -> dict[str, Any]:
        """Send one command (to the page once attached) and return its result; an error reply raises."""
        self._next += 1
        msg: dict[str, Any] = {"id": self._next, "method": method, "params": params}
        if self.session:
            msg["sessionId"] = self.session
        os.write(self._cmd_w, json.dumps(msg).encode() + b"\0")
        while True:
            reply = self._read()
            if reply.get("id") == self._next:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                result: dict[str, Any] = reply.get("result", {})
                return result
            self.events.append(reply)

    def wait_for(self, method: str) -> dict[str, Any]:
        """The first event named ``method`` (already received, or the next ones read)."""
        for event in self.events:
            if event.get("method") == method:
                return event
        while True:
            event = self._read()
            self.events.append(event)
            if event.get("method") == method:
                return event

    def evaluate(self, expression: str) -> Any:
        """The value of a JavaScript expression in the page."""
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True)
        if "exceptionDetails" in result:
            raise RuntimeError(f"{expression}: {result['exceptionDetails']}")
        return result["result"].get("value")

    def _read(self) -> dict[str, Any]:
        deadline = time.monotonic() + TIMEOUT_S
        with selectors.DefaultSelector() as sel:
            sel.register(self._out_r, selectors.EVENT_READ)
            while b"\0" not in self._buf:
                if not sel.select(timeout=max(0.0, deadline - time.monotonic())):
                    raise TimeoutError(f"chromium sent nothing for {TIMEOUT_S:.0f} s")
                chunk = os.read(self._out_r, 1 << 20)
                if not chunk:
                    raise RuntimeError(f"chromium closed the protocol pipe (exit {self.proc.poll()})")
                self._buf += chunk
        msg, self._buf = self._buf.split(b"\0", 1)
        doc: dict[str, Any] = json.loads(msg)
        return doc

    def close(self) -> None:
        """Stop this browser (the process this object started, by its PID) and remove its profile."""
        for fd in (self._cmd_w, self._out_r):
            with contextlib.suppress(OSError):  # closed already by an earlier close()
                os.close(fd)
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        shutil.rmtree(self.profile, ignore_errors=True)

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


def _fds_3_4(cmd_r: int, out_w: int) -> Any:
    """In the child: the command pipe's read end on fd 3, the reply pipe's write end on fd 4."""
    def move() -> None:
        a, b = os.dup(cmd_r), os.dup(out_w)  # above 4, so the two dup2 calls cannot clobber each other
        os.dup2(a, 3)
        os.dup2(b, 4)
        os.close(a)
        os.close(b)
    return move


def open_page(browser: Browser, path: Path) -> None:
    """Load ``path`` as a file:// URL and wait for its load event."""
    browser.events.clear()
    browser.call("Page.navigate", url=path.resolve().as_uri())
    browser.wait_for("Page.loadEventFired")


def network_requests(browser: Browser) -> list[str]:
    """Every URL the page asked for that is not the page itself or a ``data:`` URI."""
    urls = [e["params"]["request"]["url"] for e in browser.events
            if e.get("method") == "Network.requestWillBeSent"]
    return [u for u in urls if not u.startswith(("data:", "file://"))]


def console_errors(browser: Browser) -> list[str]:
    """Console errors, uncaught exceptions and browser log errors (a blocked request among them)."""
    out = []
    for e in browser.events:
        method, params = e.get("method"), e.get("params", {})
        if method == "Runtime.consoleAPICalled" and params.get("type") in ("error", "assert"):
            out.append(f"console.{params['type']}: {params.get('args')}")
        elif method == "Runtime.exceptionThrown":
            out.append(f"exception: {params.get('exceptionDetails')}")
        elif method == "Log.entryAdded" and params.get("entry", {}).get("level") == "error":
            out.append(f"log: {params['entry'].get('text')} {params['entry'].get('url', '')}")
    return out


def drawn_images(browser: Browser, path: Path) -> int:
    """Open ``path`` and check what every run page must do: draw every image it holds, show at least one
    table, ask the network for nothing, log no console error. Returns the number of images."""
    open_page(browser, path)
    assert browser.evaluate("document.querySelectorAll('table').length") >= 1
    images = browser.evaluate("[...document.images].map(i => i.complete && i.naturalWidth > 0)")
    assert all(images)
    assert network_requests(browser) == []
    assert console_errors(browser) == []
    return len(images)


def table1_rows(browser: Browser) -> int:
    """Rows of the open page's Table 1 section."""
    return int(browser.evaluate("[...document.querySelectorAll('section')].find(s => s.querySelector('h2')"
                                ".textContent == 'Table 1').querySelectorAll('tbody tr').length"))
