"""The HTML report in a real browser: Debian's headless Chromium driven by playwright (no
browser download: ``executable_path``), every request that is not a local file aborted.

For the bell and the beam (external data): the page loads with no console error and asks
for nothing on the network, the 3D view is not blank, moving the slider to the last step
changes it, and each sphere has as many coloured DBGs as the report has distinct DBGs. The
screenshots go to ``tmp_path``, and also to ``$NDBG_SCREENSHOTS`` when it is set (how the
pictures in ``docs/`` are made: ``NDBG_SCREENSHOTS=docs pytest tests/test_pictures_browser.py``).

Skipped, saying why, where no Chromium (``.ci/run`` installs Debian's) or no playwright is
installed.
"""

from __future__ import annotations

import io
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import ndbg_cli
from ndbg_cli.core.options import Options
from ndbg_cli.report.document import dumps

from conftest import shared

ROOT = Path(__file__).resolve().parents[1]

#: WebGL without a GPU: Chromium's software renderer (SwiftShader), which headless
#: Chromium no longer picks by itself.
BROWSER_ARGS = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                "--ignore-gpu-blocklist"]


def chromium_path() -> str:
    """Debian's Chromium, or a skip saying what is missing."""
    for name in ("chromium", "chromium-browser"):
        found = shutil.which(name)
        if found:
            return found
    pytest.skip("no Chromium browser installed (apt-get install chromium; .ci/run does)")


@pytest.fixture(scope="module")
def browser():
    path = chromium_path()
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("playwright is not installed (pip install -e '.[test]')")
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=path, args=BROWSER_ARGS)
        yield b
        b.close()


def report_page(source: Path, tmp_path: Path, name: str) -> tuple[dict, Path]:
    """``(report, path of its HTML page)`` of an assembly, analysed here."""
    from ndbg_cli.pictures.html import render_html

    asm = ndbg_cli.load(source)
    report = json.loads(dumps(ndbg_cli.analyze(asm, Options(motion="translation",
                                                             cache=None))))
    page = tmp_path / f"{name}.html"
    page.write_text(render_html(report, asm), encoding="utf-8")
    return report, page


def pixels(png: bytes) -> np.ndarray:
    from PIL import Image

    with Image.open(io.BytesIO(png)) as im:
        return np.asarray(im.convert("RGB")).astype(int)


def save(png: bytes, tmp_path: Path, name: str) -> None:
    (tmp_path / name).write_bytes(png)
    if os.environ.get("NDBG_SCREENSHOTS"):
        folder = Path(os.environ["NDBG_SCREENSHOTS"])
        folder.mkdir(parents=True, exist_ok=True)
        (folder / name).write_bytes(png)


def check_page(browser, report: dict, page_path: Path, tmp_path: Path, name: str) -> None:
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    problems: list[str] = []
    fetched: list[str] = []
    page.on("console", lambda m: problems.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: problems.append(str(e)))

    def route(r):
        if r.request.url.startswith("file:"):
            r.continue_()
        else:  # offline: anything else is aborted, and noted
            fetched.append(r.request.url)
            r.abort()

    page.route("**/*", route)
    page.goto(page_path.as_uri())
    page.wait_for_selector("body[data-ndbg-ready]", timeout=60_000)
    page.wait_for_timeout(500)
    view = page.locator("#ndbg-view")
    first = view.screenshot()
    background = np.array([255, 255, 255])
    drawn = (np.abs(pixels(first) - background).sum(axis=2) > 30).mean()
    assert drawn > 0.01, f"the 3D view is blank ({drawn:.4f} of its pixels drawn)"

    steps = len(report["plan"]["sequence"])
    page.eval_on_selector("#ndbg-step", "(e, n) => { e.value = n; "
                          "e.dispatchEvent(new Event('input')); }", steps)
    page.wait_for_timeout(500)
    last = view.screenshot()
    change = (np.abs(pixels(last) - pixels(first)).sum(axis=2) > 30).mean()
    assert change > 0.005, "the last step's picture is the assembled one"
    label = page.inner_text("#ndbg-step-label")
    assert label.startswith(f"{steps}/{steps}: remove"), label
    save(page.screenshot(), tmp_path, f"{name}-last-step.png")


    for family, sec in report["ndbg"].items():
        if not sec.get("region_list"):
            continue
        div = f"ndbg-sphere-{family}"
        colours = page.evaluate(
            "id => document.getElementById(id).data.filter(t => t.meta && "
            "t.meta.dbg !== undefined).map(t => t.marker.color)", div)
        assert len(colours) == len(set(colours)) == sec["distinct_dbgs"], family
        hover = page.evaluate(
            "id => document.getElementById(id).data.filter(t => t.meta && "
            "t.meta.dbg !== undefined).map(t => t.hovertext)", div)
        assert all("minimal free sets" in h and "arcs" in h for h in hover)
        save(page.locator(f"#{div}").screenshot(), tmp_path, f"{name}-sphere-{family}.png")
    save(page.locator("#ndbg-tree").screenshot(), tmp_path, f"{name}-tree.png")

    # last (the animation keeps a software-rendered page busy): the play button takes it
    # apart from the start, the slider moving by itself
    page.eval_on_selector("#ndbg-step", "e => { e.value = 0; "
                          "e.dispatchEvent(new Event('input')); }")
    page.evaluate("document.getElementById('ndbg-play').click()")
    page.wait_for_function("document.getElementById('ndbg-step').value > 0", timeout=90_000)
    assert not problems, problems
    assert not fetched, fetched
    page.close()


def test_bell_report_in_chromium(browser, tmp_path):
    report, page = report_page(ROOT / "assemblies" / "bell.yaml", tmp_path, "bell")
    check_page(browser, report, page, tmp_path, "bell")


@pytest.mark.external
def test_beam_report_in_chromium(browser, tmp_path):
    report, page = report_page(shared("beam", "assembled"), tmp_path, "beam")
    check_page(browser, report, page, tmp_path, "beam")
