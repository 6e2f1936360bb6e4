"""Renders an HTML page in headless Chromium and reports what a person would see, at each of several
window widths (default 1280 and 700 CSS px: a laptop and a narrow screen): a full-page PNG, every
console message and page error, every failed resource load, for each <figure data-figure=ID>
whether its drawing loaded (an inline SVG with a non-empty box and drawn elements, or images that
decoded) and the size of its text on screen (font size times the drawing's scale), and every element that overflows its box — measured
with DOM geometry (getBoundingClientRect, scrollWidth/clientWidth), not by looking at pixels.

An element overflows when its content is wider than its box (scrollWidth > clientWidth) without
the box scrolling, or when it sticks out of its parent's box, or out of the window; content inside
a horizontally scrolling container (overflow-x auto/scroll: the page's wide tables) is allowed to
be wider, and the figures' own SVG drawing is left to gnuplot. Those scrolling containers are listed.

It speaks the DevTools protocol over --remote-debugging-pipe (JSON messages separated by NUL bytes
on file descriptors 3 and 4): no port, no websocket library, and the console, exception, log and
network events arrive as structured data instead of being scraped from Chromium's own log, which
also prints unrelated D-Bus and GPU noise on a headless server.

Usage: chromium_check.py PAGE.html SHOT.png   (writes SHOT-1280.png and SHOT-700.png; prints the result
as JSON; exit 1 if anything failed)
"""
import base64
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


# Evaluated in the page after load: elements that overflow their box (see the module docstring).
OVERFLOW_JS = r"""
JSON.stringify((() => {
  const vw = document.documentElement.clientWidth;
  const name = el => el.tagName.toLowerCase() + (el.id ? '#' + el.id : '') +
      (el.className && typeof el.className === 'string' ? '.' + el.className.trim().split(/\s+/).join('.') : '');
  const path = el => { const p = []; for (let e = el; e && e !== document.body; e = e.parentElement) p.unshift(name(e)); return p.slice(-3).join(' > '); };
  const scrolls = el => { const o = getComputedStyle(el).overflowX; return o === 'auto' || o === 'scroll'; };
  const inScroller = el => { for (let e = el.parentElement; e; e = e.parentElement) if (scrolls(e)) return true; return false; };
  const overflows = [], scrollers = [];
  for (const el of document.body.querySelectorAll('*')) {
    if (el.closest('svg')) continue;  // the drawing inside a figure: gnuplot's layout
    const cs = getComputedStyle(el);
    if (cs.display === 'none' || cs.display === 'contents') continue;
    const r = el.getBoundingClientRect();
    if (scrolls(el) && el.scrollWidth > el.clientWidth + 1) {
      scrollers.push({element: path(el), content_px: el.scrollWidth, box_px: el.clientWidth});
    }
    if (inScroller(el)) continue;
    if (!scrolls(el) && el.clientWidth > 0 && el.scrollWidth > el.clientWidth + 1 && cs.overflowX !== 'hidden') {
      overflows.push(`${path(el)}: content ${el.scrollWidth} px wide in a ${el.clientWidth} px box`);
    }
    const p = el.parentElement;
    if (p && p !== document.body && r.width > 0) {
      const pr = p.getBoundingClientRect();
      if (r.right > pr.right + 1 || r.left < pr.left - 1) {
        overflows.push(`${path(el)}: [${Math.round(r.left)}, ${Math.round(r.right)}] px sticks out of its parent's [${Math.round(pr.left)}, ${Math.round(pr.right)}]`);
      }
    }
    if (r.right > vw + 1) overflows.push(`${path(el)}: right edge ${Math.round(r.right)} px beyond the ${vw} px window`);
  }
  if (document.documentElement.scrollWidth > vw + 1) {
    overflows.push(`the page is ${document.documentElement.scrollWidth} px wide in a ${vw} px window`);
  }
  return {overflows: overflows, scrollers: scrollers, window_px: vw};
})())
"""

