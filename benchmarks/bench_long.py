"""Long recordings (a whole shift): time and memory of `bootnav process`, `import` and `info` (issue 18).

Simulated 200 Hz MPU6050 recordings of a shift (laps of a loop with a stair flight and standing pauses,
``bootnav.simulator.simulate.LongSimulation``), generated block by block (bounded memory) and cached in
``--cache``. Every command runs as a child process of its own; wall time, CPU time (user + system) and peak
RSS come from ``os.wait4`` of that child. numba's cache is warmed first on a one-minute crop, so compile
time is not counted. Goals: 1 h at 200 Hz in <= 2.5 s end to end (charts included) and a peak RSS flat in the
length, < 500 MB at 24 h (issue 25); `info` on 24 h < 1 s (issue 18). Prints a table; asserts nothing.

    .venv/bin/python benchmarks/bench_long.py [--hours 1 3] [--long] [--cache DIR] [--block-s S ...]

Each length is processed as ``bootnav process`` runs it without flags (``pipeline.process_to``: blocks of
``settings.block_s`` seconds, charts included), and once more per ``--block-s`` length given (the row names the
block length). ``--long`` adds 12 and 24 h (generating them takes ~10 min on 2 cores, once). The `import` row reads a
canonical CSV of the 12 h recording (of the longest one generated without ``--long``; streamed in blocks);
the `info` rows read the longest recording (scanned in blocks, or its writer's summary when it was generated
with one) and the imported one (the import's writer stores a summary).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

BOOTNAV = [sys.executable, "-m", "bootnav"]

GENERATE = """
import sys
from bootnav.simulator.simulate import LongSimulation
from bootnav.simulator.writers import write_long_h5
write_long_h5(LongSimulation(float(sys.argv[1]), seed=int(sys.argv[2]), block_s=120.0), sys.argv[3])
"""

TO_CSV = """
import sys
import numpy as np
from bootnav.logger.recording import load
rec = load(sys.argv[1], with_truth=False)
with open(sys.argv[2], "w") as f:
    f.write("t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps\\n")
    for i in range(0, rec.n, 100_000):
        block = np.column_stack((rec.t_s[i:i + 100_000], rec.acc_mps2[i:i + 100_000], rec.gyro_radps[i:i + 100_000]))
        f.write(("%.6f" + ",%.6f" * 6 + "\\n") * len(block) % tuple(block.ravel()))
"""


def run(cmd: list[str]) -> dict:
    """Run ``cmd`` as a child; its wall time, CPU time and peak RSS (MB), from ``os.wait4``."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, cwd=tempfile.gettempdir())
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode(errors="replace")
    proc.stderr.close()
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(map(str, cmd))} failed ({proc.returncode}):\n{err[-2000:]}")
    return {"wall_s": wall, "cpu_s": usage.ru_utime + usage.ru_stime, "rss_mb": usage.ru_maxrss / 1024}


def recording(cache: Path, hours: float, seed: int) -> tuple[Path, dict | None]:
    """The cached recording of ``hours`` (generated when missing: its generation figures, else None)."""
    path = cache / f"shift_{hours:g}h_seed{seed}.h5"
    if path.exists():
        return path, None
    tmp = path.with_suffix(".tmp.h5")
    fig = run([sys.executable, "-c", GENERATE, str(hours * 3600.0), str(seed), str(tmp)])
    tmp.rename(path)
    return path, fig


def _how_info_reads(path: Path) -> str:
    """"summary" when the recording carries its writer's summary (``bootnav.logger.samplestats``), else "scan"."""
    import h5py

    with h5py.File(path, "r") as f:
        return "summary" if "summary" in f["imu"].attrs else "scan"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, nargs="+", default=[1.0, 3.0])
    parser.add_argument("--long", action="store_true", help="add 12 h and 24 h")
    parser.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "bootnav_bench_long")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--block-s", type=float, nargs="*", default=[],
                        help="also run with these block lengths (bootnav process --block-s), s")
    parser.add_argument("--skip-import", action="store_true")
    args = parser.parse_args()
    hours = sorted(set(args.hours) | ({12.0, 24.0} if args.long else set()))
    args.cache.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="bench_long_"))

    recs = {}
    for h in hours:
        recs[h], gen = recording(args.cache, h, args.seed)
        if gen:
            print(f"generated {recs[h].name}: {gen['wall_s']:.0f} s wall, {gen['rss_mb']:.0f} MB peak RSS, "
                  f"{recs[h].stat().st_size / 1e6:.0f} MB on disk", flush=True)
    run(BOOTNAV + ["process", str(recs[hours[0]]), "--out", str(work / "warm"), "--crop", "0", "60", "-q",
                   "--no-plots"])  # numba cache warm

    rows = []
    for h in hours:
        modes = [("", [])] + [(f" block {b:g} s", ["--block-s", str(b)]) for b in args.block_s]
        for label, extra in modes:
            fig = run(BOOTNAV + ["process", str(recs[h]), "--out", str(work / f"out_{h:g}h{label.strip().replace(' ', '')}"), "-q",
                                 *extra])
            rows.append((f"process {h:g} h{label}", h, fig))
            print(f"  process {h:g} h{label} done: {fig['wall_s']:.1f} s", flush=True)
    if not args.skip_import:
        h_csv = 12.0 if 12.0 in recs else hours[-1]
        csv = args.cache / f"shift_{h_csv:g}h_seed{args.seed}.csv"
        if not csv.exists():
            run([sys.executable, "-c", TO_CSV, str(recs[h_csv]), str(csv.with_suffix(".tmp"))])
            csv.with_suffix(".tmp").rename(csv)
        fig = run(BOOTNAV + ["import", str(csv), "--out", str(work / "imported.h5"), "--quiet"])
        rows.append((f"import {h_csv:g} h CSV ({csv.stat().st_size / 1e6:.0f} MB)", h_csv, fig))
        fig = run(BOOTNAV + ["info", str(work / "imported.h5")])
        rows.append((f"info {h_csv:g} h ({_how_info_reads(work / 'imported.h5')})", h_csv, fig))
    fig = run(BOOTNAV + ["info", str(recs[hours[-1]])])
    rows.append((f"info {hours[-1]:g} h ({_how_info_reads(recs[hours[-1]])})", hours[-1], fig))

    print(f"\n{'command':<28} {'wall s':>8} {'CPU s':>8} {'peak RSS MB':>12} {'wall s per h':>13}")
    for label, h, fig in rows:
        print(f"{label:<28} {fig['wall_s']:8.2f} {fig['cpu_s']:8.2f} {fig['rss_mb']:12.0f} {fig['wall_s'] / h:13.2f}")
    print(f"\n(2 cores; {os.cpu_count()} CPUs visible; outputs in {work})")


if __name__ == "__main__":
    main()
