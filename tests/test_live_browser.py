"""``bootnav live`` as a person uses it: an emulated boot walks up a floor, stands, walks on; a real headless
chromium (through chromedriver, W3C WebDriver over plain HTTP) watches the page.

The walk is the simulator's three-floors walk cut at the first floor's landing, with 10 s of standing spliced in
(the start's still samples: a flat foot reads the same whatever its heading), 4 s more of the stairs and 1 s
of standing at the end. The test waits for strides, checks the drawn path (one vertex per footprint, one
polyline per floor run), the provisional strides (hollow markers drawn before the final stride, then replaced
by it), the floor indicator (floor 1 after one storey of 3 m), the no-motion alarm (on
during the spliced stand only) and, after Ctrl-C, compares the live path with ``bootnav process`` on the file
the live view recorded (the same configured detector, without the whole-record timing calibration a stream
cannot do).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.request

import numpy as np
import pytest

from tests.conftest import REPO

CHROMIUM = next((shutil.which(n) for n in ("chromium", "chromium-browser") if shutil.which(n)), None)
DRIVER = shutil.which("chromedriver")
if CHROMIUM is None or DRIVER is None:
    if os.environ.get("CI"):
        raise RuntimeError("CI is set but chromium or chromedriver is missing (apt-get install chromium "
                           "chromium-driver): the live view's browser test must run in CI")
    pytestmark = pytest.mark.skip(reason="chromium and chromedriver are needed (Debian: apt-get install chromium "
                                         "chromium-driver, or scripts/install-debian-deps.sh)")

STAND_S = (28.39, 10.0)  # splice time on the first floor's landing (mid-stance, foot flat), standing time
RESUME_END_S = 32.39  # mid-stance on the second flight
NO_MOTION_S = 6.0  # longer than the 5 s rest at the start


def _spliced_walk(path):
    """The walk of the module docstring as a recording the emulator can stream (int16 counts)."""
    from bootnav.logger.recording import counts_channel, load, write_recording
    from bootnav.simulator import simulate, write_h5

    sim = path.with_name("three-floors.h5")
    write_h5(simulate("three-floors", seed=0, profile="mpu6050-16g-2000dps", rate_hz=200.0), sim)
    rec = load(sim)
    t_true = rec.truth["t_s"]
    i1, i2 = np.searchsorted(t_true, [STAND_S[0], RESUME_END_S])
    still = np.flatnonzero((t_true >= 0.5) & (t_true < 4.5))  # 4 s of the initial rest
    rate = float(rec.meta["rate_nominal_hz"])
    stand = np.tile(still, int(np.ceil(STAND_S[1] / 4.0)))[: int(STAND_S[1] * rate)]
    idx = np.concatenate([np.arange(i1), stand, np.arange(i1, i2), still[: int(rate)]])
    meta = {k: rec.meta[k] for k in ("accel_range_g", "gyro_range_dps", "rate_nominal_hz", "device")}
    write_recording(path, np.arange(idx.size) / rate, rec.raw["acc"][idx], rec.raw["gyro"][idx],
                    acc_channel=counts_channel("acc", rec.raw["acc_attrs"]["scale_to_si"]),
                    gyro_channel=counts_channel("gyro", rec.raw["gyro_attrs"]["scale_to_si"]), meta=meta)
    return idx.size / rate


class WebDriver:
    """The few W3C WebDriver commands the test needs, over urllib (no client library)."""

    def __init__(self, tmp_path):
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        self.proc = subprocess.Popen([DRIVER, f"--port={port}"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self.base = f"http://127.0.0.1:{port}"
        for _ in range(100):
            try:
                self._call("GET", "/status")
                break
            except OSError:
                time.sleep(0.1)
        caps = {"browserName": "chrome", "goog:chromeOptions": {"binary": CHROMIUM, "args": [
            "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1200,800",
            f"--user-data-dir={tmp_path / 'chromium'}"]}}
        self.session = self._call("POST", "/session", {"capabilities": {"alwaysMatch": caps}})["sessionId"]

    def _call(self, method, path, body=None):
        req = urllib.request.Request(self.base + path, method=method,
                                     data=None if body is None else json.dumps(body).encode(),
                                     headers={"Content-Type": "application/json"})
        with urllib.request.urlopen(req, timeout=30) as resp:
            return json.loads(resp.read())["value"]

    def get(self, url):
        self._call("POST", f"/session/{self.session}/url", {"url": url})

    def js(self, script):
        return self._call("POST", f"/session/{self.session}/execute/sync", {"script": script, "args": []})

    def quit(self):
        try:
            self._call("DELETE", f"/session/{self.session}")
        finally:
            self.proc.terminate()
            self.proc.wait(10)


PAGE_STATE = """
const s = window.bootnavLive, b = s && s.boots && s.boots["0"];
const lines = [...document.querySelectorAll('polyline.path[data-boot="0"]')];
return b ? {rows: b.rows, status: b.status, connected: s.connected, provisional: b.provisional,
  hollow: [...document.querySelectorAll('circle.provisional[data-boot="0"]')].map(c => +c.dataset.t),
  floor: document.getElementById("floor-0").textContent,
  alarm: getComputedStyle(document.getElementById("alarm-0")).display !== "none",
  legend: [...document.querySelectorAll("#legend-boots .legend-boot")].map(e => e.textContent),
  polylines: lines.map(l => [l.dataset.floor, l.getAttribute("points").trim().split(/\\s+/).length])} : null;
