"""A real headless Chromium (Debian's ``chromium``) driven over the Chrome DevTools Protocol.

:class:`HeadlessChromium` starts the browser with its own throw-away profile, opens a page, collects
every console error and uncaught exception, and evaluates JavaScript in the page. It uses the
``websocket-client`` package only (no Playwright, no Selenium). :func:`chromium_or_skip` gives the
binary or the reason it is missing (the set-up, ``scripts/ensure_system_deps.sh``, installs it).
"""

from __future__ import annotations

import contextlib
import itertools
import json
import os
import shutil
import signal
import subprocess
import tempfile
import time
import urllib.request
from pathlib import Path
from types import TracebackType
from typing import Any

import pytest

FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run", "--no-default-browser-check",
         "--disable-dev-shm-usage", "--remote-debugging-port=0", "--remote-debugging-address=127.0.0.1",
         # WebGL (plotly's 3D views) without a GPU: Chromium's software renderer, as a GPU-less desktop gets
         "--use-angle=swiftshader", "--enable-unsafe-swiftshader")


def chromium_or_skip() -> str:
    """The Chromium binary; skips the test, saying why, when the package is not installed."""
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    pytest.skip("no Chromium: `apt-get install chromium` (scripts/ensure_system_deps.sh installs it; "
                "this machine could not)")


#: browser starts tried before giving up (each waits ``timeout`` for the DevTools port)
LAUNCHES = 2


class HeadlessChromium:
    """One headless browser with one page (a context manager)."""

    def __init__(self, binary: str, timeout: float = 30.0) -> None:
        import websocket  # the CDP client

        self.timeout = timeout
        for attempt in range(LAUNCHES):  # a start that never opens its port (seen once on a loaded machine): again
            self._launch(binary)
            try:
                port = self._port()
                break
            except TimeoutError:
                self.close()
                if attempt == LAUNCHES - 1:
                    raise
            except BaseException:
                self.close()
                raise
        try:
            page = self._page_target(port)
            self._ws = websocket.create_connection(page, timeout=timeout, suppress_origin=True)
        except BaseException:
            self.close()
            raise
        self._ids = itertools.count(1)
        self.console_errors: list[str] = []
        self.events: list[dict[str, Any]] = []
        for method in ("Runtime.enable", "Log.enable", "Page.enable"):
            self.call(method)

    def _launch(self, binary: str) -> None:
        # Chromium's helper processes (renderer, crash handler) may still write into the profile after the
        # main one exits: the browser gets its own process group, all of it is ended before the profile goes
        self._profile = tempfile.TemporaryDirectory(prefix="auvlink-chromium-", ignore_cleanup_errors=True)
        self._proc = subprocess.Popen([binary, *FLAGS, f"--user-data-dir={self._profile.name}", "about:blank"],
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)

    def _port(self) -> int:
        marker = Path(self._profile.name) / "DevToolsActivePort"
        end = time.monotonic() + self.timeout
        while time.monotonic() < end:
            if self._proc.poll() is not None:
                raise RuntimeError(f"chromium exited with {self._proc.returncode} before listening")
            if marker.is_file() and marker.read_text().strip():
                return int(marker.read_text().split()[0])
            time.sleep(0.05)
        raise TimeoutError("chromium did not open its DevTools port")

    def _page_target(self, port: int) -> str:
        end = time.monotonic() + self.timeout
        while time.monotonic() < end:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=5) as r:
                pages = [t for t in json.load(r) if t.get("type") == "page"]
            if pages:
                return str(pages[0]["webSocketDebuggerUrl"])
            time.sleep(0.05)
        raise TimeoutError("chromium has no page target")

    def _note(self, msg: dict[str, Any]) -> None:
        method, params = msg.get("method"), msg.get("params", {})
        if method is None:
            return
        self.events.append(msg)
        if method == "Runtime.consoleAPICalled" and params.get("type") in ("error", "assert"):
            args = params.get("args", [])
            self.console_errors.append(" ".join(str(a.get("value", a.get("description", ""))) for a in args))
        elif method == "Runtime.exceptionThrown":
            d = params.get("exceptionDetails", {})
            self.console_errors.append(str(d.get("exception", {}).get("description") or d.get("text")))
        elif method == "Log.entryAdded" and params.get("entry", {}).get("level") == "error":
            e = params["entry"]
            self.console_errors.append(f"{e.get('source')}: {e.get('text')} ({e.get('url', '')})")

    def call(self, method: str, **params: Any) -> dict[str, Any]:
        """Send one CDP command and return its result (events met meanwhile are recorded)."""
        mid = next(self._ids)
        self._ws.send(json.dumps({"id": mid, "method": method, "params": params}))
        while True:
            msg = json.loads(self._ws.recv())
            if msg.get("id") == mid:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return dict(msg.get("result", {}))
            self._note(msg)

    def wait_event(self, method: str) -> dict[str, Any]:
        end = time.monotonic() + self.timeout
        seen = next((e for e in self.events if e["method"] == method), None)
        while seen is None:
            if time.monotonic() > end:
                raise TimeoutError(f"no {method} within {self.timeout} s")
            msg = json.loads(self._ws.recv())
            self._note(msg)
            if msg.get("method") == method:
                seen = msg
        return seen

    def open(self, path: Path) -> None:
        """Navigate to a local file and wait for its load event."""
        self.call("Page.navigate", url=path.resolve().as_uri())
        self.wait_event("Page.loadEventFired")

    def evaluate(self, expression: str) -> Any:
        """The value of a JavaScript expression in the page (promises awaited)."""
        res = self.call("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in res:
            raise RuntimeError(f"{expression}: {res['exceptionDetails']}")
        return res.get("result", {}).get("value")

    def wait_for(self, expression: str, timeout: float | None = None) -> Any:
        """Poll ``expression`` until it is truthy; returns its value (or raises after the timeout)."""
        end = time.monotonic() + (timeout or self.timeout)
        while True:
            value = self.evaluate(expression)
            if value or time.monotonic() > end:
                return value
            time.sleep(0.1)

    def close(self) -> None:
        ws = getattr(self, "_ws", None)
        if ws is not None:
            ws.close()
        if self._proc.poll() is None:
            self._proc.terminate()
            try:
                self._proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self._proc.pid, signal.SIGKILL)  # the helper processes left in the browser's group
        self._profile.cleanup()

    def __enter__(self) -> HeadlessChromium:
        return self

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None) -> None:
        self.close()
