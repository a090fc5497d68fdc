"""The documentation site as a reader meets it: built once (``-W``, the gallery's scripts not
executed), its landing page leads to Getting started in one click, every page's top bar
holds the five sections in order and its footer the copyright, every page with sections
has its own contents beside it; in Debian's headless Chromium (driven by Playwright, as
tests/test_notebook_browser.py does), no page is wider than the window, nothing sticks out
of the content column except inside a box that scrolls, and no text lies over other text.
Getting started shows the README's own commands, spec and Python (CI installs the docs
extra and chromium and sets EYELAB_REQUIRE_DOCS and EYELAB_REQUIRE_BROWSER)."""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
START = ROOT / "docs" / "getting-started.md"

#: The top bar's sections, in order (docs/index.md's root toctree).
SECTIONS = ["Getting started", "User guide", "Gallery", "Reference", "Background"]
COPYRIGHT = "© Copyright 2026, the eyelab maintainers."

HAVE_DOCS = importlib.util.find_spec("sphinx") is not None
needs_docs = pytest.mark.skipif(not HAVE_DOCS and not os.environ.get("EYELAB_REQUIRE_DOCS"),
                                reason="the docs extra is not installed (CI sets "
                                "EYELAB_REQUIRE_DOCS)")

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
HAVE_BROWSER = CHROMIUM is not None and importlib.util.find_spec("playwright") is not None
needs_browser = pytest.mark.skipif(not HAVE_BROWSER
                                   and not os.environ.get("EYELAB_REQUIRE_BROWSER"),
                                   reason="needs chromium and playwright (CI sets "
                                   "EYELAB_REQUIRE_BROWSER)")
#: How Chromium is started here (tests/test_notebook_browser.py): headless, and without the
#: background services whose connections this machine's closed network refuses.
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]
WINDOW = {"width": 1280, "height": 800}
#: The pages the browser opens: the landing page, Getting started, the spec reference (its
#: [eye] table is the widest), and a guide page with long TOML comments.
BROWSED = ["index", "getting-started", "reference/spec", "guide/lenslets"]


def _blocks(text: str, lang: str) -> list:
    return re.findall(rf"^```{lang}\n(.*?)^```", text, flags=re.S | re.M)


def test_getting_started_shows_the_readmes_commands_spec_and_python():
    """The install line, the demo, the first spec with its commands, and the Python with
    what it prints, are the README's, character for character (tests/test_docs.py runs
    the README's)."""
    page = START.read_text()
    readme_bash, page_bash = _blocks(README, "bash"), _blocks(page, "bash")
    install = readme_bash[0].strip().splitlines()
    assert [b.strip() for b in page_bash[:2]] == install
    assert page_bash[2] == readme_bash[1]
    assert _blocks(page, "toml") == [(ROOT / "examples" / "first.toml").read_text()]
    assert _blocks(page, "python") == _blocks(README, "python")
    assert _blocks(page, "text") == _blocks(README, "text")[:1]
    assert re.search(r"This is\s+`examples/first\.toml`", page)
    for picture in ("demo.png", "first.png", "naked.png"):
        assert f"](gallery/{picture})" in page, picture


