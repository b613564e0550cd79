"""Drive a headless Chromium through the DevTools protocol over a pipe: open a page, run
JavaScript in it, collect its console errors, take a screenshot.

The viewer's browser tests, ``benchmarks/bench_viewer.py`` and the screenshot in
docs/viewer.md use it. ``--remote-debugging-pipe`` speaks JSON messages separated by NUL bytes
on file descriptors 3 (to the browser) and 4 (from it), so the standard library suffices: no
websocket client, no port to pick. Needs a ``chromium`` (Debian's package) on PATH.
"""

from __future__ import annotations

import base64
import json
import os
import queue
import shutil
import subprocess
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from swarmnav.errors import SwarmnavError

#: Flags of every launch: headless, no first-run chores or network, WebGL on the software
#: rasteriser (SwiftShader) so the perspective view draws on a machine without a GPU, and the
#: page composited in software (through SwiftShader's GL a 2-D canvas page got ~2 frames/s
#: instead of 60 on a loaded 2-core machine).
FLAGS = ("--headless", "--no-sandbox", "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--disable-quic", "--mute-audio",
         "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist",
         "--disable-gpu-compositing", "--disable-dev-shm-usage")


def find_chromium() -> str | None:
    """Path of a chromium binary on PATH, or None."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


class Browser:
    """One headless Chromium with one page (a context manager).

    Attributes:
        errors: console errors and uncaught exceptions of the page, as one line each.
        requests: URL of every request the page made (the page itself included).
    """

    def __init__(self, width: int = 1280, height: int = 800, timeout: float = 60.0):
        exe = find_chromium()
        if exe is None:
            raise SwarmnavError("no chromium on PATH (Debian: apt-get install chromium)")
        self.timeout = timeout
        self.errors: list[str] = []
        self.requests: list[str] = []
        self._profile = tempfile.TemporaryDirectory(prefix="swarmnav-chromium-")
        to_child_r, self._to_child = os.pipe()
        self._from_child, from_child_w = os.pipe()

        def wire():  # in the child: the protocol's fds 3 (commands in) and 4 (replies out)
            import fcntl

            r, w = (fcntl.fcntl(fd, fcntl.F_DUPFD, 10) for fd in (to_child_r, from_child_w))
            os.dup2(r, 3)  # dup2 leaves the copy inheritable
            os.dup2(w, 4)

        self.proc = subprocess.Popen(
            [exe, *FLAGS, "--remote-debugging-pipe", f"--user-data-dir={self._profile.name}",
             f"--window-size={width},{height}", "about:blank"],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            close_fds=False, preexec_fn=wire)  # our own fds are not inheritable; 3 and 4 are
        os.close(to_child_r)
        os.close(from_child_w)
        self._next = 0
        self._replies: dict[int, queue.Queue] = {}
        self._events: queue.Queue = queue.Queue()
        self._lock = threading.Lock()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        # the page chromium opened with (a target made with createTarget is a background tab,
        # whose requestAnimationFrame is throttled to a few frames per second)
        pages = [t for t in self.send("Target.getTargets")["targetInfos"] if t["type"] == "page"]
        target = pages[0]["targetId"] if pages else self.send("Target.createTarget", url="about:blank")["targetId"]
        self.session = self.send("Target.attachToTarget", targetId=target, flatten=True)["sessionId"]
        for domain in ("Page", "Runtime", "Log", "Network"):
            self.send(f"{domain}.enable", session=True)
        self.send("Page.bringToFront", session=True)
        self.send("Emulation.setDeviceMetricsOverride", session=True, width=width, height=height,
                  deviceScaleFactor=1, mobile=False)

    # ------------------------------------------------------------------ protocol
    def _read(self) -> None:
        buf = b""
        while True:
            try:
                chunk = os.read(self._from_child, 1 << 20)
            except OSError:
                chunk = b""
            if not chunk:
                self._events.put(None)
                for q in list(self._replies.values()):
                    q.put({"error": {"message": "chromium exited"}})
                return
            buf += chunk
            *messages, buf = buf.split(b"\0")
            for raw in messages:
                msg = json.loads(raw)
                if "id" in msg:
                    q = self._replies.get(msg["id"])
                    if q is not None:
                        q.put(msg)
                else:
                    self._on_event(msg)

    def _on_event(self, msg: dict) -> None:
        method, p = msg.get("method"), msg.get("params", {})
        if method == "Runtime.exceptionThrown":
            d = p["exceptionDetails"]
            self.errors.append((d.get("exception") or {}).get("description") or d.get("text", "exception"))
        elif method == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
            self.errors.append(" ".join(str(a.get("value", a.get("description", ""))) for a in p["args"]))
        elif method == "Network.requestWillBeSent":
            self.requests.append(p["request"]["url"])
        elif method == "Log.entryAdded" and p["entry"].get("level") == "error":
            self.errors.append(p["entry"].get("text", "error"))
        self._events.put(msg)

    def send(self, method: str, *, session: bool = False, timeout: float | None = None, **params) -> dict:
        """Send one protocol command and wait for its result (an error reply raises)."""
        with self._lock:
            self._next += 1
            i = self._next
            self._replies[i] = q = queue.Queue()
        msg = {"id": i, "method": method, "params": params}
        if session:
            msg["sessionId"] = self.session
        os.write(self._to_child, json.dumps(msg).encode() + b"\0")
        try:
            reply = q.get(timeout=timeout or self.timeout)
        except queue.Empty:
            raise TimeoutError(f"chromium did not answer {method} within {timeout or self.timeout} s") from None
        finally:
            self._replies.pop(i, None)
        if "error" in reply:
            raise RuntimeError(f"{method}: {reply['error'].get('message')}")
        return reply.get("result", {})

    # ------------------------------------------------------------------ page
    def open(self, url: str | Path) -> float:
        """Load ``url`` (a path becomes a file:// URL) and wait for its load event.

        Returns:
            Seconds from the navigation to the load event [s].
        """
        if isinstance(url, Path) or "://" not in str(url):
            url = Path(url).resolve().as_uri()
        while not self._events.empty():
            self._events.get_nowait()
        t0 = time.perf_counter()
        self.send("Page.navigate", session=True, url=url)
        deadline = t0 + self.timeout
        while True:
            try:
                ev = self._events.get(timeout=max(0.01, deadline - time.perf_counter()))
            except queue.Empty:
                raise TimeoutError(f"{url}: no load event within {self.timeout} s") from None
            if ev is None:
                raise RuntimeError("chromium exited while loading the page")
            if ev.get("method") == "Page.loadEventFired":
                return time.perf_counter() - t0

    def eval(self, expression: str, timeout: float | None = None) -> Any:
        """Value of a JavaScript expression in the page (promises awaited, result as JSON)."""
        r = self.send("Runtime.evaluate", session=True, timeout=timeout, expression=expression,
                      awaitPromise=True, returnByValue=True)
        if "exceptionDetails" in r:
            d = r["exceptionDetails"]
            raise RuntimeError((d.get("exception") or {}).get("description") or d.get("text"))
        return r["result"].get("value")

    def screenshot(self, path: str | Path) -> Path:
        """Write a PNG of the page's viewport."""
        data = self.send("Page.captureScreenshot", session=True, format="png")["data"]
        out = Path(path)
        out.write_bytes(base64.b64decode(data))
        return out

    def close(self) -> None:
        if self.proc.poll() is None:
            try:
                self.send("Browser.close", timeout=5)
            except (RuntimeError, TimeoutError, OSError):
                pass
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        for fd in (self._to_child, self._from_child):
            try:
                os.close(fd)
            except OSError:
                pass
        self._profile.cleanup()

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
