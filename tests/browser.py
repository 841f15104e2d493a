"""Render an HTML page in headless Chromium and report what happened (stdlib only).

:func:`render` starts Debian's ``chromium`` with ``--remote-debugging-pipe`` and
speaks the DevTools protocol over file descriptors 3 and 4 (JSON messages ended
by a NUL byte): it opens the page in a 1280×900 viewport, collects every
uncaught exception, ``console.error`` call and Content-Security-Policy violation,
every URL the page requests, runs the given JavaScript expressions once the page
has settled, and takes a screenshot.  :func:`chromium_or_skip` skips a test,
saying why, where there is no Chromium.
"""

from __future__ import annotations

import base64
import json
import os
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

#: The only host a page may fetch from: OpenStreetMap's raster tiles.
TILE_HOSTS = ("tile.openstreetmap.org",)

FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-default-apps", "--mute-audio", "--hide-scrollbars",
         # WebGL (the map) on the CPU: headless without a GPU has no other
         "--use-angle=swiftshader", "--enable-unsafe-swiftshader")


def chromium() -> str | None:
    """Path of the Chromium executable, or None."""
    for name in ("chromium", "chromium-browser", "google-chrome"):
        p = shutil.which(name)
        if p:
            return p
    return None


def chromium_or_skip() -> str:
    """The Chromium executable; skips the calling test (with the reason) when there is none."""
    import pytest

    p = chromium()
    if p is None:
        pytest.skip("headless Chromium not found (install Debian's 'chromium'; .ci/run does): "
                    "the page cannot be rendered in a browser here")
    return p


@dataclass
class Rendered:
    """What a page did in the browser.

    Attributes
    ----------
    errors : list of str
        Uncaught exceptions, ``console.error`` messages and what the page's
        Content-Security-Policy refused.
    requests : list of str
        Every URL the page requested (the page itself included).
    values : dict
        Expression -> its value, evaluated after the page settled.
    screenshot : pathlib.Path
        PNG of the 1280×900 first screen.
    """

    errors: list = field(default_factory=list)
    requests: list = field(default_factory=list)
    values: dict = field(default_factory=dict)
    screenshot: Path | None = None

    def script_errors(self) -> list[str]:
        """The errors that are not a map tile failing to load (offline, a tile server down).

        MapLibre reports each tile it cannot fetch (naming its URL) and Plotly repeats
        it as "Map error."; those are accepted only when a tile failure was reported.
        """
        tiles = [e for e in self.errors if any(h in e for h in TILE_HOSTS)]
        return [e for e in self.errors if e not in tiles
                and not (tiles and e.startswith("Error: Map error."))]

    def foreign_requests(self, page: Path) -> list[str]:
        """Requested URLs other than the page itself, inline data and map tiles."""
        own = Path(page).resolve().as_uri()
        out = []
        for u in self.requests:
            if u == own or u.startswith(("data:", "blob:", "about:")):
                continue
            host = u.split("/")[2] if "://" in u else ""
            if not any(host == h or host.endswith("." + h) for h in TILE_HOSTS):
                out.append(u)
        return out


