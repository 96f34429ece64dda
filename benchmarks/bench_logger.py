#!/usr/bin/env python3
"""Logger throughput: parser alone, and emulator -> real pty -> `bootnav record` -> HDF5.

    .venv/bin/python benchmarks/bench_logger.py [--seconds 3] [--rates 1000,5000,20000]

Prints, for the parser, frames/s and CPU µs per frame (clean and with 1 % corrupted frames), and for
each pty rate the frames the recorder stored vs the intact frames the emulator sent (loss must be 0),
the sustained rate and the recorder's CPU use (user+sys of its process / wall time).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bootnav.logger.protocol import FrameParser, pack_samples  # noqa: E402


def bench_parser(n: int = 200_000, chunk: int = 4096, corrupt: float = 0.0) -> dict:
    rng = np.random.default_rng(0)
    data = bytearray(pack_samples(np.arange(n), np.arange(n) * 1000, rng.integers(-32768, 32768, (n, 3)),
                                  rng.integers(-32768, 32768, (n, 3)), np.zeros(n)))
    bad = np.flatnonzero(rng.random(n) < corrupt)
    for k in bad:  # one bit flip in the payload of each chosen frame
        data[26 * k + 12] ^= 0x04
    data = bytes(data)
    parser = FrameParser()
    w0, c0 = time.perf_counter(), time.process_time()
    got = 0
    for i in range(0, len(data), chunk):
        got += parser.feed(data[i:i + chunk]).samples.size
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    assert got == n - bad.size, (got, n, bad.size)
    return {"frames": got, "crc_errors": parser.stats.crc_errors, "frames_per_s": got / wall,
            "cpu_us_per_frame": cpu / n * 1e6}


def bench_pty(rate: float, seconds: float, tmp: Path) -> dict:
    link, out, report = tmp / f"tty{int(rate)}", tmp / f"rec{int(rate)}.h5", tmp / f"rep{int(rate)}.json"
    cmd = [sys.executable, "-m", "bootnav"]
    emu = subprocess.Popen(cmd + ["emulate", "--out-link", str(link), "--rate", str(rate), "--duration", str(seconds),
                                  "--report", str(report), "--linger", "0.5", "--quiet"], cwd=REPO)
    while not os.path.lexists(link):
        time.sleep(0.01)
    rec = subprocess.Popen(cmd + ["record", "--port", str(link), "--out", str(out), "--quiet"], cwd=REPO,
                           stderr=subprocess.DEVNULL)
    t0 = time.monotonic()
    # Steady-state CPU of the recorder from /proc (start-up imports excluded): from 1 s in to 0.3 s before the end.
    time.sleep(1.0)
    c1, w1 = _proc_cpu_s(rec.pid), time.monotonic()
    time.sleep(max(0.1, seconds - 1.3))
    c2, w2 = _proc_cpu_s(rec.pid), time.monotonic()
    emu.wait(timeout=seconds * 5 + 30)
    time.sleep(0.3)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    rec.send_signal(signal.SIGTERM)
    rec.wait(timeout=60)
    wall = time.monotonic() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    from bootnav.logger.recording import load

    r = load(out)
    rep = json.loads(report.read_text())
    lost = len(rep["valid_seqs"]) - r.n
    exact = r.seq.tolist() == rep["valid_seqs"]
    return {"rate_hz": rate, "sent": rep["frames_sent"], "stored": r.n, "lost": lost, "bit_exact_seq": exact,
            "sustained_fps": r.n / rep["duration_s"], "recorder_cpu_s": cpu, "recorder_wall_s": wall,
            "recorder_cpu_pct": 100 * cpu / wall, "steady_cpu_pct": 100 * (c2 - c1) / (w2 - w1)}


def _proc_cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime + stime


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--rates", default="1000,5000,20000")
    args = ap.parse_args()
    for corrupt in (0.0, 0.01):
        p = bench_parser(corrupt=corrupt)
        print(f"parser  corrupt {corrupt:4.0%}: {p['frames_per_s']:>10,.0f} frames/s, "
              f"{p['cpu_us_per_frame']:.2f} µs CPU/frame ({p['crc_errors']} CRC errors found)")
    with tempfile.TemporaryDirectory() as d:
        for rate in (float(x) for x in args.rates.split(",")):
            r = bench_pty(rate, args.seconds, Path(d))
            print(f"pty {rate:>7.0f} Hz for {args.seconds:g} s: stored {r['stored']}/{r['sent']} "
                  f"(lost {r['lost']}, seq bit-exact {r['bit_exact_seq']}), sustained {r['sustained_fps']:,.0f} frames/s, "
                  f"recorder CPU {r['recorder_cpu_s']:.2f} s over {r['recorder_wall_s']:.1f} s = "
                  f"{r['recorder_cpu_pct']:.1f} % of one core incl. start-up; steady state {r['steady_cpu_pct']:.1f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
