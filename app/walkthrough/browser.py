"""Headless Chromium over the DevTools protocol, for the handout's checks and screenshot.

Debian's ``/usr/bin/chromium`` is started with ``--remote-debugging-pipe``: the protocol's
JSON messages, each ending in a NUL byte, go in on the child's file descriptor 3 and come
out on 4, so no port is opened and nothing beyond the standard library is needed. Every
network request the page makes is recorded (``Network.requestWillBeSent``) and any that
is not a local file is refused (``Fetch``), so a handout that reaches for the network is
both caught and kept off it.
"""

from __future__ import annotations

import base64
import contextlib
import fcntl
import json
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_PACKAGE = "chromium"
LOCAL_SCHEMES = ("file:", "data:", "about:", "blob:")
# The flags of a headless, sandbox-free (we may be root), quiet browser that fetches no
# updates, components or sync data of its own.
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--hide-scrollbars",
    "--remote-debugging-pipe",
)


class BrowserError(RuntimeError):
    """Chromium is missing, died, or did not answer in time."""


def chromium_path() -> str | None:
    """The Chromium binary, or None (install Debian's ``chromium``)."""
    if Path(CHROMIUM).is_file():
        return CHROMIUM
    return shutil.which("chromium")


class Browser:
    """One headless Chromium with one page; ``with Browser() as b: b.open(path)``."""

    def __init__(self, width: int = 1000, height: int = 1400, timeout: float = 60.0) -> None:
        binary = chromium_path()
        if binary is None:
            raise BrowserError(f"no Chromium: install the Debian package {CHROMIUM_PACKAGE}")
        self.timeout = timeout
        self.requests: list[str] = []  # every URL the page asked for
        self.blocked: list[str] = []  # the ones refused as not local
        self._profile = tempfile.TemporaryDirectory(prefix="pbs-chromium-")
        to_child_r, self._to_child = os.pipe()
        self._from_child, from_child_w = os.pipe()

        def child_fds() -> None:  # runs in the child: its fds 3 (in) and 4 (out)
            # Copies above 10 first: a pipe's own number may be 3 or 4 already.
            high_in = fcntl.fcntl(to_child_r, fcntl.F_DUPFD, 10)
            high_out = fcntl.fcntl(from_child_w, fcntl.F_DUPFD, 10)
            os.dup2(high_in, 3)  # dup2's copies are inheritable: they survive exec
            os.dup2(high_out, 4)

        self._proc = subprocess.Popen(
            [binary, *FLAGS, f"--user-data-dir={self._profile.name}",
             f"--window-size={width},{height}", "about:blank"],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            close_fds=False, preexec_fn=child_fds,
        )  # fmt: skip
        os.close(to_child_r)
        os.close(from_child_w)
        self._buffer = b""
        self._next_id = 0
        self._events: list[dict] = []
        try:
            target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
            self.session = self.call(
                "Target.attachToTarget", {"targetId": target, "flatten": True}
            )["sessionId"]
            self.call("Page.enable", session=True)
            self.call("Network.enable", session=True)
            self.call("Fetch.enable", {"patterns": [{"urlPattern": "*"}]}, session=True)
            self.call(
                "Emulation.setDeviceMetricsOverride",
                {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False},
                session=True,
            )
        except BaseException:
            self.close()
            raise

    # --- the protocol ----------------------------------------------------------------------

    def _read_message(self, deadline: float) -> dict:
        import select

        while b"\0" not in self._buffer:
            left = deadline - time.monotonic()
            if left <= 0:
                raise BrowserError("Chromium did not answer in time")
            ready, _, _ = select.select([self._from_child], [], [], left)
            if ready:
                chunk = os.read(self._from_child, 1 << 20)
                if not chunk:
                    raise BrowserError("Chromium closed the DevTools pipe (did it start?)")
                self._buffer += chunk
        raw, self._buffer = self._buffer.split(b"\0", 1)
        return json.loads(raw)

    def _handle_event(self, message: dict) -> None:
        method = message.get("method")
        params = message.get("params", {})
        if method == "Network.requestWillBeSent":
            self.requests.append(params["request"]["url"])
        elif method == "Fetch.requestPaused":
            url = params["request"]["url"]
            if url.startswith(LOCAL_SCHEMES):
                self._send("Fetch.continueRequest", {"requestId": params["requestId"]}, True)
            else:
                self.blocked.append(url)
                self._send(
                    "Fetch.failRequest",
                    {"requestId": params["requestId"], "errorReason": "BlockedByClient"},
                    True,
                )
        self._events.append(message)

    def _send(self, method: str, params: dict | None, session: bool) -> int:
        self._next_id += 1
        message: dict[str, Any] = {"id": self._next_id, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = self.session
        os.write(self._to_child, json.dumps(message).encode() + b"\0")
        return self._next_id

    def call(self, method: str, params: dict | None = None, session: bool = False) -> dict:
        """Send one command and return its result (events meanwhile are handled)."""
        wanted = self._send(method, params, session)
        deadline = time.monotonic() + self.timeout
        while True:
            message = self._read_message(deadline)
            if message.get("id") == wanted:
                if "error" in message:
                    raise BrowserError(f"{method}: {message['error'].get('message')}")
                return message.get("result", {})
            if "method" in message:
                self._handle_event(message)

    def wait_for(self, event: str) -> dict:
        """Wait for the page's next ``event`` (``Page.loadEventFired``)."""
        for k, message in enumerate(self._events):
            if message.get("method") == event:
                del self._events[k]
                return message
        deadline = time.monotonic() + self.timeout
        while True:
            message = self._read_message(deadline)
            if "method" in message:
                self._handle_event(message)
                if message["method"] == event:
                    self._events.remove(message)
                    return message

    # --- what the checks use ---------------------------------------------------------------

    def open(self, page: Path) -> None:
        """Load a local HTML file and wait for its load event (images included)."""
        self._events.clear()
        self.call("Page.navigate", {"url": Path(page).resolve().as_uri()}, session=True)
        self.wait_for("Page.loadEventFired")

    def evaluate(self, expression: str) -> Any:
        """A JavaScript expression's value in the page (JSON-serialisable)."""
        result = self.call(
            "Runtime.evaluate",
            {"expression": expression, "returnByValue": True, "awaitPromise": True},
            session=True,
        )
        if "exceptionDetails" in result:
            raise BrowserError(f"script failed: {result['exceptionDetails'].get('text')}")
        return result["result"].get("value")

    def screenshot(self, clip: dict | None = None, full_page: bool = False) -> bytes:
        """PNG bytes of the viewport, of ``clip`` ({x, y, width, height} in CSS pixels),
        or of the whole page."""
        params: dict[str, Any] = {"format": "png", "captureBeyondViewport": full_page}
        if clip is not None:
            params["clip"] = {**clip, "scale": 1}
        return base64.b64decode(self.call("Page.captureScreenshot", params, session=True)["data"])

    def close(self) -> None:
        """Stop Chromium (this process only) and remove its profile."""
        with contextlib.suppress(Exception):
            self._send("Browser.close", None, False)
        try:
            self._proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
        for fd in (self._to_child, self._from_child):
            with contextlib.suppress(OSError):
                os.close(fd)
        self._profile.cleanup()

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
