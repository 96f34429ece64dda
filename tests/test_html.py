"""``path.html`` in a real headless browser (Debian ``chromium``; issue 13, point 7): a simulated three-storey
walk with its exact truth as reference is loaded, its script run, and the drawn DOM checked: the path in one
colour per floor with a floor selector, a marker per stride, start and end, the reference, a metre grid with
labels and a scale bar. The page must need no network."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys

import pytest

from tests.conftest import REPO

CHROMIUM = next((shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome") if shutil.which(n)), None)


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.plots import make_html
    from bootnav.postproc.settings import ProcessSettings

    d = tmp_path_factory.mktemp("html")
    sim = subprocess.run([sys.executable, "-m", "bootnav.cli", "simulate", "--scenario", "three-floors", "--out",
                          str(d / "floors.h5"), "--quiet"], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert sim.returncode == 0, sim.stderr
    r = process(d / "floors.h5", ProcessSettings(reference="truth"))
    return r, make_html(r, d)


def test_page_is_self_contained(page):
    _, path = page
    text = path.read_text()
    assert not re.search(r"<(script|link|img)[^>]+(src|href)=", text)  # no CDN, no external file
    assert not re.search(r"https?://(?!www\.w3\.org/2000/svg)", text)


@pytest.mark.skipif(CHROMIUM is None, reason="no chromium binary: install Debian's chromium "
                                              "(scripts/install-debian-deps.sh) to run the browser test")
def test_drawn_in_a_headless_browser(page, tmp_path):
    r, path = page
    proc = subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--window-size=1000,800",
                           f"--user-data-dir={tmp_path / 'profile'}", "--virtual-time-budget=3000", "--dump-dom",
                           path.as_uri()], capture_output=True, text=True, timeout=90)
    assert proc.returncode == 0, proc.stderr[-2000:]
    dom = proc.stdout
    n_strides = len(r.steps["t_s"])
    floors = sorted(set(re.findall(r'<polyline class="path" data-floor="(-?\d+)"', dom)))
    assert floors == ["0", "1", "2", "3"]  # three storeys climbed: four floors, each drawn
    assert r.summary["path"]["floors_climbed"] == 3
    assert re.findall(r'<option value="([^"]+)"', dom) == ["all", "0", "1", "2", "3"]
    assert len(re.findall(r'<circle class="stride"', dom)) == n_strides > 40
    assert 'id="start"' in dom and 'id="end"' in dom and '<polyline id="reference"' in dom
    # drawn by the script, so present only if it ran: grid lines with metre labels, a scale bar
    grid = re.search(r'<g id="grid">(.*?)</g>', dom, re.S).group(1)
    assert grid.count("<line") >= 4 and re.findall(r"<text[^>]*>(-?[\d.]+) m</text>", grid)
    label = re.search(r'id="scalelabel">([^<]+)<', dom).group(1)
    width = float(re.search(r'id="bar" style="width: ([\d.]+)px', dom).group(1))
    assert re.fullmatch(r"[\d.]+ c?m", label) and 40 <= width <= 250
