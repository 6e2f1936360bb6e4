"""Renders an HTML page in headless Chromium and reports what a person would see: a full-page PNG,
every console message and page error, every failed resource load, and for each <figure
data-figure=ID> whether its drawing loaded (an inline SVG with a non-empty box and drawn elements,
or images that decoded).

It speaks the DevTools protocol over --remote-debugging-pipe (JSON messages separated by NUL bytes
on file descriptors 3 and 4): no port, no websocket library, and the console, exception, log and
network events arrive as structured data instead of being scraped from Chromium's own log, which
also prints unrelated D-Bus and GPU noise on a headless server.

Usage: chromium_check.py PAGE.html SHOT.png   (prints the result as JSON; exit 1 if anything failed)
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

CHROMIUM_FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--hide-scrollbars", "--remote-debugging-pipe",
]

# Evaluated in the page after load: one entry per figure.
FIGURES_JS = r"""
JSON.stringify(Array.from(document.querySelectorAll('figure[data-figure]')).map(f => {
  const svg = f.querySelector('svg');
  const box = svg ? svg.getBoundingClientRect() : null;
  const drawn = svg ? svg.querySelectorAll('path, polyline, polygon, rect, image, text').length : 0;
  const imgs = Array.from(f.querySelectorAll('img'));
  const imgsOk = imgs.every(i => i.complete && i.naturalWidth > 0);
  return {id: f.dataset.figure, svg: !!svg, width: box ? box.width : 0, height: box ? box.height : 0,
          drawn: drawn, images: imgs.length, images_ok: imgsOk,
          loaded: (!!svg && box.width > 100 && box.height > 100 && drawn > 20 || imgs.length > 0) && imgsOk};
}))
"""


def find_chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


class Browser:
    def __init__(self, exe, profile):
        to_chrome_r, self._to_chrome = os.pipe()
        self._from_chrome, from_chrome_w = os.pipe()
        # Chromium reads commands on fd 3 and writes replies on fd 4.
        def child_fds():  # via fresh copies, so that neither dup2 overwrites the other's source
            r, w = os.dup(to_chrome_r), os.dup(from_chrome_w)
            os.dup2(r, 3)
            os.dup2(w, 4)
        self.proc = subprocess.Popen([exe, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", "about:blank"],
                                     stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL, preexec_fn=child_fds, pass_fds=(3, 4))
        os.close(to_chrome_r)
        os.close(from_chrome_w)
        self._buf = b""
        self._next = 0
        self.events = []

    def _read(self, deadline):
        while b"\0" not in self._buf:
            if time.time() > deadline:
                raise TimeoutError("no answer from chromium")
            chunk = os.read(self._from_chrome, 1 << 20)
            if not chunk:
                raise RuntimeError("chromium closed the pipe")
            self._buf += chunk
        msg, self._buf = self._buf.split(b"\0", 1)
        return json.loads(msg)

    def send(self, method, params=None, session=None, timeout=60):
        self._next += 1
        msg = {"id": self._next, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self._to_chrome, json.dumps(msg).encode() + b"\0")
        deadline = time.time() + timeout
        while True:
            reply = self._read(deadline)
            if reply.get("id") == self._next:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})
            self.events.append(reply)

    def wait_for(self, method, timeout=60):
        deadline = time.time() + timeout
        for e in self.events:
            if e.get("method") == method:
                return e
        while True:
            e = self._read(deadline)
            self.events.append(e)
            if e.get("method") == method:
                return e

    def close(self):
        try:
            self.send("Browser.close", timeout=10)
        except Exception:
            pass
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        os.close(self._to_chrome)
        os.close(self._from_chrome)


def check(page, shot, width=1280):
    """Renders `page` and writes a full-page screenshot to `shot`; returns the findings."""
    exe = find_chromium()
    if exe is None:
        raise FileNotFoundError("chromium is not installed (Debian package 'chromium', scripts/install-deps)")
    profile = tempfile.mkdtemp(prefix="porthole-chromium-")
    browser = Browser(exe, profile)
    try:
        targets = browser.send("Target.getTargets")["targetInfos"]
        page_target = next(t["targetId"] for t in targets if t["type"] == "page")
        session = browser.send("Target.attachToTarget", {"targetId": page_target, "flatten": True})["sessionId"]
        for domain in ("Page", "Runtime", "Log", "Network"):
            browser.send(f"{domain}.enable", session=session)
        browser.send("Emulation.setDeviceMetricsOverride",
                     {"width": width, "height": 900, "deviceScaleFactor": 1, "mobile": False}, session=session)
        browser.events.clear()
        browser.send("Page.navigate", {"url": "file://" + os.path.abspath(page)}, session=session)
        browser.wait_for("Page.loadEventFired")
        figures = json.loads(browser.send("Runtime.evaluate", {"expression": FIGURES_JS, "returnByValue": True},
                                          session=session)["result"]["value"])
        height = browser.send("Page.getLayoutMetrics", session=session)["cssContentSize"]["height"]
        browser.send("Emulation.setDeviceMetricsOverride",
                     {"width": width, "height": min(int(height) + 1, 30000), "deviceScaleFactor": 1, "mobile": False},
                     session=session)
        import base64
        png = browser.send("Page.captureScreenshot", {"format": "png"}, session=session)["data"]
        with open(shot, "wb") as f:
            f.write(base64.b64decode(png))
        problems = []
        for e in browser.events:
            m, p = e.get("method"), e.get("params", {})
            if m == "Runtime.consoleAPICalled":
                text = " ".join(str(a.get("value", a.get("description", ""))) for a in p.get("args", []))
                problems.append(f"console.{p.get('type')}: {text}")
            elif m == "Runtime.exceptionThrown":
                problems.append(f"exception: {p['exceptionDetails'].get('text')}")
            elif m == "Log.entryAdded" and p["entry"]["level"] in ("error", "warning"):
                problems.append(f"log {p['entry']['level']}: {p['entry'].get('text')} {p['entry'].get('url', '')}")
            elif m == "Network.loadingFailed":
                problems.append(f"load failed: {p.get('errorText')}")
        return {"figures": figures, "problems": problems, "page_height_px": height, "screenshot": shot}
    finally:
        browser.close()
        shutil.rmtree(profile, ignore_errors=True)


if __name__ == "__main__":
    result = check(sys.argv[1], sys.argv[2])
    print(json.dumps(result, indent=2))
    bad = result["problems"] or not all(f["loaded"] for f in result["figures"])
    sys.exit(1 if bad else 0)
