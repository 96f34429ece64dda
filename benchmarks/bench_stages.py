"""Where `bootnav process` spends its CPU: seconds of process CPU per stage of one run (issue 25, point 5).

Runs ``pipeline.process`` (the block passes, rows kept in memory) + ``outputs.write_outputs`` (without charts) on a
cached ``bench_long`` recording under ``cProfile`` with the process CPU clock as its timer: a stage's
figure (a function of the passes, cumulative over every pass that calls it) is the CPU of every thread of the process while the stage ran (the timing probes' two threads, the
smoother's thread). The kernels are loaded first (a one-minute run), so compile time is not counted; the
import row is a child ``python -c "import ..."``. The charts (``plots.ChartStream`` and the drawing of the
chart processes, here in this process) are timed without the profiler, whose cost per Python call would
triple matplotlib's. Wall times on a shared machine are noise: compare CPU.
A second table gives the process CPU of each pass of the default run (``pipeline.process_to``: the block
passes of a recording longer than ``block_s``), by the stages its ``timings_s`` names.
Prints tables; asserts nothing.

    .venv/bin/python benchmarks/bench_stages.py [--hours 1] [--cache DIR] [--repeat 2]
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_long import recording  # noqa: E402  (the cached simulated shift)

# (label, function name as cProfile lists it: file suffix, function)
STAGES = [
    ("load", "source.py", "load_source"),
    ("read blocks (decoded, calibrated)", "passes.py", "read"),
    ("initial alignment", "calibration.py", "initial_alignment"),
    ("stance detection (stream)", "detectors/stream.py", "_detect"),
    ("noise floor pass", "passes.py", "noise_floor"),
    ("timing probes (2 filters, 2 threads)", "passes.py", "_ForwardProbes.push"),
    ("filter + smoother pushes (every pass)", "ins/stream.py", "push"),
    ("  of which filter kernel", "fast.py", "filter_chunk"),
    ("  of which smoother kernel (this thread)", "fast.py", "smooth_segments"),
    ("heading / storeys' filter pass", "passes.py", "path_footprints"),
    ("final pass rows (emit)", "passes.py", "emit"),
    ("storeys", "floors.py", "storey_offsets"),
    ("strides", "strides.py", "footprint_strides"),
    ("process (all passes)", "pipeline.py", "process"),
    ("trajectory.csv", "outputs.py", "write_trajectory_csv"),
    ("write_outputs (no charts)", "outputs.py", "write_outputs"),
]

IMPORTS = ("import bootnav.postproc.pipeline, bootnav.postproc.outputs, "
           "bootnav.postproc.ins, bootnav.postproc.cli_process")


def _cumulative(stats: pstats.Stats, suffix: str, name: str) -> float:
    """Cumulative CPU of the functions ``name`` of the files ending in ``suffix`` ("Class.method": that class's)."""
    line = None
    if "." in name:
        cls, name = name.split(".")
        import bootnav.postproc.pipeline as module  # the one file such a row names

        text = Path(module.__file__).read_text().splitlines()
        start = next(i for i, t in enumerate(text) if t.startswith(f"class {cls}"))
        line = next(i for i in range(start, len(text)) if text[i].startswith(f"    def {name}(")) + 1
    return sum(v[3] for (path, ln, func), v in stats.stats.items()
               if func == name and path.endswith(suffix) and line in (None, ln))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "bootnav_bench_long")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeat", type=int, default=2, help="runs (the table shows the smallest CPU of each)")
    args = parser.parse_args()
    args.cache.mkdir(parents=True, exist_ok=True)
    rec, _ = recording(args.cache, args.hours, args.seed)

    c0 = time.process_time()
    imp = subprocess.run([sys.executable, "-c", f"import time; {IMPORTS}; print(time.process_time())"],
                         capture_output=True, text=True, check=True)
    import_cpu = float(imp.stdout.split()[-1])

    from bootnav.postproc import outputs
    from bootnav.postproc.outputs import warm_csv_writer, write_outputs

    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings

    work = Path(tempfile.mkdtemp(prefix="bench_stages_"))
    warm = ProcessSettings(crop_s=(0.0, 60.0))
    warm.output.plots = False
    write_outputs(process(rec, warm), work / "warm")
    warm_csv_writer()
    from bootnav.postproc.plots import ChartStream, warm_up

    warm_up()
    settings = ProcessSettings()
    settings.output.plots = False
    best: dict[str, float] = {}
    walls = []
    for i in range(args.repeat):
        out = work / f"run{i}"
        prof = cProfile.Profile(time.process_time)
        w0 = time.perf_counter()
        prof.enable()
        result = process(rec, settings)
        write_outputs(result, out)
        prof.disable()
        c = time.process_time()
        stream = ChartStream.from_result(result)
        c1 = time.process_time()
        outputs.draw_here(stream, out)
        for label, v in (("chart stream", c1 - c), ("charts drawn (7 PNG + html)", time.process_time() - c1)):
            best[label] = min(best.get(label, v), v)
        walls.append(time.perf_counter() - w0)
        stats = pstats.Stats(prof)
        for label, suffix, name in STAGES:
            v = _cumulative(stats, suffix, name)
            best[label] = min(best.get(label, v), v)
        shutil.rmtree(out, ignore_errors=True)
    print(f"\n{rec.name}: CPU s per stage (smallest of {args.repeat} runs; process CPU of all threads)")
    print(f"{'imports (child process)':<44} {import_cpu:7.2f}")
    for label in [s[0] for s in STAGES] + ["chart stream", "charts drawn (7 PNG + html)"]:
        print(f"{label:<44} {best[label]:7.2f}")
    print(f"(wall of process + write_outputs: {', '.join(f'{w:.2f}' for w in walls)} s; {os.cpu_count()} CPUs; "
          f"bench CPU {time.process_time() - c0:.1f} s)")
    passes, walls = _default_passes(rec, work, args.repeat)
    print(f"\n{rec.name}: CPU s per pass of the default run (`bootnav process` without flags: "
          f"pipeline.process_to, charts in the chart processes, not counted here; smallest of {args.repeat} runs)")
    for label, v in passes.items():
        print(f"{label:<44} {v:7.2f}")
    print(f"(wall of process_to: {', '.join(f'{w:.2f}' for w in walls)} s)")
    shutil.rmtree(work, ignore_errors=True)


def _default_passes(rec: Path, work: Path, repeat: int) -> tuple[dict[str, float], list[float]]:
    """Process CPU (all threads) of each stage ``process_to`` times (its ``timings_s`` keys), smallest of
    ``repeat`` runs, and the wall of each run."""
    from bootnav.postproc import pipeline
    from bootnav.postproc.settings import ProcessSettings

    best: dict[str, float] = {}
    clock = pipeline._StageClock
    lap = clock.__call__

    def timed(self, stage):
        now = time.process_time()
        v = now - getattr(self, "_bench_cpu", self._bench_cpu0)
        self._bench_cpu = now
        best[stage] = min(best.get(stage, v), v)
        lap(self, stage)

    init = clock.__init__

    def start(self, progress):
        init(self, progress)
        self._bench_cpu0 = time.process_time()

    clock.__init__, clock.__call__ = start, timed
    walls = []
    try:
        for i in range(repeat):
            w0 = time.perf_counter()
            pipeline.process_to(rec, ProcessSettings(), work / f"default{i}", force=True)
            walls.append(time.perf_counter() - w0)
    finally:
        clock.__init__, clock.__call__ = init, lap
    best["all passes"] = sum(best.values())
    return best, walls


if __name__ == "__main__":
    main()
