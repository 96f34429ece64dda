"""The live view's data path without the browser: tailing a SWMR recording another process writes, replay,
and one boot's strides/floors/no-motion time against ``process`` on the same samples."""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
import pytest

from bootnav.logger.recording import load
from bootnav.postproc.live.boot import BootView, LiveSettings
from bootnav.postproc.live.sources import Chunk, GrowingRecording, ReplayRecording
from tests.conftest import REPO

WRITER = """
import sys, time
import numpy as np
from bootnav.logger.recording import RecordingWriter, counts_channel
w = RecordingWriter(sys.argv[1], counts_channel("acc", 0.01), counts_channel("gyro", 0.001), meta={"subject": "w"})
rng = np.random.default_rng(0)
n = 0
for block in range(8):
    m = 37 + 11 * block
    w.append((n + np.arange(m)) / 200.0, rng.integers(-2000, 2000, (m, 3)).astype(np.int16),
             rng.integers(-2000, 2000, (m, 3)).astype(np.int16), saturated=(np.arange(m) % 50 == 0).astype(np.uint8))
    w.add_events([{"kind": "gap", "sample_index": n, "count": 2, "t_s": n / 200.0}])
    w.flush()
    n += m
    time.sleep(0.15)
w.close()
"""


def test_growing_recording_reads_what_another_process_flushes(tmp_path):
    path = tmp_path / "growing.h5"
    tail = GrowingRecording(path)
    assert tail.poll() is None  # no file yet
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path)], cwd=REPO)
    chunks, t_end = [], time.monotonic() + 30
    while time.monotonic() < t_end:
        done = proc.poll() is not None
        c = tail.poll()
        if c is not None:
            chunks.append(c)
        if done:
            break
        time.sleep(0.05)
    c = tail.poll()
    chunks.append(c)
    tail.close()
    assert proc.returncode == 0
    assert sum(len(c.t_s) > 0 for c in chunks) >= 3  # seen growing, not only at the end
    rec = load(path)  # the file as any reader sees it once closed
    got_t = np.concatenate([c.t_s for c in chunks])
    np.testing.assert_array_equal(got_t, rec.t_s)
    np.testing.assert_array_equal(np.concatenate([c.acc_mps2 for c in chunks]), rec.acc_mps2)
    np.testing.assert_array_equal(np.concatenate([c.gyro_radps for c in chunks]), rec.gyro_radps)
    np.testing.assert_array_equal(np.concatenate([c.saturated for c in chunks]), rec.saturated)
    events = np.concatenate([c.events for c in chunks])
    assert len(events) == len(rec.events) == 8 and events["count"].sum() == 16
    assert tail.meta.get("subject") == "w"


def test_replay_paces_by_the_recording_clock():
    rec = REPO / "recordings" / "sim_paper-straight.h5"
    src = ReplayRecording(rec, speed=20.0)
    t0 = time.monotonic()
    first = src.poll()
    time.sleep(0.25)
    second = src.poll()
    elapsed = time.monotonic() - t0
    # 20x real time: about 20 * elapsed seconds of recording are due, never more
    assert second.t_s[-1] - first.t_s[0] <= 20 * elapsed + 0.01
    assert second.t_s[-1] - first.t_s[0] >= 20 * 0.25 - 0.5
    assert not src.finished
    rest = ReplayRecording(rec, speed=float("inf")).poll()
    assert len(rest.t_s) == load(rec).n


@pytest.fixture(scope="module")
def stairs():
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings

    rec = load(REPO / "recordings" / "sim_paper-stairs.h5")
    settings = ProcessSettings()
    settings.floor_height_m = 1.5  # the paper's 1.7 m climb is one such "floor": the indicator must change
    settings.selftune.timing_calibration = False  # a stream cannot calibrate on the whole record
    return rec, settings, process(rec, settings)


def _feed(rec, settings, sizes, no_motion_s=30.0):
    view = BootView("b", settings, LiveSettings(no_motion_s=no_motion_s))
    rows, statuses, a, k = [], [], 0, 0
    while a < rec.n:
        sl = slice(a, min(a + sizes[k % len(sizes)], rec.n))
        rows += view.push(Chunk(rec.t_s[sl], rec.acc_mps2[sl], rec.gyro_radps[sl], rec.saturated[sl]), 0.0)
        statuses.append(view.status(0.0, False))
        a, k = sl.stop, k + 1
    rows += view.finish()
    return np.array(rows), statuses, view


