"""Check the built documentation site: internal links and anchors, and every page in headless Chromium.

    .venv/bin/python scripts/check_docs_site.py [docs/_build/html] [--chromium /usr/bin/chromium]
    .venv/bin/python scripts/check_docs_site.py --links-only          # no browser

Two checks, over every ``*.html`` page of the build folder:

1. **Links** (static, no browser): every ``href``/``src`` of ``<a>``, ``<img>``, ``<source>``,
   ``<video>``, ``<link>``, ``<script>`` that is internal (no scheme, not ``mailto:``) names a file
   that exists in the build; a ``#fragment`` on a page names an ``id`` (or ``name``) on that page.
   External links (``http(s)://``) are counted, not followed (there is no internet). The site
   must read offline: no page loads a script or a style sheet from outside the site, a page with
   formulas loads the site's own MathJax (``_static/mathjax/tex-mml-chtml.js``, vendored by
   ``docs/conf.py``), and every ``<video>`` has a ``poster`` (a picture shown before it plays)
   that exists.
2. **Browser**: the folder is served over HTTP on 127.0.0.1 (Python's ``http.server``, which sets
   the MIME type from the extension) and each page is opened in headless Chromium
   (``--headless --no-sandbox``), driven through the DevTools protocol over a websocket
   (``websockets``, in the docs extra). After the load event it checks that the page rendered
   (a non-empty body text and title), that every ``<img>`` loaded (``complete`` and
   ``naturalWidth > 0``; lazy images are switched to eager first), that every ``<video>`` reached
   ``readyState ≥ 1`` (metadata) with a finite ``duration > 0``, that each of its ``<source>``
   answers HTTP 200 with the ``Content-Type`` its ``type`` attribute states and, when the browser
   says it can play that type, loads on its own in a detached ``<video>`` (so the WebM is checked
   even where the MP4 was chosen), that the browser can play at least one source, that MathJax
   typeset the page's formulas (one ``mjx-container`` per formula), and that no JavaScript
   exception was thrown. The browser's viewport is :data:`VIEWPORT_WIDTH_PX` (1 280 px) wide, a
   laptop screen: no claim table of the reproduction reports (``<table class="repro-claims">``,
   written by ``magsail report render``) may overflow there, neither its scrolling wrapper (the
   table wider than the text column) nor the window (its right edge beyond the viewport).

Sphinx does not delete the pages of a removed document from the build folder, and they are checked
too: remove ``docs/_build`` for a check of the current pages only (CI builds into a fresh clone).

Exit status: 0 every check passed; 1 a check failed (each failure on one line of stderr);
2 invalid input (no such folder, no Chromium where the browser check was asked for).
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import http.server
import itertools
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from html.parser import HTMLParser
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urlsplit

from websockets.sync.client import connect

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_SITE = ROOT / "docs" / "_build" / "html"
DEFAULT_CHROMIUM = "/usr/bin/chromium"
_LINK_ATTRS = {
    "a": ("href",),
    "img": ("src",),
    "source": ("src",),
    "video": ("src", "poster"),
    "link": ("href",),
    "script": ("src",),
    "iframe": ("src",),
}
_DEVTOOLS_URL = re.compile(r"DevTools listening on (ws://\S+)")
#: the browser window every page is checked in [CSS px] (the claim tables must fit its width)
VIEWPORT_WIDTH_PX = 1280
VIEWPORT_HEIGHT_PX = 900
#: the CSS selector of the reproduction reports' claim tables (``magsail_mj.report.render``)
CLAIM_TABLE_SELECTOR = "table.repro-claims"

# Runs in each page after the page check; the widths of every claim table and of what holds it.
CLAIM_TABLE_JS = (
    r"""
