#!/usr/bin/env python3
"""The live view (``bootnav live``): latency, agreement with ``process``, CPU per boot, memory over an hour.

    .venv/bin/python benchmarks/bench_live.py [--part all|chain|lossless|cpu|memory] [--sources three-floors,mixed,xio,openshoe]
                                              [--detectors adaptive,shoe]

* **chain** (real time, per source): ``bootnav emulate`` serves the walk on a pty, ``bootnav live`` records it
  and shows it; an SSE client notes when each stride arrives. Latency = arrival − the host time at which the
  recorder received the first sample of the stride's stance phase (``/imu/t_host``; stance phases from
  ``process`` with the same detector), measured twice: to the provisional marker (the first provisional row
  at or after 0.3 s before that stance start, so a cue slightly earlier than the detector counts; one per
  stance phase) and to the final stride. Agreement: after Ctrl-C the live footprints (``live.json``) against
  ``process`` on the recorded file, with the same configured detector and without the whole-record timing
  calibration (``selftune.timing_calibration`` off), and against the default ``process`` (same detector):
  distance difference, worst footprint distance and end-point distance, in % of the distance walked. Once
  with the default ``adaptive`` detector (1.4 s decision look-ahead) and once with ``shoe`` (0.07 s).
* **lossless** (real time): the three-floors walk at 1 kHz through the same chain with the page stream open;
  the intact frames the emulator sent (its ``--report``) that are missing from the recording, and the CPU
  share of the view's process (its own threads, start-up included; the recorder is a separate process).
* **cpu**: one boot's view (stance detection, filter, smoother, strides, floors) fed 0.1 s chunks as the
  poll does, plus the idle cost of polling a growing SWMR file ten times a second; CPU s per s of data at
  200 Hz and 1 kHz (the recorder children are measured by ``bench_logger.py``).
* **memory**: a simulated hour (``long`` scenario, 200 Hz) pushed in 0.1 s chunks as fast as it goes: the
  resident memory every 10 minutes of data.

Prints the figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
CLI = [sys.executable, "-m", "bootnav.cli"]


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 1e6


def _sim(scenario: str, out: Path, rate: float = 200.0, duration: float | None = None, seed: int = 0) -> Path:
    from bootnav.simulator import simulate, write_h5

    kw = {"duration_s": duration} if duration else {}
    write_h5(simulate(scenario, seed=seed, profile="mpu6050-16g-2000dps", rate_hz=rate, **kw), out)
    return out


def _sse_rows(url: str, arrivals: list, stop: threading.Event, provisional: dict) -> None:
    """Note (wall time, row) for every stride row the page stream sends, and the first arrival (wall time) of
    every provisional row (by its time stamp)."""
    with urllib.request.urlopen(url.replace("/?", "/events?") if "?" in url else url + "events", timeout=120) as r:
        event = None
        while not stop.is_set():
            line = r.readline().decode()
            if not line:
                return
            if line.startswith("event: "):
                event = line[7:].strip()
            elif line.startswith("data: ") and event == "strides":
                now = time.time()
                arrivals.extend((now, row) for row in json.loads(line[6:])["rows"])
            elif line.startswith("data: ") and event == "provisional":
                now = time.time()
                for row in json.loads(line[6:])["rows"]:
                    provisional.setdefault(row[0], now)


def _cpu_s(pid: int) -> float:
    """user + system CPU seconds of one process (its own threads, not its children)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def chain(source: Path, label: str, work: Path, detector: str, report: Path | None = None) -> dict:
    """Emulator -> bootnav live (recorder child + view) -> SSE client; then live.json vs process."""
    from bootnav.core.runs import runs
    from bootnav.logger.recording import load
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings

    label = f"{label}-{detector}"
    link, out = work / f"{label}.pty", work / label
    emu = subprocess.Popen([*CLI, "emulate", "--out-link", str(link), "--source", str(source), "--quiet"]
                           + (["--report", str(report)] if report else []),
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t_start = time.monotonic()
    live = subprocess.Popen([*CLI, "live", "--port", str(link), "--label", label, "--out", str(out),
                             "--http-port", "0", "--detector", detector, "--quiet"], stdout=subprocess.PIPE, text=True)
    url = live.stdout.readline().split()[-1]
    arrivals: list = []
    provisional: dict = {}
    stop = threading.Event()
    reader = threading.Thread(target=_sse_rows, args=(url, arrivals, stop, provisional), daemon=True)
    reader.start()
    emu.wait()
    last, same_since = None, time.monotonic()
    while time.monotonic() - same_since < 3.0:  # until the view has caught up with the end of the walk
        time.sleep(0.5)
        with urllib.request.urlopen(url.replace("/?", "/state.json?") if "?" in url else url + "state.json") as r:
            t = json.loads(r.read())["status"].get("0", {}).get("t_s")
        if t != last:
            last, same_since = t, time.monotonic()
    wall = time.monotonic() - t_start
    view_cpu = _cpu_s(live.pid) / wall
    with open(f"/proc/{live.pid}/task/{live.pid}/children") as f:
        rec_cpu = sum(_cpu_s(int(p)) for p in f.read().split()) / wall  # the recorder child
    stop.set()
    live.send_signal(signal.SIGINT)
    live.wait(600)
    rec = load(out / f"{label}.h5")
    final = np.array(json.loads((out / "live.json").read_text())["boots"][label]["rows"], float)
    s_same, s_default = ProcessSettings(), ProcessSettings()
    s_same.detector = s_default.detector = s_default.detector.with_method(detector)
    s_same.selftune.timing_calibration = False
    same, default = process(rec, s_same), process(rec, s_default)
    row = {"source": label, "duration_s": float(rec.t_s[-1]), "live_strides": len(final) - 1,
           "view_process_core_pct": 100 * view_cpu, "recorder_process_core_pct": 100 * rec_cpu}
    if report:
        sent = json.loads(report.read_text())
        row["frames_recorded"], row["intact_frames_sent"] = rec.n, len(sent["valid_seqs"])
        row["frames_lost"] = len(sent["valid_seqs"]) - rec.n
        row["same_frames_in_order"] = bool(np.array_equal(np.asarray(sent["valid_seqs"]) % 65536, rec.seq))
    for name, res in (("same", same), ("default", default)):
        st = res.steps
        dist = res.summary["path"]["distance_m"]
        d_live = float(np.hypot(*np.diff(final[:, 1:3], axis=0).T).sum())
        row[f"{name}_strides"] = len(st["t_s"])
        row[f"{name}_distance_m"] = dist
        row[f"{name}_d_distance_pct"] = 100 * (d_live - dist) / dist
        end = np.array([st["x_m"][-1], st["y_m"][-1], st["z_m"][-1]])
        row[f"{name}_end_diff_pct"] = 100 * float(np.linalg.norm(final[-1, 1:4] - end)) / dist
        if len(final) - 1 == len(st["t_s"]):
            fp = np.column_stack([st["x_m"], st["y_m"], st["z_m"]])
            row[f"{name}_worst_footprint_pct"] = 100 * float(np.linalg.norm(final[1:, 1:4] - fp, axis=1).max()) / dist
    starts, stops = runs(same.stance)
    t_host = rec.t_host
    lat = []
    for wall, r in arrivals[1:]:  # the first row is the start footprint, not a stride
        k = np.searchsorted(rec.t_s[stops - 1], r[0])
        if k < len(starts) and rec.t_s[starts[k]] <= r[0]:
            lat.append(wall - t_host[starts[k]])
    row["strides_timed"] = len(lat)
    row["latency_median_s"] = float(np.median(lat)) if lat else float("nan")
    row["latency_p95_s"] = float(np.percentile(lat, 95)) if lat else float("nan")
    row["latency_max_s"] = float(np.max(lat)) if lat else float("nan")
    t_stop = rec.t_s[stops - 1]
    first = {}
    for t_prov, wall in sorted(provisional.items()):
        k = int(np.searchsorted(t_stop, t_prov))
        if k < len(starts) and rec.t_s[starts[k]] - 0.3 <= t_prov and k not in first:
            first[k] = wall - t_host[starts[k]]
    plat = list(first.values())
    row["provisional_timed"] = len(plat)
    row["provisional_latency_median_s"] = float(np.median(plat)) if plat else float("nan")
    row["provisional_latency_p95_s"] = float(np.percentile(plat, 95)) if plat else float("nan")
    row["provisional_latency_max_s"] = float(np.max(plat)) if plat else float("nan")
    return row


def _feed(view, rec, chunk_s: float = 0.1) -> float:
    """Push a loaded recording through a BootView in chunks of ``chunk_s``; CPU seconds used."""
    from bootnav.postproc.live.sources import Chunk

    n = rec.n
    step = max(1, int(round(chunk_s * rec.rate_hz)))
    cpu0 = time.process_time()
    for a in range(0, n, step):
        sl = slice(a, min(a + step, n))
        view.push(Chunk(rec.t_s[sl], rec.acc_mps2[sl], rec.gyro_radps[sl], rec.saturated[sl]), time.monotonic())
    view.finish()
    return time.process_time() - cpu0


def cpu(work: Path) -> list[dict]:
    from bootnav.logger.recording import RecordingWriter, counts_channel, load
    from bootnav.postproc.live.boot import BootView, LiveSettings
    from bootnav.postproc.live.sources import GrowingRecording
    from bootnav.postproc.settings import ProcessSettings

    rows = []
    _warm_up()
    for rate in (200.0, 1000.0):
        rec = load(_sim("three-floors", work / f"tf{int(rate)}.h5", rate=rate))
        cpu_s = _feed(BootView("b", ProcessSettings(), LiveSettings()), rec)
        rows.append({"rate_hz": rate, "data_s": float(rec.t_s[-1]), "view_cpu_s": cpu_s,
                     "view_core_pct": 100 * cpu_s / float(rec.t_s[-1])})
    # idle cost of tailing: ten polls per second of a SWMR file nobody appends to
    path = work / "swmr.h5"
    w = RecordingWriter(path, counts_channel("acc", 1e-3), counts_channel("gyro", 1e-3))
    w.append(np.arange(10) / 200.0, np.zeros((10, 3), np.int16), np.zeros((10, 3), np.int16))
    w.flush()
    tail = GrowingRecording(path)
    tail.poll()
    c0 = time.process_time()
    for _ in range(1000):
        tail.poll()
    poll_cpu = (time.process_time() - c0) / 1000
    tail.close()
    w.close()
    for r in rows:
        r["poll_core_pct"] = 100 * poll_cpu * 10
        r["eight_boots_core_pct"] = 8 * (r["view_core_pct"] + r["poll_core_pct"])
    return rows


def memory(work: Path) -> list[tuple[float, float]]:
    from bootnav.logger.recording import load
    from bootnav.postproc.live.boot import BootView, LiveSettings
    from bootnav.postproc.live.sources import Chunk
    from bootnav.postproc.settings import ProcessSettings

    rec = load(_sim("long", work / "long.h5"))
    view = BootView("long", ProcessSettings(), LiveSettings())
    step = int(round(0.1 * rec.rate_hz))
    marks, next_mark = [], 0.0
    for a in range(0, rec.n, step):
        sl = slice(a, min(a + step, rec.n))
        view.push(Chunk(rec.t_s[sl], rec.acc_mps2[sl], rec.gyro_radps[sl], rec.saturated[sl]), time.monotonic())
        if rec.t_s[a] >= next_mark:
            marks.append((float(rec.t_s[a]), _rss_mb()))
            next_mark += 600.0
    view.finish()
    marks.append((float(rec.t_s[-1]), _rss_mb()))
    return marks


def _warm_up() -> None:
    """Compile (or load from numba's cache) the kernels once, so no child's start-up includes it."""
    from bootnav.logger.recording import load
    from bootnav.postproc.live.boot import BootView, LiveSettings
    from bootnav.postproc.settings import ProcessSettings

    _feed(BootView("warm", ProcessSettings(), LiveSettings()), load(REPO / "recordings" / "sim_paper-straight.h5"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default="all", choices=("all", "chain", "lossless", "cpu", "memory"))
    ap.add_argument("--sources", default="three-floors,mixed,xio,openshoe")
    ap.add_argument("--detectors", default="adaptive,shoe", help="stance detectors of the chain part")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench_live_") as tmp:
        work = Path(tmp)
        if args.part in ("all", "chain"):
            _warm_up()
            files = {"three-floors": lambda: _sim("three-floors", work / "three-floors.h5"),
                     "mixed": lambda: _sim("mixed-30min", work / "mixed.h5", duration=120.0),
                     "xio": lambda: REPO / "recordings" / "xio_ngimu_short_walk.h5",
                     "openshoe": lambda: REPO / "recordings" / "openshoe_820_loop.h5"}
            for detector in args.detectors.split(","):
                for name in args.sources.split(","):
                    r = chain(files[name](), name, work, detector)
                    print(json.dumps({k: round(v, 4) if isinstance(v, float) else v for k, v in r.items()}), flush=True)
        if args.part in ("all", "lossless"):
            _warm_up()
            src = _sim("three-floors", work / "tf1000.h5", rate=1000.0)
            r = chain(src, "three-floors-1kHz", work, "adaptive", report=work / "emulator.json")
            print(json.dumps({k: round(v, 4) if isinstance(v, float) else v for k, v in r.items()}), flush=True)
        if args.part in ("all", "cpu"):
            for r in cpu(work):
                print(json.dumps({k: round(v, 3) for k, v in r.items()}), flush=True)
        if args.part in ("all", "memory"):
            for t, mb in memory(work):
                print(f"t = {t / 60:5.1f} min of data: RSS {mb:6.1f} MB", flush=True)


if __name__ == "__main__":
    main()