@pytest.mark.parametrize("sizes", [[20], [1, 7, 333, 64]])
def test_boot_view_matches_process_for_any_chunking(stairs, sizes):
    rec, settings, res = stairs
    rows, statuses, view = _feed(rec, settings, sizes)
    steps, path = res.steps, res.summary["path"]
    dist = path["distance_m"]
    assert len(rows) == len(steps["t_s"]) + 1  # the start, then one row per stride
    np.testing.assert_allclose(rows[1:, 0], steps["t_s"], atol=0.02)  # a stance phase's mid time, within a sample
    fp = np.column_stack([steps["x_m"], steps["y_m"], steps["z_m"]])
    assert np.linalg.norm(rows[1:, 1:4] - fp, axis=1).max() <= 0.005 * dist
    assert abs(view.result()["distance_m"] - dist) <= 0.005 * dist
    assert rows[-1, 4] == path["final_floor"] == 1 and view.result()["final_floor"] == 1
    # the start's 10 s rest raised the 30 s alarm nowhere; the no-motion time grew through that rest
    assert not any(s["alarm"] for s in statuses)
    assert max(s["still_s"] for s in statuses) > 8.0


def test_no_motion_alarm_after_the_configured_time(stairs):
    rec, settings, _ = stairs
    _, statuses, _ = _feed(rec, settings, [40], no_motion_s=8.0)  # the recording starts and ends with 10 s still
    on = [s["t_s"] for s in statuses if s["alarm"]]
    assert on and min(on) >= 8.0 - 0.3 and min(on) < 9.0
    assert any(rec.t_s[-1] - 2.5 <= t for t in on)  # and again in the final rest
    walking = [s for s in statuses if 12.0 < s["t_s"] < rec.t_s[-1] - 12.0]
    assert walking and not any(s["alarm"] for s in walking)


def test_refused_samples_stop_the_path_not_the_view(stairs):
    rec, settings, _ = stairs
    view = BootView("b", settings, LiveSettings())
    n = int(15 * rec.rate_hz)  # the rest and the first strides: the filter runs
    view.push(Chunk(rec.t_s[:n], rec.acc_mps2[:n], rec.gyro_radps[:n], rec.saturated[:n]), 0.0)
    back = slice(n - 50, n + 50)  # time goes back by 50 samples
    view.push(Chunk(rec.t_s[back], rec.acc_mps2[back], rec.gyro_radps[back], rec.saturated[back]), 1.0)
    view.push(Chunk(rec.t_s[n + 50:], rec.acc_mps2[n + 50:], rec.gyro_radps[n + 50:], rec.saturated[n + 50:]), 2.0)
    st = view.status(2.0, False)
    assert st["note"].startswith("path stopped:") and "backwards" in st["note"] and st["link"]["state"] == "ok"
    assert view.finish() == []
    assert view.link.samples == rec.n + 50  # the link figures still count every sample


