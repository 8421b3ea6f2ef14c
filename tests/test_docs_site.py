"""The documentation site checker (``scripts/check_docs_site.py``) finds what it claims to find, and
the pages embed every video as H.264 MP4 and VP9 WebM.

The checker runs on small sites written here (a page with good and broken links, images and
videos), so the tests take seconds and never build the real site (``scripts/test.sh`` builds it and
runs the checker on it). The browser tests skip where Chromium is absent.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest
from PIL import Image

from tests.conftest import load_file_module

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
CHROMIUM = shutil.which("/usr/bin/chromium") or shutil.which("chromium")
needs_chromium = pytest.mark.skipif(CHROMIUM is None, reason="no chromium on this machine (apt-get install chromium)")
_VIDEO = re.compile(r"<video\b.*?</video>", re.DOTALL)
_SOURCE = re.compile(r'<source src="(?:\.\./)?_static/([\w.-]+)" type="([\w/]+)">')


def _checker():
    return load_file_module("scripts", "check_docs_site", register=True)  # its dataclasses look their module up


check_docs_site = _checker()


def _page(title: str, body: str) -> str:
    return f"<!doctype html><html><head><title>{title}</title></head><body>{body}</body></html>"


def _video(path: Path, codec: list[str]) -> None:
    """A 1 s, 64 × 48 test video written by imageio-ffmpeg's ffmpeg."""
    subprocess.run(
        [
            imageio_ffmpeg.get_ffmpeg_exe(),
            "-hide_banner",
            "-loglevel",
            "error",
            "-y",
            "-f",
            "lavfi",
            "-i",
            "testsrc=duration=1:size=64x48:rate=10",
            "-pix_fmt",
            "yuv420p",
            *codec,
            str(path),
        ],
        check=True,
        timeout=60,
    )


@pytest.fixture
def site(tmp_path: Path) -> Path:
    """index.html: a good image, a missing image, a good video (MP4 + WebM) and one whose files are
    missing, a link to a missing anchor and to a missing page; other.html: an anchor and a script error."""
    Image.fromarray(np.full((8, 12, 3), 200, dtype=np.uint8)).save(tmp_path / "good.png")
    _video(tmp_path / "clip.mp4", ["-c:v", "libx264"])
    _video(tmp_path / "clip.webm", ["-c:v", "libvpx-vp9", "-b:v", "0", "-crf", "50"])
    text = "Some text so that the page counts as rendered. " * 3
    (tmp_path / "index.html").write_text(
        _page(
            "Index",
            f"""
        <p>{text}</p>
        <img src="good.png" alt="good"> <img src="missing.png" alt="missing">
        <video controls poster="good.png"><source src="clip.mp4" type="video/mp4">
          <source src="clip.webm" type="video/webm"></video>
        <video controls poster="good.png"><source src="gone.mp4" type="video/mp4">
          <source src="gone.webm" type="video/webm"></video>
        <a href="other.html#here">ok</a> <a href="other.html#nowhere">bad anchor</a>
        <a href="nothing.html">bad page</a> <a href="https://example.org/">external</a> <a href="#">top</a>""",
        )
    )
    (tmp_path / "other.html").write_text(
        _page(
            "Other",
            f"""
        <p id="here">{text}</p><script>undefinedFunction();</script>""",
        )
    )
    return tmp_path


def test_link_check_finds_missing_pages_files_and_anchors(site):
    report = check_docs_site.check_links(site)
    assert report.pages == 2 and report.external == 1
    problems = "\n".join(report.problems)
    assert "no anchor #nowhere in other.html" in problems
    assert "no file nothing.html" in problems
    assert "no file missing.png" in problems
    assert "no file gone.mp4" in problems and "no file gone.webm" in problems
    assert len(report.problems) == 5, report.problems
    assert "good.png" not in problems and "#here" not in problems and "clip." not in problems


