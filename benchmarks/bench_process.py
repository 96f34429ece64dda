"""End-to-end speed of `bootnav process` on a 1-hour 200 Hz recording (issue: < 5 s, < 500 MB).

Generates the recording once with the simulator (`long` scenario, seeded), then times the stages the
user pays for: load -> checks -> calibration -> detection -> filter + smoother -> strides -> write
(CSV, JSON, HDF5 results; no plots). Peak memory is the process's peak RSS (resource.getrusage).

    .venv/bin/python benchmarks/bench_process.py [--duration 3600] [--engine fast|reference]
"""

from __future__ import annotations

import argparse
import resource
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--duration", type=float, default=3600.0)
    parser.add_argument("--rate", type=float, default=200.0)
    parser.add_argument("--engine", default="fast", choices=["fast", "reference"])
    parser.add_argument("--keep", type=Path, default=None, help="cache the generated recording here")
    args = parser.parse_args()

    from bootnav.postproc.outputs import write_outputs
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings
    from bootnav.simulator import simulate, write_h5

    work = Path(tempfile.mkdtemp(prefix="bench_process_"))
    rec = args.keep or work / "long.h5"
    if not rec.exists():
        t0 = time.perf_counter()
        write_h5(simulate("long", seed=0, rate_hz=args.rate, duration_s=args.duration), rec)
        print(f"generated {rec} ({rec.stat().st_size / 1e6:.1f} MB) in {time.perf_counter() - t0:.1f} s")
    run_copy = work / "run.h5"
    settings = ProcessSettings()
    settings.filter.engine = args.engine
    settings.output.plots = False

    # Warm numba's cache on a short slice so compile time is not counted (it is paid once per install).
    warm = ProcessSettings.from_dict(settings.to_dict())
    warm.crop_s = (0.0, 60.0)
    process(rec, warm)

    shutil.copy(rec, run_copy)
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    cpu0 = time.process_time()
    result = process(run_copy, settings)
    t_process = time.perf_counter() - t0
    write_outputs(result, work / "out")
    wall = time.perf_counter() - t0
    cpu = time.process_time() - cpu0
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    n = len(result.t_s)
    print(f"samples: {n} ({n / args.rate / 3600:.2f} h at {args.rate:g} Hz), engine {args.engine}")
    for stage, seconds in result.summary["timings_s"].items():
        print(f"  {stage:<16} {seconds:7.3f} s")
    print(f"process: {t_process:.2f} s; end to end incl. writing: {wall:.2f} s wall, {cpu:.2f} s CPU "
          f"({n / wall / 1e6:.2f} M samples/s)")
    print(f"peak RSS: {peak_mb:.0f} MB (before run {rss0 / 1024:.0f} MB)")
    print(f"path: {result.summary['path']['distance_m']:.0f} m walked, "
          f"closure {result.summary['path']['closure_pct']:.2f} %")
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