# Evaluated in the page: the on-screen height of each figure's text (the SVG scaled to its box).
TEXT_JS = r"""
JSON.stringify(Array.from(document.querySelectorAll('figure[data-figure]')).map(f => {
  // The font size in the drawing's units times the drawing's scale on screen.
  const h = Array.from(f.querySelectorAll('svg text')).filter(t => t.textContent.trim() !== '')
    .map(t => parseFloat(getComputedStyle(t).fontSize) * t.getScreenCTM().a).filter(x => x > 0).sort((a, b) => a - b);
  const box = f.getBoundingClientRect(), svg = f.querySelector('svg');
  const sb = svg ? svg.getBoundingClientRect() : null;
  return {id: f.dataset.figure, texts: h.length, median_font_px: h.length ? h[Math.floor(h.length / 2)] : 0,
          min_font_px: h.length ? h[0] : 0, svg_width_px: sb ? sb.width : 0, figure_width_px: box.width};
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

    def wait_for(self, method, timeout=60, since=0):
        """The first event `method` at or after events[since] (waits for it)."""
        deadline = time.time() + timeout
        for e in self.events[since:]:
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


def _view(browser, session, page, shot, width):
    """Loads `page` at `width` CSS px, measures it and writes a full-page screenshot to `shot`."""
    browser.send("Emulation.setDeviceMetricsOverride",
                 {"width": width, "height": 900, "deviceScaleFactor": 1, "mobile": False}, session=session)
    since = len(browser.events)
    browser.send("Page.navigate", {"url": "file://" + os.path.abspath(page)}, session=session)
    browser.wait_for("Page.loadEventFired", since=since)

    def evaluate(js):
        return json.loads(browser.send("Runtime.evaluate", {"expression": js, "returnByValue": True},
                                       session=session)["result"]["value"])
    figures = evaluate(FIGURES_JS)
    overflow = evaluate(OVERFLOW_JS)
    text = {t["id"]: t for t in evaluate(TEXT_JS)}
    for f in figures:
        f.update({k: v for k, v in text.get(f["id"], {}).items() if k != "id"})
    height = browser.send("Page.getLayoutMetrics", session=session)["cssContentSize"]["height"]
    browser.send("Emulation.setDeviceMetricsOverride",
                 {"width": width, "height": min(int(height) + 1, 30000), "deviceScaleFactor": 1, "mobile": False},
                 session=session)
    png = browser.send("Page.captureScreenshot", {"format": "png"}, session=session)["data"]
    with open(shot, "wb") as f:
        f.write(base64.b64decode(png))
    return {"width_px": width, "figures": figures, "overflows": overflow["overflows"],
            "scrollers": overflow["scrollers"], "page_height_px": height, "screenshot": shot}


def check(page, shot, widths=(1280, 700)):
    """Renders `page` at each width and writes full-page screenshots SHOT-<width>.png; returns the
    findings: `views` (one per width: figures, overflows, scrolling containers, page height,
    screenshot), `figures` and `page_height_px` of the first width, and `problems` (console
    messages, exceptions, log errors, failed loads, and every overflow, prefixed with the width)."""
    exe = find_chromium()
    if exe is None:
        raise FileNotFoundError("chromium is not installed (Debian package 'chromium', scripts/install-deps)")
    profile = tempfile.mkdtemp(prefix="porthole-chromium-")
    browser = Browser(exe, profile)
    stem = shot[:-4] if shot.endswith(".png") else shot
    try:
        targets = browser.send("Target.getTargets")["targetInfos"]
        page_target = next(t["targetId"] for t in targets if t["type"] == "page")
        session = browser.send("Target.attachToTarget", {"targetId": page_target, "flatten": True})["sessionId"]
        for domain in ("Page", "Runtime", "Log", "Network"):
            browser.send(f"{domain}.enable", session=session)
        browser.events.clear()
        views = [_view(browser, session, page, f"{stem}-{w}.png", w) for w in widths]
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
        for v in views:
            problems += [f"{v['width_px']} px: overflow: {o}" for o in v["overflows"]]
        return {"views": views, "figures": views[0]["figures"], "page_height_px": views[0]["page_height_px"],
                "problems": problems}
    finally:
        browser.close()
        shutil.rmtree(profile, ignore_errors=True)


if __name__ == "__main__":
    result = check(sys.argv[1], sys.argv[2])
    print(json.dumps(result, indent=2))
    bad = result["problems"] or not all(f["loaded"] for v in result["views"] for f in v["figures"])
    sys.exit(1 if bad else 0)