JSON.stringify(Array.from(document.querySelectorAll('%s')).map(table => {
  const holder = table.parentElement;
  return {table: table.scrollWidth, holderClient: holder.clientWidth, holderScroll: holder.scrollWidth,
          right: table.getBoundingClientRect().right, viewport: document.documentElement.clientWidth,
          rows: table.rows.length};
}))
"""
    % CLAIM_TABLE_SELECTOR
)

# Runs in each page after its load event; returns a JSON text (see the module docstring).
PAGE_CHECK_JS = r"""
(async () => {
  const wait = (target, events, ms) => new Promise(done => {
    const timer = setTimeout(done, ms);
    for (const e of events) target.addEventListener(e, () => { clearTimeout(timer); done(); }, {once: true});
  });
  const out = {title: document.title, textLength: document.body ? document.body.innerText.trim().length : 0,
               images: [], videos: []};
  const images = Array.from(document.images);
  for (const img of images) if (img.loading === 'lazy') img.loading = 'eager';
  await Promise.all(images.filter(img => !img.complete).map(img => wait(img, ['load', 'error'], 10000)));
  for (const img of images) out.images.push({src: img.currentSrc || img.src,
                                             ok: img.complete && img.naturalWidth > 0});
  const formulas = document.querySelectorAll('.math').length;
  if (formulas && window.MathJax && MathJax.startup && MathJax.startup.promise)
    await Promise.race([MathJax.startup.promise, new Promise(done => setTimeout(done, 15000))]);
  out.math = {formulas, typeset: document.querySelectorAll('mjx-container').length,
              mathjax: Boolean(window.MathJax && MathJax.version)};
  for (const video of document.querySelectorAll('video')) {
    if (video.readyState < 1) {
      // a failed <source> fires its error event on itself, not on the video: wait for metadata,
      // an error of the video, or an error of its last source (then no source is left)
      const all = video.querySelectorAll('source');
      let lastFailed = false;
      if (all.length) all[all.length - 1].addEventListener('error', () => { lastFailed = true; }, {once: true});
      video.preload = 'metadata';
      video.load();
      const until = Date.now() + 15000;
      while (video.readyState < 1 && !video.error && !lastFailed && Date.now() < until)
        await new Promise(done => setTimeout(done, 50));
    }
    const sources = [];
    for (const source of video.querySelectorAll('source')) {
      let status = 0, contentType = '';
      try {
        const response = await fetch(source.src, {method: 'HEAD'});
        status = response.status;
        contentType = response.headers.get('content-type') || '';
      } catch (err) { contentType = String(err); }
      const canPlay = source.type ? video.canPlayType(source.type) : '';
      let probeState = -1, probeDuration = -1, probeError = null;
      if (canPlay) {  // load this source alone in a detached element
        const probe = document.createElement('video');
        probe.preload = 'metadata';
        probe.muted = true;
        probe.src = source.src;
        await wait(probe, ['loadedmetadata', 'error'], 15000);
        probeState = probe.readyState;
        probeDuration = Number.isFinite(probe.duration) ? probe.duration : -1;
        probeError = probe.error ? probe.error.code : null;
        probe.removeAttribute('src');
        probe.load();
      }
      sources.push({src: source.src, type: source.type, status, contentType, canPlay,
                    readyState: probeState, duration: probeDuration, error: probeError});
    }
    out.videos.push({currentSrc: video.currentSrc, readyState: video.readyState,
                     duration: Number.isFinite(video.duration) ? video.duration : -1,
                     error: video.error ? video.error.code : null, sources});
  }
  return JSON.stringify(out);
})()
"""


# --------------------------------------------------------------------------- static link check


class _PageParser(HTMLParser):
    """Collects the ids/names of a page and its link targets ``(tag, attribute, value)``."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.anchors: set[str] = set()
        self.links: list[tuple[str, str, str]] = []
        self.loads: list[tuple[str, str]] = []  # (tag, URL) of scripts and style sheets
        self.posters: list[str | None] = []  # each <video>'s poster (None: none)
        self.formulas = 0  # elements of class "math" (Sphinx's MathJax markup)

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        """Record ``id``/``name`` anchors, the link attributes of ``_LINK_ATTRS``, the scripts and
        style sheets loaded, the videos' posters and the formulas."""
        values = {k: v for k, v in attrs if v is not None}
        if tag == "script" and "src" in values:
            self.loads.append((tag, values["src"]))
        if tag == "link" and "stylesheet" in values.get("rel", "").split() and "href" in values:
            self.loads.append((tag, values["href"]))
        if tag == "video":
            self.posters.append(values.get("poster") or None)
        if "math" in values.get("class", "").split():
            self.formulas += 1
        for key in ("id", "name"):
            if key in values and (key == "id" or tag == "a"):
                self.anchors.add(values[key])
        for attr in _LINK_ATTRS.get(tag, ()):
            if attr in values:
                self.links.append((tag, attr, values[attr]))