@pytest.mark.parametrize("argv, message", [
    (["--port", "/dev/null"], "--port needs --out"),
    (["--replay", "x.h5", "--speed", "0"], "--speed 0.0: must be a positive number"),
    (["--replay", "x.h5", "--out", "d"], "--replay writes nothing"),
    (["--replay", "a/x.h5", "b/x.h5"], "not distinct"),
    (["--replay", "x.h5", "--detector", "nope"], "unknown stance detector 'nope'"),
    (["--replay", "x.h5", "--detector", "xio"], "cannot run on a stream"),
])
def test_cli_usage_errors_are_one_line(argv, message, capsys):
    from bootnav.cli import main

    assert main(["live", *argv, "--http-port", "0"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_provisional_strides_come_early_and_are_replaced_by_the_final_ones(stairs):
    """Each stride is drawn provisionally a cue look-ahead after its stance start, near where its final footprint
    will be, and disappears when that final stride arrives."""
    rec, settings, _ = stairs
    view = BootView("b", settings, LiveSettings())
    step = 20  # 0.1 s chunks, as the poll delivers them
    first_seen, gone_with = {}, {}
    finals = []
    for a in range(0, rec.n, step):
        sl = slice(a, min(a + step, rec.n))
        before = {r[0] for r in view.provisional}
        new = view.push(Chunk(rec.t_s[sl], rec.acc_mps2[sl], rec.gyro_radps[sl], rec.saturated[sl]), 0.0)
        finals += new
        now = {r[0]: r for r in view.provisional}
        for t, r in now.items():
            first_seen.setdefault(t, (float(rec.t_s[sl.stop - 1]), r))
        for t in before - set(now):
            gone_with[t] = new
    left = view.provisional
    last = view.finish()
    finals += last
    gone_with.update({r[0]: last for r in left})
    assert view.provisional == []
    cue_lookahead = view.cue_lookahead_s
    rate = rec.rate_hz
    finals = np.array(finals)
    strides = finals[1:]
    matched = 0
    for t, (t_newest, r) in first_seen.items():
        # data latency: the newest sample when it appeared, after the stance start: the cue's look-ahead, a chunk
        assert t_newest - t <= cue_lookahead + step / rate + 1.5 / rate, (t, t_newest)
        k = int(np.searchsorted(strides[:, 0], t, side="right"))  # the first final footprint after it
        # the final footprint is the stance's mean position (its time stamp is the stance's mid time); the
        # provisional one is at its start: they differ by the boot's roll-over onto its sole
        # and the open-loop drift over the ~2 s not yet filtered with ZUPT. Within a quarter of a stride
        # (0.8 m and more here) the marker is unambiguously on its own stride.
        if k < len(strides):
            matched += 1
            assert np.linalg.norm(strides[k, 1:4] - r[1:4]) <= 0.2, (t, strides[k], r)
            # replaced in the very push that delivered its final stride
            assert t in gone_with and any(abs(f[0] - strides[k, 0]) < 1e-9 for f in gone_with[t])
    assert matched >= len(strides) - 2  # every stride but the first and last has its provisional one
    # the final path is what it is without provisional strides (test_boot_view_matches_process_for_any_chunking)


def test_replay_of_a_two_boot_recording_shows_both_boots(tmp_path):
    from bootnav.logger.recording import write_multi_boot
    from bootnav.postproc.live.cli import _replay_boots
    from bootnav.postproc.live.server import Hub
    from bootnav.postproc.live.session import Feed, Session, hello
    from bootnav.postproc.settings import ProcessSettings

    parts = {"left": load(REPO / "recordings" / "sim_paper-stairs.h5"),
             "right": load(REPO / "recordings" / "sim_paper-straight.h5")}
    path = write_multi_boot(tmp_path / "both.h5", {b: {"t_s": r.t_s, "acc": r.acc_mps2, "gyro": r.gyro_radps,
                                                      "meta": {"rate_nominal_hz": r.rate_hz}}
                                                  for b, r in parts.items()})
    boots = _replay_boots([str(path)])
    assert [(b, label) for _, b, label in boots] == [("left", "left"), ("right", "right")]
    settings = ProcessSettings()
    feeds = [Feed(str(i), label, ReplayRecording(p, float("inf"), boot=b), BootView(label, settings, LiveSettings()))
             for i, (p, b, label) in enumerate(boots)]
    hub = Hub(hello(feeds, "replay", 1.0, 30.0, 3.0))
    session = Session(feeds, hub, poll_s=0.0)
    while session.step():
        pass
    snap = hub.snapshot()
    assert [b["label"] for b in snap["hello"]["boots"]] == ["left", "right"]
    for i, (label, rec) in enumerate(parts.items()):
        alone, _, _ = _feed(rec, settings, [rec.n])
        np.testing.assert_allclose(np.array(snap["rows"][str(i)]), alone)  # each boot as its own file
        assert len(alone) > 5 and snap["provisional"][str(i)] == []


def test_provisional_strides_with_a_detector_ahead_of_the_cue():
    """With ``shoe`` as the detector the navigator can be ahead of the cue (whose minimum stance widens its
    look-ahead): the provisional rows are then the filtered position itself, and the path is unchanged."""
    import dataclasses

    from bootnav.postproc.settings import ProcessSettings

    rec = load(REPO / "recordings" / "xio_ngimu_short_walk.h5")
    settings = ProcessSettings()
    settings.detector = dataclasses.replace(settings.detector, method="shoe")
    rows, _, view = _feed(rec, settings, [int(0.1 * rec.rate_hz)])
    whole, _, _ = _feed(rec, settings, [rec.n])
    assert view.note is None and len(rows) > 10
    np.testing.assert_allclose(rows, whole, rtol=0, atol=1e-6)  # chunked footprint sums: rounding only