class _Pipe:
    """The DevTools protocol over Chromium's pipe: send commands, gather events."""

    def __init__(self, proc, w, r):
        self.proc, self.w, self.r = proc, w, r
        self.buf = b""
        self.next_id = 0
        self.events: list[dict] = []

    def _read(self, deadline: float) -> dict:
        import select

        while b"\0" not in self.buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("Chromium did not answer in time")
            ready, _, _ = select.select([self.r], [], [], left)
            if ready:
                chunk = os.read(self.r, 1 << 20)
                if not chunk:
                    raise RuntimeError("Chromium closed its DevTools pipe")
                self.buf += chunk
        msg, self.buf = self.buf.split(b"\0", 1)
        return json.loads(msg)

    def send(self, method: str, params: dict | None = None, session: str | None = None,
             timeout: float = 30.0) -> dict:
        self.next_id += 1
        msg = {"id": self.next_id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self.w, json.dumps(msg).encode() + b"\0")
        deadline = time.monotonic() + timeout
        while True:
            m = self._read(deadline)
            if m.get("id") == self.next_id:
                if "error" in m:
                    raise RuntimeError(f"{method}: {m['error']}")
                return m.get("result", {})
            self.events.append(m)

    def drain(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        try:
            while True:
                self.events.append(self._read(deadline))
        except TimeoutError:
            pass


def _evaluate(pipe: _Pipe, session: str, expr: str):
    r = pipe.send("Runtime.evaluate", {"expression": expr, "returnByValue": True,
                                       "awaitPromise": True}, session)
    if "exceptionDetails" in r:
        raise RuntimeError(f"{expr}: {r['exceptionDetails'].get('text')}")
    return r["result"].get("value")


def _open(pipe: _Pipe, url: str, width: int, height: int, offline: bool = False) -> str:
    target = pipe.send("Target.createTarget", {"url": "about:blank"})["targetId"]
    session = pipe.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
    for m in ("Runtime.enable", "Network.enable", "Page.enable", "Log.enable"):
        pipe.send(m, None, session)
    if offline:             # every network request fails, as on a phone without signal
        pipe.send("Network.emulateNetworkConditions", {"offline": True, "latency": 0, "downloadThroughput": -1,
                                                       "uploadThroughput": -1}, session)
    pipe.send("Emulation.setDeviceMetricsOverride",
              {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False}, session)
    pipe.send("Page.navigate", {"url": url}, session)
    return session


def _settle(pipe: _Pipe, session: str, ready: str, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if _evaluate(pipe, session, f"document.readyState === 'complete' && !!({ready})"):
            return
        pipe.drain(0.25)
    raise TimeoutError(f"the page never became ready ({ready})")


def _collect(events: list[dict], out: Rendered) -> None:
    for m in events:
        meth, p = m.get("method"), m.get("params", {})
        if meth == "Runtime.exceptionThrown":
            d = p["exceptionDetails"]
            out.errors.append((d.get("exception") or {}).get("description") or d.get("text", ""))
        elif meth == "Runtime.consoleAPICalled" and p.get("type") == "error":
            out.errors.append(" ".join(str(a.get("value", a.get("description", ""))) for a in p["args"]))
        elif meth == "Log.entryAdded" and "Content Security Policy" in p["entry"].get("text", ""):
            out.errors.append(p["entry"]["text"])
        elif meth == "Network.requestWillBeSent":
            out.requests.append(p["request"]["url"])


def render(page: str | Path, shot: str | Path, expressions=(), *, width: int = 1280, height: int = 900,
           ready: str = "true", settle_s: float = 2.0, timeout: float = 60.0,
           full_page: bool = False, offline: bool = False) -> Rendered:
    """Open ``page`` in headless Chromium, settle, evaluate ``expressions``, screenshot to ``shot``.

    Parameters
    ----------
    page : path
        An HTML file.
    shot : path
        Where the PNG of the first screen goes.
    expressions : sequence of str
        JavaScript expressions evaluated after the page settled (values JSON-able).
    ready : str
        A JavaScript expression that is true once the page has drawn.
    settle_s : float
        Seconds to keep listening after ``ready`` (late script errors, tile requests).
    full_page : bool
        Screenshot the whole page, not only the first screen.
    offline : bool
        Block the network (the page itself, a file, still opens).
    """
    exe = chromium()
    if exe is None:
        raise FileNotFoundError("chromium not found")
    page = Path(page).resolve()
    profile = tempfile.mkdtemp(prefix="chromium-profile-")
    to_r, to_w = os.pipe()
    from_r, from_w = os.pipe()

    def fds():        # Chromium reads commands on fd 3 and writes answers on fd 4
        import fcntl

        # copies numbered above 4 first, so neither dup2 below is a no-op (that keeps close-on-exec)
        a, b = fcntl.fcntl(to_r, fcntl.F_DUPFD, 10), fcntl.fcntl(from_w, fcntl.F_DUPFD, 10)
        os.dup2(a, 3)
        os.dup2(b, 4)

    args = [exe, *FLAGS, f"--user-data-dir={profile}", "--remote-debugging-pipe",
            f"--window-size={width},{height}", "about:blank"]
    proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, preexec_fn=fds, close_fds=False)
    os.close(to_r)
    os.close(from_w)
    pipe = _Pipe(proc, to_w, from_r)
    out = Rendered()
    try:
        session = _open(pipe, page.as_uri(), width, height, offline)
        _settle(pipe, session, ready, timeout)
        pipe.drain(settle_s)
        out.values = {e: _evaluate(pipe, session, e) for e in expressions}
        shot_args = {"format": "png"}
        if full_page:
            h = _evaluate(pipe, session, "document.documentElement.scrollHeight")
            shot_args.update(captureBeyondViewport=True,
                             clip={"x": 0, "y": 0, "width": width, "height": h, "scale": 1})
        png = pipe.send("Page.captureScreenshot", shot_args, session)["data"]
        out.screenshot = Path(shot)
        out.screenshot.write_bytes(base64.b64decode(png))
        pipe.drain(0.2)
        _collect(pipe.events, out)
        try:
            pipe.send("Browser.close", timeout=5.0)
        except (RuntimeError, TimeoutError):
            pass
    finally:
        os.close(to_w)
        os.close(from_r)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        shutil.rmtree(profile, ignore_errors=True)
    return out