@dataclass
class LinkReport:
    """The result of :func:`check_links`: pages read, internal links checked, external links
    counted (not followed), and one message per broken link."""

    pages: int = 0
    internal: int = 0
    external: int = 0
    problems: list[str] = field(default_factory=list)


def _parse(page: Path) -> _PageParser:
    parser = _PageParser()
    parser.feed(page.read_text(encoding="utf-8", errors="replace"))
    return parser


def _offline_problems(where: str, parser: _PageParser) -> list[str]:
    """A script or style sheet from outside the site, formulas without the site's own MathJax, a
    video without a poster (whether the files exist is the link check's)."""
    problems = [
        f"{where}: <{tag}> loads {url!r} from outside the site (the site must read offline)"
        for tag, url in parser.loads
        if urlsplit(url).scheme or url.startswith("//")
    ]
    if parser.formulas and not any(
        tag == "script" and urlsplit(url).path.endswith("mathjax/tex-mml-chtml.js") for tag, url in parser.loads
    ):
        problems.append(f"{where}: {parser.formulas} formulas but no script _static/mathjax/tex-mml-chtml.js")
    problems += [f"{where}: <video> without a poster (a black box until it plays)" for p in parser.posters if not p]
    return problems


def check_links(site: Path) -> LinkReport:
    """Check every internal link and anchor of the HTML pages below ``site`` (see the module docstring)."""
    site = site.resolve()
    report = LinkReport()
    parsed = {page: _parse(page) for page in sorted(site.rglob("*.html"))}
    report.pages = len(parsed)
    for page, parser in parsed.items():
        where = page.relative_to(site)
        report.problems += _offline_problems(str(where), parser)
        for tag, attr, value in parser.links:
            parts = urlsplit(value)
            if parts.scheme or value.startswith("//"):
                report.external += parts.scheme in ("http", "https") or value.startswith("//")
                continue
            report.internal += 1
            target = page if not parts.path else (page.parent / unquote(parts.path)).resolve()
            if target.is_dir():
                target = target / "index.html"
            if site not in target.parents and target != site:
                report.problems.append(f"{where}: <{tag} {attr}={value!r}> points outside the site")
                continue
            if not target.is_file():
                report.problems.append(f"{where}: <{tag} {attr}={value!r}>: no file {target.relative_to(site)}")
                continue
            fragment = unquote(parts.fragment)
            if fragment and target.suffix == ".html":
                anchors = (parsed.get(target) or _parse(target)).anchors
                if fragment not in anchors:
                    report.problems.append(
                        f"{where}: <{tag} {attr}={value!r}>: no anchor #{fragment} in {target.relative_to(site)}"
                    )
    return report


# --------------------------------------------------------------------------- browser check


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    """Static files of the site, without a log line per request."""

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - the base class's name
        """Silence the request log."""