def test_offline_check_finds_outside_scripts_formulas_without_mathjax_and_videos_without_poster(tmp_path):
    """The site must read offline: a script or style sheet from a CDN, formulas without the site's
    own MathJax, a video without a poster or with a missing one are each reported."""
    Image.fromarray(np.full((8, 12, 3), 200, dtype=np.uint8)).save(tmp_path / "frame.png")
    (tmp_path / "_static" / "mathjax").mkdir(parents=True)
    (tmp_path / "_static" / "mathjax" / "tex-mml-chtml.js").write_text("")
    cdn = '<script src="https://cdn.jsdelivr.net/npm/mathjax@3/es5/tex-mml-chtml.js"></script>'
    sheet = '<link rel="stylesheet" href="//fonts.example.org/a.css">'
    video = '<video controls{}><source src="frame.png" type="video/mp4"></video>'
    (tmp_path / "index.html").write_text(
        _page("A", cdn + sheet + '<span class="math notranslate">\\(x\\)</span>' + video.format(""))
    )
    (tmp_path / "good.html").write_text(
        _page(
            "B",
            '<script src="_static/mathjax/tex-mml-chtml.js"></script><div class="math">\\[y\\]</div>'
            + video.format(' poster="frame.png"')
            + '<a href="https://example.org/">a link is fine</a>',
        )
    )
    (tmp_path / "gone.html").write_text(_page("C", video.format(' poster="nothing.png"')))
    problems = check_docs_site.check_links(tmp_path).problems
    assert len(problems) == 5, problems
    text = "\n".join(problems)
    assert "index.html: <script> loads 'https://cdn.jsdelivr.net" in text and "from outside the site" in text
    assert "index.html: <link> loads '//fonts.example.org/a.css'" in text
    assert "index.html: 1 formulas but no script _static/mathjax/tex-mml-chtml.js" in text
    assert "index.html: <video> without a poster" in text
    assert "gone.html: <video poster='nothing.png'>: no file nothing.png" in text
    assert "good.html" not in text


#: a stand-in for MathJax: typesets each formula (class "math") into an mjx-container
_FAKE_MATHJAX = """
window.MathJax = {version: 'test', startup: {promise: Promise.resolve()}};
for (const el of document.querySelectorAll('.math'))
  el.appendChild(document.createElement('mjx-container'));
"""


@needs_chromium
def test_browser_check_finds_formulas_mathjax_did_not_typeset(tmp_path):
    (tmp_path / "mathjax.js").write_text(_FAKE_MATHJAX)
    text = "<p>" + "Plain text of a page. " * 5 + "</p>"
    formulas = '<span class="math">\\(a\\)</span><div class="math">\\[b\\]</div>'
    (tmp_path / "typeset.html").write_text(_page("T", text + formulas + '<script src="mathjax.js"></script>'))
    (tmp_path / "raw.html").write_text(_page("R", text + formulas))
    report = check_docs_site.check_in_browser(tmp_path, binary=CHROMIUM, timeout_s=30)
    assert report.problems == ["raw.html: MathJax typeset 0 of 2 formulas (MathJax not loaded)"]


def test_every_video_has_a_poster_that_exists():
    """Each page's <video> shows a picture before it plays (not a black box): a poster in _static,
    a frame of the video's own size (scripts/docs_posters.py)."""
    videos = 0
    for page in sorted(DOCS.rglob("*.md")):
        if "_build" in page.parts:
            continue
        for block in _VIDEO.findall(page.read_text()):
            videos += 1
            poster = re.search(r'<video\b[^>]*\bposter="(?:\.\./)?_static/([\w.-]+)"', block)
            assert poster, f"{page.relative_to(ROOT)}: <video> without a poster"
            assert (DOCS / "_static" / poster[1]).is_file(), (page, poster[1])
            mp4 = DOCS / "_static" / _SOURCE.findall(block)[0][0]
            frames = imageio_ffmpeg.read_frames(str(mp4))
            size = tuple(next(frames)["size"])
            frames.close()
            with Image.open(DOCS / "_static" / poster[1]) as img:
                assert img.size == size, (page, poster[1], img.size, size)
    assert videos >= 6