"""


def test_live_view_in_a_headless_browser(tmp_path):
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings

    t0 = time.monotonic()
    src = tmp_path / "walk.h5"
    duration = _spliced_walk(src)
    link, out = tmp_path / "boot", tmp_path / "rec"
    cli = [sys.executable, "-m", "bootnav.cli"]
    emu = subprocess.Popen([*cli, "emulate", "--out-link", str(link), "--source", str(src), "--quiet"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, cwd=REPO)
    live = subprocess.Popen([*cli, "live", "--port", str(link), "--label", "ff1", "--out", str(out), "--http-port", "0",
                             "--no-motion-s", str(NO_MOTION_S), "--quiet"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO)
    driver = None
    try:
        url = live.stdout.readline().split()[-1]
        assert url.startswith("http://127.0.0.1:"), url
        driver = WebDriver(tmp_path)
        driver.get(url)
        seen, first_stride_at, hollow = [], None, {}
        while emu.poll() is None and time.monotonic() - t0 < duration + 40:
            st = driver.js(PAGE_STATE)
            if st:
                for r in st["provisional"]:
                    if r[0] in st["hollow"]:  # drawn as a hollow marker
                        hollow.setdefault(r[0], r)
            if st and st["status"]:
                seen.append((st["status"]["t_s"], st["alarm"], st["floor"]))
                if first_stride_at is None and len(st["rows"]) > 3:
                    first_stride_at = st["status"]["t_s"]
            time.sleep(0.25)
        assert emu.wait(5) == 0, emu.stderr.read()
        time.sleep(1.5)  # the recorder's last flush and the view's poll
        st = driver.js(PAGE_STATE)
        # the replay slider: back to the spliced stand, only the footprints walked by then are drawn
        driver.js(f"""const s = document.getElementById("slider"); s.value = {STAND_S[0] + 1.0};
                      s.dispatchEvent(new Event("input")); return null;""")
        time.sleep(0.5)
        back = driver.js(PAGE_STATE)
    finally:
        if driver is not None:
            driver.quit()
        live.send_signal(signal.SIGINT)
        try:
            live.wait(30)
        finally:
            live.kill()
            emu.kill()
    assert live.returncode == 0, live.stderr.read()
    # strides appeared while walking, early in the walk (the rest before it is 5 s, each stride ~1.1 s)
    assert first_stride_at is not None and first_stride_at < 15.0, seen[:5]
    rows = np.array(st["rows"], float)
    assert st["legend"] == ["ff1"] and st["connected"]
    # drawn: a polyline per run of strides on one floor, each starting at the previous run's last vertex
    assert sum(n for _, n in st["polylines"]) == len(rows) - 1 + len(st["polylines"])
    assert {f for f, _ in st["polylines"]} == {"0", "1"} and st["floor"] == "1"
    # the alarm: on while standing on the landing (after NO_MOTION_S of it), off while walking
    stand0, stand1 = STAND_S[0], STAND_S[0] + STAND_S[1]
    on = [t for t, alarm, _ in seen if alarm]
    assert on and min(on) >= stand0 + NO_MOTION_S - 0.5 and max(on) <= stand1 + 1.0, on
    assert any(alarm for t, alarm, _ in seen if stand0 + NO_MOTION_S + 1.0 < t < stand1 - 0.5)
    assert not any(alarm for t, alarm, _ in seen if t < stand0 + NO_MOTION_S - 0.5)  # the 5 s rest at the start
    assert [f for t, _, f in seen if stand0 < t < stand1][-1] == "1"
    # provisional strides: drawn hollow before the final stride, then replaced by it: the first final footprint
    # after its stance start (the footprint's time is its stance's mid time); the boot's roll-over and ~2 s of
    # drift apart, within a quarter of a stride of 0.8 m or more, so on its own stride
    replaced = 0
    for t, r in hollow.items():
        if t < rows[-1, 0]:  # its final stride has been drawn by the end
            k = int(np.searchsorted(rows[:, 0], t, side="right"))
            assert np.linalg.norm(rows[k, 1:4] - r[1:4]) <= 0.2, (r, rows[k])
            assert t not in st["hollow"] and all(p[0] != t for p in st["provisional"])
            replaced += 1
    assert replaced >= (len(rows) - 1) // 2, (replaced, len(rows))
    n_back = int((rows[:, 0] <= STAND_S[0] + 1.0).sum())
    assert 10 < n_back < len(rows)
    assert sum(n for _, n in back["polylines"]) == n_back - 1 + len(back["polylines"])

    # after the walk: the live path against `bootnav process` on the recorded file
    recorded = out / "ff1.h5"
    settings = ProcessSettings()
    settings.selftune.timing_calibration = False  # whole-record self-calibration: not available to a stream
    res = process(recorded, settings)
    steps = res.steps
    final = np.array(json.loads((out / "live.json").read_text())["boots"]["ff1"]["rows"], float)
    dist = res.summary["path"]["distance_m"]
    assert len(final) == len(steps["t_s"]) + 1  # the start footprint + one row per stride
    err = np.hypot(final[1:, 1] - steps["x_m"], final[1:, 2] - steps["y_m"])
    assert err.max() <= 0.005 * dist, (err.max(), dist)
    assert np.abs(final[1:, 3] - steps["z_m"]).max() <= 0.005 * dist
    # the page showed the same footprints before Ctrl-C, the last stride too: the stream ended (the emulator
    # closed its port, the recorder wrote a disconnect) and the boot's last stance phase was closed then
    assert len(rows) == len(final) and np.allclose(rows, final)
    assert st["status"]["strides"] == len(final) - 1
