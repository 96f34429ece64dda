#!/usr/bin/env python3
"""Two boots into one recording: a two-boot emulator (two real ptys) -> `bootnav record --port L --port R`.

    .venv/bin/python benchmarks/bench_two_boot_record.py [--seconds 60] [--rate 1000]

The emulator's device clocks run at -40 / +60 ppm and the right boot starts 0.25 s after the left. Prints per
boot the frames stored vs the intact frames sent (loss must be 0), the fitted rate error and the fit residual,
each boot's session-time error against the true emission times (median and spread), the difference of the two
medians (how well two samples taken at the same instant line up), and the recorder's CPU use (user+sys of
its process / wall time).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bootnav.logger.recording import boot_labels, load  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--rate", type=float, default=1000.0)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="bootnav-2boot-") as tmp:
        tmp = Path(tmp)
        links, out, report = [tmp / "L", tmp / "R"], tmp / "both.h5", tmp / "report.json"
        cmd = [sys.executable, "-m", "bootnav"]
        emu = subprocess.Popen([*cmd, "emulate", "--out-link", str(links[0]), "--out-link", str(links[1]),
                                "--rate", str(args.rate), "--duration", str(args.seconds), "--report", str(report),
                                "--quiet"], cwd=REPO)
        while not all(p.is_symlink() for p in links):
            time.sleep(0.02)
        t0 = time.monotonic()
        rec = subprocess.Popen([*cmd, "record", "--port", str(links[0]), "--port", str(links[1]), "--out", str(out),
                                "--duration", str(args.seconds + 2.0), "--quiet"], cwd=REPO)
        _, status, usage = os.wait4(rec.pid, 0)
        wall = time.monotonic() - t0
        emu.wait()
        reps = json.loads(report.read_text())["boots"]
        medians = []
        for label, rep in zip(boot_labels(out), reps):
            r = load(out, boot=label)
            k = (r.seq.astype(np.int64) - rep["settings"]["seq0"]) % 65536
            err = r.t_s + r.attrs["session_start_unix_s"] - (rep["stream_start_unix"] + k / rep["rate_hz"])
            medians.append(float(np.median(err)))
            print(f"{label}: {r.n} frames stored / {len(rep['valid_seqs'])} sent "
                  f"(lost {len(rep['valid_seqs']) - r.n}), clock {rep['settings']['clock_ppm']:+g} ppm set, "
                  f"fitted rate error {(1 / r.meta['clock_scale'] - 1) * 1e6:+.1f} ppm, residual "
                  f"{r.meta['clock_residual_s'] * 1e3:.2f} ms, time error median {medians[-1] * 1e3:.2f} ms "
                  f"(min {err.min() * 1e3:.2f}, max {err.max() * 1e3:.2f})")
        print(f"relative alignment of the two boots: {(medians[1] - medians[0]) * 1e3:+.3f} ms")
        cpu = usage.ru_utime + usage.ru_stime
        print(f"recorder: exit {os.waitstatus_to_exitcode(status)}, CPU {cpu:.2f} s over {wall:.1f} s wall "
              f"= {100 * cpu / wall:.1f} % of one core")


if __name__ == "__main__":
    main()