# -- the built site -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site, built once from docs/ with warnings as errors (the gallery's pages, not its
    scripts' runs: tests/test_docs.py builds it all)."""
    out = tmp_path_factory.mktemp("site") / "html"
    r = subprocess.run([sys.executable, "-P", "-m", "sphinx", "-W", "--keep-going", "-q",
                        "-b", "html", "-D", "plot_gallery=0", str(ROOT / "docs"), str(out)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    return out


def _pages(site: Path) -> dict:
    """{page name: its parsed HTML} for every page made from a source file (not the
    search page, the index of terms, or the theme's own files)."""
    from bs4 import BeautifulSoup

    skip = {"search", "genindex", "py-modindex"}
    out = {}
    for f in sorted(site.rglob("*.html")):
        name = f.relative_to(site).with_suffix("").as_posix()
        if name not in skip and not name.startswith(("_static/", "_sources/")):
            out[name] = BeautifulSoup(f.read_text(), "html.parser")
    return out


@pytest.fixture(scope="module")
def pages(site) -> dict:
    return _pages(site)


@needs_docs
def test_the_landing_page_leads_to_getting_started_in_one_click(pages):
    article = pages["index"].select_one("article.bd-article")
    links = [a["href"] for a in article.select("a[href]")]
    assert "getting-started.html" in links, links
    for target in ("guide/index.html", "gallery_examples/index.html", "reference/index.html",
                   "background.html"):
        assert target in links, (target, links)
    assert article.select_one("img[src$='demo.png']") is not None


@needs_docs
def test_every_page_has_the_top_bar_and_the_footer(pages):
    assert len(pages) >= 30, sorted(pages)
    for name, soup in pages.items():
        bar = soup.select_one(".bd-header ul.navbar-nav")
        assert bar is not None, name
        assert [a.get_text(" ", strip=True) for a in bar.select("a.nav-link")] == SECTIONS, name
        footer = soup.select_one("footer.bd-footer")
        assert footer is not None and COPYRIGHT in footer.get_text(" ", strip=True), name


@needs_docs
def test_every_page_with_sections_has_its_own_contents(pages):
    """A page with sections (h2 headings in its article) shows the page's contents beside
    it, one link per section; a page without needs none."""
    for name, soup in pages.items():
        article = soup.select_one("article.bd-article")
        assert article is not None, name
        sections = [h.parent.get("id") for h in article.select("section > h2")]
        if not sections:
            continue
        toc = soup.select_one("nav.page-toc")
        assert toc is not None, name
        targets = {a["href"].split("#")[-1] for a in toc.select("a[href]")}
        missing = [s for s in sections if s not in targets]
        assert not missing, (name, missing)


#: In the page: what sticks out of the content column (not inside a box that scrolls), the
#: document's width, and pairs of text boxes (one per line of an inline element) that
#: overlap by more than 1 px, neither inside the other.
_LAYOUT_JS = """() => {
  const col = document.querySelector('article.bd-article');
  const right = col.getBoundingClientRect().right;
  const scrolls = (e) => {
    const s = getComputedStyle(e);
    return ['auto', 'scroll'].includes(s.overflowX) && e.scrollWidth > e.clientWidth;
  };
  const inScroller = (e) => {
    for (let p = e.parentElement; p && p !== col; p = p.parentElement) {
      if (scrolls(p)) return true;
    }
    return false;
  };
  const shown = (e) => {
    const s = getComputedStyle(e);
    return s.display !== 'none' && s.visibility !== 'hidden' && s.opacity !== '0';
  };
  const name = (e) => e.tagName.toLowerCase() + (e.id ? '#' + e.id : '') + ' "' +
    (e.textContent || '').trim().slice(0, 40) + '"';
  const wide = [];
  for (const e of col.querySelectorAll('*')) {
    const r = e.getBoundingClientRect();
    if (r.width > 0 && shown(e) && r.right > right + 1 && !inScroller(e)) {
      wide.push(name(e) + ' right ' + Math.round(r.right) + ' > ' + Math.round(right));
    }
  }
  const sel = 'p, li, td, th, code, pre span, h1, h2, h3, h4, h5, h6, a';
  const boxes = [];
  for (const e of col.querySelectorAll(sel)) {
    if (!shown(e) || !(e.textContent || '').trim()) continue;
    for (const r of e.getClientRects()) {
      if (r.width > 0 && r.height > 0) boxes.push([e, r]);
    }
  }
  const over = [];
  for (let i = 0; i < boxes.length && over.length < 10; i++) {
    const [a, ra] = boxes[i];
    for (let j = i + 1; j < boxes.length; j++) {
      const [b, rb] = boxes[j];
      const ox = Math.min(ra.right, rb.right) - Math.max(ra.left, rb.left);
      const oy = Math.min(ra.bottom, rb.bottom) - Math.max(ra.top, rb.top);
      if (ox > 1 && oy > 1 && a !== b && !a.contains(b) && !b.contains(a)) {
        over.push(name(a) + ' over ' + name(b));
        if (over.length >= 10) break;
      }
    }
  }
  return {wide: wide.slice(0, 10), width: document.documentElement.scrollWidth,
          boxes: boxes.length, over: over};
}"""


@needs_docs
@needs_browser
def test_pages_fit_the_window_and_no_text_lies_over_text(site, tmp_path):
    """At 1280 x 800, each of :data:`BROWSED` is no wider than the window, nothing in its
    content column reaches past the column's right edge unless it is inside a box that
    scrolls (a wide table, a long code line), and no two text boxes overlap; a screenshot
    of each is kept in the test's folder."""
    from playwright.sync_api import sync_playwright

    found = {}
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport=WINDOW)
            for name in BROWSED:
                page.goto((site / f"{name}.html").as_uri(), wait_until="load")
                page.screenshot(path=str(tmp_path / f"{name.replace('/', '-')}.png"),
                                full_page=True)
                found[name] = page.evaluate(_LAYOUT_JS)
        finally:
            browser.close()
    for name, got in found.items():
        assert got["boxes"] > 10, (name, got)
        assert got["width"] <= WINDOW["width"], (name, got)
        assert not got["wide"], (name, got["wide"])
        assert not got["over"], (name, got["over"])
