"""The notebook inspector in a real browser: a notebook served by Voilà (a live kernel,
ipywidgets' own front end) opened in Debian's headless Chromium, driven by Playwright.
The test moves the sphere slider with the keyboard, as a user would, waits for the frames
to finish, reads back the image the page shows and compares it with what eyelab.render
gives for the new value (CI installs chromium and sets EYELAB_REQUIRE_BROWSER)."""

from __future__ import annotations

import base64
import importlib.util
import io
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
NEEDED = ("voila", "playwright", "ipykernel", "ipywidgets")
HAVE = CHROMIUM is not None and all(importlib.util.find_spec(m) for m in NEEDED)

#: How Chromium is started here: headless, and without the background services whose
#: connections this machine's closed network refuses.
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]

SIZE, SAMPLES = (160, 120), 4
DONE = "code[data-state='done']"

pytestmark = pytest.mark.skipif(not HAVE and not os.environ.get("EYELAB_REQUIRE_BROWSER"),
                                reason="needs chromium, voila, playwright, ipykernel and "
                                "ipywidgets (CI sets EYELAB_REQUIRE_BROWSER)")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _notebook(folder: Path, spec: Path) -> Path:
    import nbformat

    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "python3", "language": "python",
                                 "display_name": "Python 3"}
    nb.cells.append(nbformat.v4.new_code_cell(
        "import eyelab\n"
        f"inspector = eyelab.NotebookInspector({str(spec)!r}, size={SIZE!r}, "
        f"samples={SAMPLES})\ninspector"))
    path = folder / "inspect.ipynb"
    nbformat.write(nb, path)
    return path


def _serve(notebook: Path, port: int):
    log = notebook.with_suffix(".log")
    with open(log, "wb") as out:                  # the child keeps its own descriptor
        proc = subprocess.Popen([sys.executable, "-m", "voila", notebook.name,
                                 "--no-browser", f"--port={port}", "--Voila.ip=127.0.0.1"],
                                cwd=notebook.parent, stdout=out, stderr=subprocess.STDOUT,
                                start_new_session=True)
    url = f"http://127.0.0.1:{port}/"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=2).close()
            return proc, url
        except OSError:
            if proc.poll() is not None:
                break
            time.sleep(0.5)
    _stop(proc)
    raise AssertionError(f"voila did not start: {log.read_text()[-2000:]}")


def _stop(proc) -> None:
    """Voilà and the kernel it started (one process group)."""
    try:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(timeout=20)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=20)
    except ProcessLookupError:
        proc.wait(timeout=20)


def _shown_png(page) -> bytes:
    """The bytes of the image the page shows (ipywidgets' Image: a blob URL)."""
    data = page.evaluate("""async () => {
        const img = document.querySelector('.widget-image');
        const buf = new Uint8Array(await (await fetch(img.src)).arrayBuffer());
        let s = ''; for (const b of buf) s += String.fromCharCode(b);
        return btoa(s); }""")
    return base64.b64decode(data)


def test_moving_a_slider_in_the_browser_shows_eyelab_renders_image(tmp_path):
    from PIL import Image
    from playwright.sync_api import sync_playwright

    import eyelab
    from eyelab.reference.metrics import ssim

    spec = tmp_path / "first.toml"
    shutil.copy(ROOT / "examples" / "first.toml", spec)
    proc, url = _serve(_notebook(tmp_path, spec), _free_port())
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
            page = browser.new_page()
            page.goto(url, timeout=180_000)
            page.wait_for_selector(DONE, timeout=180_000)
            assert "eye -2.50" in page.inner_text(DONE)
            before = _shown_png(page)
            handle = page.locator(".widget-slider", has_text="eye sphere (D)").locator(
                ".noUi-handle")
            handle.focus()
            page.keyboard.press("ArrowRight")               # one step: +0.25 D
            page.wait_for_function(
                "([sel, text]) => { const c = document.querySelector(sel);"
                " return c !== null && c.innerText.includes(text); }",
                arg=[DONE, "eye -2.25"], timeout=180_000)
            after = _shown_png(page)
            browser.close()
    finally:
        _stop(proc)
    shown = np.asarray(Image.open(io.BytesIO(after)).convert("RGB"))
    import tomllib

    data = tomllib.loads(spec.read_text())          # the spec as the inspector holds it
    data["eye"]["rx"] = "-2.25 / -0.75 x 090"
    data["lens"]["rx"] = "-2.50 -0.75 x 90"
    data["render"].update(width=SIZE[0], height=SIZE[1], samples=SAMPLES)
    want = eyelab.render(data).srgb
    assert after != before
    assert ssim(shown / 255.0, want / 255.0) >= 0.99