def test_link_check_passes_a_clean_page(tmp_path):
    (tmp_path / "index.html").write_text(_page("A", '<h1 id="top">A</h1><a href="#top">top</a><a href="sub/">sub</a>'))
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "index.html").write_text(_page("B", '<a href="../index.html#top">back</a>'))
    report = check_docs_site.check_links(tmp_path)
    assert report.problems == [] and report.internal == 3


@needs_chromium
def test_browser_check_finds_broken_image_video_and_script_error(site):
    report = check_docs_site.check_in_browser(site, binary=CHROMIUM, timeout_s=30)
    assert report.pages == 2 and report.images == 2 and report.videos == 2 and report.sources == 4
    problems = "\n".join(report.problems)
    assert "image did not load" in problems and "missing.png" in problems and "good.png" not in problems
    assert "video did not load" in problems and "gone.mp4" in problems
    assert "gone.mp4: HTTP 404" in problems and "gone.webm: HTTP 404" in problems
    assert "clip.mp4" not in problems and "clip.webm" not in problems
    assert "other.html: JavaScript exception" in problems and "undefinedFunction" in problems
    assert report.playable.get("video/webm") == 1  # the WebM loaded on its own


@needs_chromium
def test_browser_check_command_exit_status(site, tmp_path_factory):
    clean = tmp_path_factory.mktemp("clean")
    (clean / "index.html").write_text(_page("Clean", "<p>" + "Plain text of a page. " * 5 + "</p>"))
    script = ROOT / "scripts" / "check_docs_site.py"
    ok = subprocess.run(
        [str(ROOT / ".venv/bin/python"), str(script), str(clean), "--chromium", CHROMIUM],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert ok.returncode == 0, ok.stderr
    assert "1 pages" in ok.stdout and "0 problems" in ok.stdout
    bad = subprocess.run(
        [str(ROOT / ".venv/bin/python"), str(script), str(site), "--chromium", CHROMIUM],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert bad.returncode == 1 and bad.stderr.count("error: ") >= 5
    missing = subprocess.run(
        [str(ROOT / ".venv/bin/python"), str(script), str(clean / "nope")], capture_output=True, text=True, timeout=60
    )
    assert missing.returncode == 2 and missing.stderr.startswith("error: site:")


def _embedded_videos() -> list[tuple[Path, list[tuple[str, str]]]]:
    found = []
    for page in sorted(DOCS.rglob("*.md")):
        if "_build" in page.parts:
            continue
        for block in _VIDEO.findall(page.read_text()):
            found.append((page, _SOURCE.findall(block)))
    return found


def test_every_video_is_embedded_as_mp4_and_webm():
    videos = _embedded_videos()
    assert len(videos) >= 6
    for page, sources in videos:
        types = [t for _, t in sources]
        assert types == ["video/mp4", "video/webm"], (page, sources)
        stems = {Path(name).stem for name, _ in sources}
        assert len(stems) == 1, (page, sources)
        for name, _ in sources:
            assert (DOCS / "_static" / name).is_file(), (page, name)


def test_video_files_are_h264_mp4_and_vp9_webm():
    for mp4 in sorted((DOCS / "_static").glob("*.mp4")):
        head = mp4.read_bytes()[:4096]
        assert head[4:8] == b"ftyp" and b"avc1" in mp4.read_bytes(), mp4
        webm = mp4.with_suffix(".webm")
        assert webm.is_file(), f"{mp4.name} has no WebM beside it (scripts/docs_webm.py)"
        data = webm.read_bytes()[:4096]
        assert data[:4] == b"\x1a\x45\xdf\xa3" and b"webm" in data and b"V_VP9" in data, webm
        assert webm.stat().st_size < 3 * mp4.stat().st_size, f"{webm.name} is large; re-encode with a higher --crf"
