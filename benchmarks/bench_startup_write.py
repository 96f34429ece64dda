"""Start-up, CSV writing and timing probes of `bootnav process` (issue 18): CPU and wall time of each part.

* start-up: a fresh interpreter importing the `bootnav` parser (what `bootnav --help` costs) and then the
  modules `process` runs (numpy, scipy, numba, h5py, the pipeline), CPU from ``os.wait4``, min of ``--repeat``;
* CSV: ``outputs.append_csv_rows`` on 300 000 trajectory-like rows (8 columns as trajectory.csv), ns per row;
* probes: ``selftune.level_timing_offset`` on a recording (``--recording``, e.g. a simulated 1 h shift of
  ``benchmarks/bench_long.py``) with the default bound of level strides and without one (whole recording),
  with the τ each gives.

Prints; asserts nothing. The numba kernels are warmed first (compile time is not counted).

    .venv/bin/python benchmarks/bench_startup_write.py [--recording walk.h5] [--repeat 5]
"""

from __future__ import annotations

import argparse
import io
import os
import resource
import subprocess
import sys
import time

PARSER = "import bootnav.cli as c\nc.build_parser()"
PROCESS = PARSER + ("\nimport bootnav.postproc.cli_process, bootnav.postproc.pipeline, bootnav.postproc.outputs, "
                    "bootnav.postproc.ins.stream, bootnav.postproc.detectors.adaptive")


def child_cpu(code: str) -> tuple[float, float]:
    """(CPU s, wall s) of a fresh interpreter running ``code``."""
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-c", code])
    _, status, usage = os.wait4(proc.pid, 0)
    if os.waitstatus_to_exitcode(status):
        raise SystemExit(f"child failed: {code!r}")
    return usage.ru_utime + usage.ru_stime, time.perf_counter() - t0


def cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def bench_csv(repeat: int) -> None:
    import numpy as np

    from bootnav.postproc.outputs import TRAJECTORY_FORMATS, append_csv_rows

    rng = np.random.default_rng(0)
    n = 300_000
    cols = [np.cumsum(rng.uniform(0.004, 0.006, n)), *rng.normal(0, 30, (6, n)), rng.integers(0, 2, n)]
    append_csv_rows(io.BytesIO(), [c[:10] for c in cols], TRAJECTORY_FORMATS)  # compile / load the kernel
    best = float("inf")
    for _ in range(repeat):
        c0 = cpu()
        append_csv_rows(io.BytesIO(), cols, TRAJECTORY_FORMATS)
        best = min(best, cpu() - c0)
    print(f"trajectory.csv formatting: {best / n * 1e9:.0f} ns per row (CPU, min of {repeat}, {n} rows)")


def bench_probes(path: str) -> None:
    import numpy as np

    from bootnav.postproc import selftune
    from bootnav.postproc.calibration import initial_alignment
    from bootnav.postproc.checks import clipping_bits
    from bootnav.postproc.detectors import detect_stance
    from bootnav.postproc.settings import ProcessSettings
    from bootnav.postproc.source import crop, load_source

    s = ProcessSettings()
    src = load_source(path)
    smp = crop(src.recording, s.crop_s, src.name)
    sat = smp.saturated | clipping_bits(smp.acc_b, smp.gyro_b) if s.detector.detect_clipping else smp.saturated
    g = s.calibration.gravity()
    init = initial_alignment(smp.t_s, smp.acc_b, smp.gyro_b, s.calibration, g)
    stance = np.asarray(detect_stance(smp.t_s, smp.acc_b, smp.gyro_b, s.detector, g, saturated=sat).stance, bool)
    st = s.selftune
    n = 4000
    selftune.level_timing_offset(smp.t_s[:n], smp.acc_b[:n], smp.gyro_b[:n], stance[:n], init, g, s.filter)  # warm
    print(f"timing probes on {path} ({len(smp.t_s)} samples, {smp.t_s[-1] - smp.t_s[0]:.0f} s):")
    for bound in (st.timing_max_level_strides, None):
        c0, w0 = cpu(), time.perf_counter()
        r = selftune.level_timing_offset(smp.t_s, smp.acc_b, smp.gyro_b, stance, init, g, s.filter, saturated=sat,
                                         delta_s=st.timing_probe_s, max_abs_s=st.timing_max_abs_s,
                                         min_level_strides=st.timing_min_level_strides, max_level_strides=bound)
        print(f"  max_level_strides={bound}: {cpu() - c0:.2f} s CPU, {time.perf_counter() - w0:.2f} s wall; "
              f"probes over {r['probe_s']:.0f} s, {r['n_level']} level strides, tau {r['tau_s'] * 1e3:.3f} ms")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--recording", help="a recording for the timing probes (e.g. a 1 h simulated shift)")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    child_cpu(PROCESS)  # warm the file cache
    print(f"load average {os.getloadavg()[0]:.1f}")
    for name, code in (("import + parser (bootnav --help)", PARSER), ("imports of process", PROCESS)):
        runs = [child_cpu(code) for _ in range(args.repeat)]
        print(f"{name}: {min(c for c, _ in runs):.3f} s CPU, {min(w for _, w in runs):.3f} s wall (min of {args.repeat})")
    bench_csv(args.repeat)
    if args.recording:
        bench_probes(args.recording)


if __name__ == "__main__":
    main()
