"""Issue 26, point 3: the live view as a firefighter's officer reads it. A boot that goes silent raises the
no-motion alarm marked "signal lost"; a stream that breaks off has its last stride final at once (page and
live.json agree); samples after a reconnect continue the path; the header says the boots' state; the demo's
walks are drawn apart; the link line wraps between figures, never inside one."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from bootnav.logger.recording import load, make_events
from bootnav.postproc.live.boot import BootView, LiveSettings
from bootnav.postproc.live.sources import Chunk
from tests.conftest import REPO


@pytest.fixture(scope="module")
def stairs():
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings

    rec = load(REPO / "recordings" / "sim_paper-stairs.h5")
    settings = ProcessSettings()
    settings.selftune.timing_calibration = False  # a stream cannot calibrate on the whole record
    return rec, settings, process(rec, settings)


def _chunks(rec, t_shift=0.0, size=200):
    for a in range(0, rec.n, size):
        sl = slice(a, min(a + size, rec.n))
        yield Chunk(rec.t_s[sl] + t_shift, rec.acc_mps2[sl], rec.gyro_radps[sl], rec.saturated[sl])


DISCONNECT = Chunk(np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.uint8),
                   make_events([{"kind": "disconnect", "detail": "port vanished"}]))


def test_a_stream_that_breaks_off_has_its_last_stride_final_at_once(stairs):
    rec, settings, res = stairs
    view = BootView("b", settings, LiveSettings())
    rows = []
    for c in _chunks(rec):
        rows += view.push(c, 0.0)
    # the recording ends standing: the last stance phase is still open, its stride not yet final
    assert len(rows) == len(res.steps["t_s"])
    rows += view.push(DISCONNECT, 0.0)  # what the recorder writes when the emulator or the cable goes
    assert len(rows) == len(res.steps["t_s"]) + 1 == view.result()["strides"] + 1  # page rows = live.json rows
    assert view.status(0.0, False)["strides"] == view.result()["strides"]
    assert view.finish() == []  # the end of the session adds nothing twice


def test_samples_after_a_reconnect_continue_from_the_last_footprint(stairs):
    rec, settings, _ = stairs
    view = BootView("b", settings, LiveSettings())
    first = []
    for c in _chunks(rec):
        first += view.push(c, 0.0)
    first += view.push(DISCONNECT, 0.0)
    second = []
    for c in _chunks(rec, t_shift=rec.t_s[-1] + 5.0):  # the same walk again after the link came back
        second += view.push(c, 0.0)
    second += view.finish()
    first, second = np.array(first), np.array(second)
    # the same samples navigated again from the last footprint: the same strides, shifted by it (to 1 mm: the
    # shifted clock's rounding moves the filter's time steps; a stride is 1 m, a jump would be metres)
    assert len(second) == len(first) - 1  # the new segment's start coincides with the last footprint
    np.testing.assert_allclose(second[:, 1:3], first[1:, 1:3] + first[-1, 1:3] - first[0, 1:3], atol=1e-3)
    # heights to 1 cm: the storeys pool the riser estimate over both walks' flights (millimetres on a flight)
    np.testing.assert_allclose(second[:, 3], first[1:, 3] + first[-1, 3] - first[0, 3], atol=0.01)
    assert view.result()["distance_m"] == pytest.approx(2 * np.hypot(*np.diff(first[:, 1:3], axis=0).T).sum(),
                                                        abs=1e-3 * len(first))
    assert "signal back" in view.status(0.0, False)["note"]


def test_a_silent_boot_raises_the_alarm_marked_signal_lost(stairs):
    rec, settings, _ = stairs
    view = BootView("b", settings, LiveSettings(no_motion_s=30.0))
    walking = rec.t_s < 20.0  # the walk, not the final rest: the boot was moving when it went silent
    n = int(walking.sum())
    view.push(Chunk(rec.t_s[:n], rec.acc_mps2[:n], rec.gyro_radps[:n], rec.saturated[:n]), 100.0)
    fine = view.status(101.0, False)
    assert not fine["alarm"] and fine["link"]["state"] == "ok"
    silent = view.status(100.0 + 31.0, False)  # 31 s of wall time without a sample
    assert silent["alarm"] and silent["alarm_reason"] == "signal lost" and silent["still_s"] >= 30.0
    assert not view.status(100.0 + 31.0, True)["alarm"]  # a stream the user ended is not lost
    never = BootView("c", settings, LiveSettings(no_motion_s=30.0))  # a boot never heard from
    assert not never.status(0.0, False)["alarm"]
    assert never.status(31.0, False)["alarm_reason"] == "signal lost"


def test_demo_walks_are_drawn_apart():
    from bootnav.postproc.live.cli import DEMO_GAP_M, demo_offsets

    radii = [6.2, 10.1]
    (x0, y0), (x1, y1) = demo_offsets(radii)
    assert (x0, y0, y1) == (0.0, 0.0, 0.0) and x1 - x0 == pytest.approx(radii[0] + DEMO_GAP_M + radii[1])


# ------------------------------------------------------------------ the page, in a headless browser
def test_page_header_alarm_label_link_line_and_offsets_in_a_browser(tmp_path):
    from tests.test_live_browser import CHROMIUM, DRIVER, WebDriver

    if CHROMIUM is None or DRIVER is None:
        pytest.skip("chromium and chromedriver are needed")
    from bootnav.postproc.live.server import Hub, LiveServer
    from bootnav.postproc.live.session import Feed, hello

    feeds = [Feed("0", "ff1", None, None), Feed("1", "ff2", None, None)]
    hub = Hub(hello(feeds, "live", 1.0, 30.0, 3.0, offsets_m=[(0.0, 0.0), (20.0, 0.0)]))
    for boot in ("0", "1"):
        hub.add_rows(boot, [[0.0, 0.0, 0.0, 0.0, 0], [1.0, 1.0, 0.0, 0.0, 0]])
    link = {"rate_hz": 200.0, "nominal_hz": 200, "dropped": 123456, "crc_errors": 7890, "saturated": 12345,
            "age_s": 0.1}
    base = {"floor": 0, "height_m": 0.0, "distance_m": 1.0, "strides": 1, "t_s": 5.0, "note": None}
    hub.set_status({"0": {**base, "still_s": 1.0, "alarm": False, "alarm_reason": None,
                          "link": {**link, "state": "ok"}},
                    "1": {**base, "still_s": 35.0, "alarm": True, "alarm_reason": "signal lost",
                          "link": {**link, "state": "disconnected"}}})
    server = LiveServer(hub, "127.0.0.1", 0).start()
    driver = WebDriver(tmp_path)
    try:
        driver.get(server.url)
        for _ in range(50):
            st = driver.js("""const c = document.getElementById("conn");
              if (!document.getElementById("alarm-1") || !document.getElementById("link-1")) return null;
              const heads = [...document.querySelectorAll("circle.head")].map(e => [e.dataset.boot, +e.getAttribute("cx")]);
              const spans = [...document.querySelectorAll("#link-1 span")];
              return {header: c.textContent, cls: c.className, heads: heads,
                alarm: document.getElementById("alarm-1").textContent,
                alarmShown: getComputedStyle(document.getElementById("alarm-1")).display !== "none",
                parts: spans.map(s => [s.textContent, s.getClientRects().length]),
                linkLines: Math.round(document.getElementById("link-1").getBoundingClientRect().height /
                  parseFloat(getComputedStyle(spans.length ? spans[0] : document.body).lineHeight || 16))};""")
            if st and len(st["heads"]) == 2 and st["parts"]:
                break
            time.sleep(0.1)
    finally:
        driver.quit()
        server.stop()
    assert st, "the page never showed both boots"
    assert "ff1: ok" in st["header"] and "ff2: disconnected" in st["header"] and st["cls"] == "bad", st
    assert st["alarmShown"] and st["alarm"] == "SIGNAL LOST"
    assert len(st["parts"]) == 5 and all(n == 1 for _, n in st["parts"]), st["parts"]  # no figure split
    heads = dict(st["heads"])
    assert heads["1"] - heads["0"] > 50, heads  # 20 m east on a map a few tens of metres wide
    json.dumps(st)