@contextlib.contextmanager
def serve(site: Path) -> Iterator[str]:
    """Serve ``site`` on 127.0.0.1 (a free port) in a thread; yields the base URL."""
    handler = functools.partial(_QuietHandler, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()


@contextlib.contextmanager
def chromium(binary: str, *, timeout_s: float) -> Iterator[str]:
    """Start headless Chromium with a DevTools port; yields the browser's websocket URL."""
    profile = tempfile.mkdtemp(prefix="magsail_docs_chromium_")
    cmd = [
        binary,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--no-first-run",
        "--no-default-browser-check",
        "--mute-audio",
        "--autoplay-policy=no-user-gesture-required",
        f"--user-data-dir={profile}",
        "--remote-debugging-port=0",
        "about:blank",
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        url = _devtools_url(proc, timeout_s=timeout_s)
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        shutil.rmtree(profile, ignore_errors=True)


def _devtools_url(proc: subprocess.Popen, *, timeout_s: float) -> str:
    """The ``ws://`` URL Chromium prints on stderr once its DevTools port listens."""
    deadline = time.monotonic() + timeout_s
    seen: list[str] = []
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        if not line:
            if proc.poll() is not None:
                break
            continue
        seen.append(line.strip())
        match = _DEVTOOLS_URL.search(line)
        if match:
            threading.Thread(target=_drain, args=(proc.stderr,), daemon=True).start()
            return match.group(1)
    raise RuntimeError("chromium did not open its DevTools port: " + " | ".join(seen[-5:]))


def _drain(stream: Any) -> None:
    for _ in stream:
        pass


class DevTools:
    """A minimal client of the Chrome DevTools protocol (one websocket, flattened sessions)."""

    def __init__(self, ws: Any, *, timeout_s: float) -> None:
        self.ws = ws
        self.timeout_s = timeout_s
        self.ids = itertools.count(1)
        self.events: list[dict[str, Any]] = []

    def call(
        self,
        method: str,
        params: dict[str, Any] | None = None,
        *,
        session: str | None = None,
        timeout_s: float | None = None,
    ) -> dict[str, Any]:
        """Send one command and return its ``result`` (events that arrive meanwhile are kept)."""
        msg_id = next(self.ids)
        message: dict[str, Any] = {"id": msg_id, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = session
        self.ws.send(json.dumps(message))
        deadline = time.monotonic() + (timeout_s or self.timeout_s)
        while True:
            reply = json.loads(self.ws.recv(timeout=max(0.01, deadline - time.monotonic())))
            if reply.get("id") == msg_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})
            self.events.append(reply)

    def wait_event(self, method: str, *, session: str, timeout_s: float) -> dict[str, Any] | None:
        """The first event ``method`` of ``session`` (kept or arriving within ``timeout_s``), else None."""
        deadline = time.monotonic() + timeout_s
        while True:
            for k, event in enumerate(self.events):
                if event.get("method") == method and event.get("sessionId") == session:
                    return self.events.pop(k)
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            try:
                self.events.append(json.loads(self.ws.recv(timeout=left)))
            except TimeoutError:
                return None


def _page_problems(where: str, result: dict[str, Any], exceptions: list[str]) -> list[str]:
    """One message per failed check of a page's :data:`PAGE_CHECK_JS` result."""
    problems = [f"{where}: JavaScript exception: {text}" for text in exceptions]
    if not result.get("title") or result.get("textLength", 0) < 20:
        problems.append(
            f"{where}: the page did not render (title {result.get('title')!r}, "
            f"{result.get('textLength', 0)} characters of text)"
        )
    problems += [f"{where}: image did not load: {img['src']}" for img in result.get("images", []) if not img["ok"]]
    math = result.get("math") or {}
    if math.get("formulas") and math.get("typeset", 0) < math["formulas"]:
        problems.append(
            f"{where}: MathJax typeset {math.get('typeset', 0)} of {math['formulas']} formulas "
            f"(MathJax {'loaded' if math.get('mathjax') else 'not loaded'})"
        )
    for video in result.get("videos", []):
        name = video["currentSrc"] or (video["sources"][0]["src"] if video["sources"] else "<video>")
        if video["readyState"] < 1 or not video["duration"] > 0 or video["error"]:
            problems.append(
                f"{where}: video did not load: {name} (readyState {video['readyState']}, "
                f"duration {video['duration']}, error {video['error']})"
            )
        if video["sources"] and not any(source["canPlay"] for source in video["sources"]):
            problems.append(f"{where}: the browser can play none of the sources of {name}")
        for source in video["sources"]:
            expected = source["type"].split(";")[0].strip()
            if source["canPlay"] and (source["readyState"] < 1 or not source["duration"] > 0 or source["error"]):
                problems.append(
                    f"{where}: video source {source['src']} did not load on its own (readyState "
                    f"{source['readyState']}, duration {source['duration']}, error {source['error']})"
                )
            if source["status"] != 200:
                problems.append(f"{where}: video source {source['src']}: HTTP {source['status']}")
            elif expected and source["contentType"].split(";")[0].strip() != expected:
                problems.append(
                    f"{where}: video source {source['src']}: served as {source['contentType']!r}, "
                    f"the page says {expected!r}"
                )
    return problems


def claim_table_problems(where: str, tables: list[dict[str, float]]) -> list[str]:
    """One message per claim table of :data:`CLAIM_TABLE_JS` that overflows horizontally: wider
    than the element that holds it (which then scrolls) or reaching past the viewport (half a pixel
    of rounding allowed)."""
    problems = []
    for k, t in enumerate(tables, start=1):
        if t["holderScroll"] > t["holderClient"] or t["table"] > t["holderClient"]:
            problems.append(
                f"{where}: claim table {k} ({t['rows']} rows) is {t['table']} px wide in a column of "
                f"{t['holderClient']} px: it scrolls horizontally at a {VIEWPORT_WIDTH_PX} px viewport"
            )
        elif t["right"] > t["viewport"] + 0.5:
            problems.append(
                f"{where}: claim table {k} ends at {t['right']:.0f} px, past the {t['viewport']} px "
                f"of the {VIEWPORT_WIDTH_PX} px viewport"
            )
    return problems


@dataclass
class BrowserReport:
    """The result of :func:`check_in_browser`: pages opened, images and videos seen, and one
    message per failed check."""

    pages: int = 0
    images: int = 0
    videos: int = 0
    sources: int = 0
    claim_tables: int = 0
    playable: dict[str, int] = field(default_factory=dict)
    problems: list[str] = field(default_factory=list)


def check_in_browser(
    site: Path, *, binary: str = DEFAULT_CHROMIUM, timeout_s: float = 30.0, pages: list[Path] | None = None
) -> BrowserReport:
    """Open every page of ``site`` (or ``pages``) in headless Chromium and check it (module docstring)."""
    site = site.resolve()
    report = BrowserReport()
    todo = pages if pages is not None else sorted(site.rglob("*.html"))
    with (
        serve(site) as base,
        chromium(binary, timeout_s=timeout_s) as ws_url,
        connect(ws_url, max_size=None, open_timeout=timeout_s) as ws,
    ):
        tools = DevTools(ws, timeout_s=timeout_s)
        target = tools.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = tools.call("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        for domain in ("Page", "Runtime"):
            tools.call(f"{domain}.enable", session=session)
        viewport = {"width": VIEWPORT_WIDTH_PX, "height": VIEWPORT_HEIGHT_PX, "deviceScaleFactor": 1, "mobile": False}
        tools.call("Emulation.setDeviceMetricsOverride", viewport, session=session)
        for page in todo:
            where = str(page.relative_to(site))
            report.pages += 1
            result, exceptions = _open(tools, session, base + where, timeout_s=timeout_s)
            if result:
                tables = _claim_tables(tools, session)
                report.claim_tables += len(tables)
                report.problems += claim_table_problems(where, tables)
            report.images += len(result.get("images", []))
            report.videos += len(result.get("videos", []))
            for video in result.get("videos", []):
                report.sources += len(video["sources"])
                for source in video["sources"]:
                    if source["canPlay"] and source["readyState"] >= 1:
                        report.playable[source["type"]] = report.playable.get(source["type"], 0) + 1
            report.problems += _page_problems(where, result, exceptions)
    return report


def _claim_tables(tools: DevTools, session: str) -> list[dict[str, float]]:
    """The widths of the open page's claim tables (:data:`CLAIM_TABLE_JS`)."""
    value = tools.call("Runtime.evaluate", {"expression": CLAIM_TABLE_JS, "returnByValue": True}, session=session)
    return json.loads(value["result"]["value"])


def _open(tools: DevTools, session: str, url: str, *, timeout_s: float) -> tuple[dict[str, Any], list[str]]:
    """Navigate to ``url``, wait for its load event, run :data:`PAGE_CHECK_JS`; returns its result
    and the texts of JavaScript exceptions thrown meanwhile."""
    tools.events.clear()
    nav = tools.call("Page.navigate", {"url": url}, session=session)
    if nav.get("errorText"):
        return {}, [f"navigation failed: {nav['errorText']}"]
    if tools.wait_event("Page.loadEventFired", session=session, timeout_s=timeout_s) is None:
        return {}, [f"no load event within {timeout_s:g} s"]
    value = tools.call(
        "Runtime.evaluate",
        {"expression": PAGE_CHECK_JS, "awaitPromise": True, "returnByValue": True},
        session=session,
        timeout_s=timeout_s + 30,
    )
    if "exceptionDetails" in value:
        return {}, [f"the page check failed: {value['exceptionDetails'].get('text')}"]
    exceptions = [
        e["params"]["exceptionDetails"].get("exception", {}).get("description")
        or e["params"]["exceptionDetails"].get("text", "")
        for e in tools.events
        if e.get("method") == "Runtime.exceptionThrown"
    ]
    return json.loads(value["result"]["value"]), exceptions


# --------------------------------------------------------------------------- command line


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("site", nargs="?", default=str(DEFAULT_SITE), help="built HTML folder (default docs/_build/html)")
    ap.add_argument(
        "--chromium",
        default=os.environ.get("CHROMIUM", DEFAULT_CHROMIUM),
        help="Chromium binary (default $CHROMIUM, else /usr/bin/chromium)",
    )
    ap.add_argument("--links-only", action="store_true", help="only the static link check (no browser)")
    ap.add_argument("--timeout-s", type=float, default=30.0, help="seconds to wait for a page or a video (default 30)")
    args = ap.parse_args(argv)
    site = Path(args.site)
    if not (site / "index.html").is_file():
        print(
            f"error: site: no index.html in {str(site)!r} (build the docs first: bash scripts/build_docs.sh)",
            file=sys.stderr,
        )
        return 2
    if not args.links_only and shutil.which(args.chromium) is None:
        print(
            f"error: --chromium: no browser at {args.chromium!r} (apt-get install chromium, or --links-only)",
            file=sys.stderr,
        )
        return 2
    t0 = time.perf_counter()
    links = check_links(site)
    problems = list(links.problems)
    line = (
        f"links: {links.pages} pages, {links.internal} internal links and anchors checked, "
        f"{links.external} external not followed, {len(links.problems)} broken"
    )
    if not args.links_only:
        browser = check_in_browser(site, binary=args.chromium, timeout_s=args.timeout_s)
        problems += browser.problems
        line += (
            f"; browser: {browser.pages} pages, {browser.images} images, {browser.videos} videos "
            f"({browser.sources} sources; loaded on their own: "
            f"{', '.join(f'{n} {t}' for t, n in sorted(browser.playable.items())) or 'none'}), "
            f"{browser.claim_tables} claim tables at {VIEWPORT_WIDTH_PX} px, {len(browser.problems)} problems"
        )
    for problem in problems:
        print(f"error: {problem}", file=sys.stderr)
    print(f"{line} ({time.perf_counter() - t0:.0f} s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
