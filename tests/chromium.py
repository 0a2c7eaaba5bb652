"""Drive Debian's headless Chromium over the DevTools protocol on a pipe (``--remote-debugging-pipe``), for the
tests of pages autorig writes: open a file, run script in it, type into it as a user would, take a screenshot.

    with Chromium() as browser:
        browser.open(path)
        browser.evaluate("document.title")
        browser.type_into("#filter", "hero")
        browser.screenshot(tmp_path / "page.png")

The protocol's messages are JSON, each ended by a NUL byte: commands go to the browser on its fd 3, answers and
events come back on its fd 4. Only the standard library is needed, and no port is opened.
"""
from __future__ import annotations

import base64
import fcntl
import json
import os
import select
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

EXECUTABLE = shutil.which("chromium")
# No network of any kind (the page must not need one), no first-run or background work, a fresh profile.
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--remote-debugging-pipe"]


class ChromiumError(RuntimeError):
    pass


class Chromium:
    def __init__(self, width: int = 1300, height: int = 1000, timeout: float = 60.0):
        if EXECUTABLE is None:
            raise ChromiumError("chromium is not installed")
        self.timeout = timeout
        self._profile = tempfile.mkdtemp(prefix="autorig-chromium-")
        to_browser, self._commands = os.pipe()
        self._answers, from_browser = os.pipe()

        def pipes_at_3_and_4():
            # Copies above 10 first, so that moving one to 3 or 4 cannot overwrite the other.
            high = [fcntl.fcntl(fd, fcntl.F_DUPFD, 10) for fd in (to_browser, from_browser)]
            os.dup2(high[0], 3)
            os.dup2(high[1], 4)

        self._process = subprocess.Popen(
            [EXECUTABLE, *FLAGS, f"--user-data-dir={self._profile}", f"--window-size={width},{height}",
             "about:blank"], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            preexec_fn=pipes_at_3_and_4, pass_fds=(3, 4))
        os.close(to_browser)
        os.close(from_browser)
        self._buffer = b""
        self._next_id = 0
        self.events: list[dict] = []
        target = self._send("Target.createTarget", {"url": "about:blank"})["targetId"]
        self._session = self._send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        self.command("Emulation.setDeviceMetricsOverride",
                     {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False})
        self.command("Page.enable")
        self.command("Runtime.enable")

    def __enter__(self) -> Chromium:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        try:
            self._send("Browser.close")
        except (ChromiumError, OSError):
            pass
        try:
            self._process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
        for fd in (self._commands, self._answers):
            try:
                os.close(fd)
            except OSError:
                pass
        shutil.rmtree(self._profile, ignore_errors=True)

    def command(self, method: str, params: dict | None = None) -> dict:
        """Run one protocol command in the page; returns its result."""
        return self._send(method, params, session=self._session)

    def open(self, path: str | os.PathLike, query: str = "") -> None:
        """Load a file (with ``?query``) and wait for its load event."""
        self.open_url(Path(path).resolve().as_uri() + (f"?{query}" if query else ""))

    def open_url(self, url: str) -> None:
        """Load a URL and wait for its load event."""
        self.events.clear()
        self.command("Page.navigate", {"url": url})
        self._wait_for("Page.loadEventFired")
        # Two frames: the first rendering is done, so that what is on screen is laid out (content-visibility:
        # auto leaves cards unrendered, their innerText empty, until the browser has seen where they are).
        self.evaluate("new Promise(done => requestAnimationFrame(() => requestAnimationFrame(done)))")

    def evaluate(self, expression: str):
        """The value of a JavaScript expression in the page (promises awaited)."""
        answer = self.command("Runtime.evaluate", {"expression": expression, "returnByValue": True,
                                                   "awaitPromise": True})
        if "exceptionDetails" in answer:
            raise ChromiumError(f"{expression!r} threw: {answer['exceptionDetails']}")
        return answer["result"].get("value")

    def type_into(self, selector: str, text: str) -> None:
        """Focus the element, select what it holds and type ``text`` over it, as key input does (the page sees
        real input events)."""
        self.evaluate(f"(e => {{ e.focus(); e.select(); }})(document.querySelector({json.dumps(selector)}))")
        self.command("Input.insertText", {"text": text})

    def click(self, x: float, y: float) -> None:
        """A left click at (x, y) in the window's CSS pixels, as the mouse makes it (move, press, release)."""
        for kind in ("mouseMoved", "mousePressed", "mouseReleased"):
            self.command("Input.dispatchMouseEvent", {"type": kind, "x": x, "y": y, "button": "left",
                                                      "buttons": 1 if kind == "mousePressed" else 0,
                                                      "clickCount": 0 if kind == "mouseMoved" else 1})

    def click_on(self, selector: str) -> None:
        """Click the middle of the first element ``selector`` matches."""
        x, y = self.evaluate(f"(b => [b.left + b.width / 2, b.top + b.height / 2])"
                             f"(document.querySelector({json.dumps(selector)}).getBoundingClientRect())")
        self.click(x, y)

    def wait_until(self, expression: str, timeout: float | None = None):
        """Poll a JavaScript expression until it is truthy; its value (``ChromiumError`` on timeout)."""
        deadline = time.monotonic() + (self.timeout if timeout is None else timeout)
        while True:
            value = self.evaluate(expression)
            if value:
                return value
            if time.monotonic() > deadline:
                raise ChromiumError(f"{expression!r} still false after {timeout or self.timeout:g} s")
            time.sleep(0.05)

    def download_into(self, folder: str | os.PathLike) -> None:
        """Save the page's downloads into ``folder`` under the names the page gives them."""
        self._send("Browser.setDownloadBehavior", {"behavior": "allow", "downloadPath": str(Path(folder).resolve())})

    def screenshot(self, path: str | os.PathLike) -> Path:
        """Save the whole page (beyond the window too) as a PNG."""
        data = self.command("Page.captureScreenshot", {"format": "png", "captureBeyondViewport": True})["data"]
        path = Path(path)
        path.write_bytes(base64.b64decode(data))
        return path

    def console_messages(self) -> list[str]:
        """Messages the page logged or threw since it was opened."""
        return [json.dumps(e["params"]) for e in self.events
                if e.get("method") in ("Runtime.exceptionThrown", "Runtime.consoleAPICalled")]

    # --------------------------------------------------------------------------------------- the protocol

    def _send(self, method: str, params: dict | None = None, session: str | None = None) -> dict:
        self._next_id += 1
        message = {"id": self._next_id, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = session
        os.write(self._commands, json.dumps(message).encode() + b"\0")
        while True:
            answer = self._read()
            if answer.get("id") == self._next_id:
                if "error" in answer:
                    raise ChromiumError(f"{method}: {answer['error']}")
                return answer.get("result", {})
            self.events.append(answer)

    def _wait_for(self, event: str) -> dict:
        for seen in self.events:
            if seen.get("method") == event:
                return seen
        while True:
            answer = self._read()
            self.events.append(answer)
            if answer.get("method") == event:
                return answer

    def _read(self) -> dict:
        deadline = time.monotonic() + self.timeout
        while b"\0" not in self._buffer:
            if not select.select([self._answers], [], [], max(0.0, deadline - time.monotonic()))[0]:
                raise ChromiumError(f"no answer from chromium in {self.timeout:g} s")
            chunk = os.read(self._answers, 1 << 16)
            if not chunk:
                raise ChromiumError(f"chromium closed the pipe (exit code {self._process.poll()})")
            self._buffer += chunk
        message, self._buffer = self._buffer.split(b"\0", 1)
        return json.loads(message)
