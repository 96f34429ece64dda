"""The source paper's Table 1 and runtime figures side by side with bootnav [Heidari2019, Table 1 and §5].

Table 1: over simulator seeds 0-19 of ``paper-straight`` (9 m) and ``paper-stairs`` (11 m, 1.7 m climb),
MPU6050 profile (``mpu6050-16g-2000dps``: datasheet noise, turn-on bias and scale errors), the paper's
metrics — distance, deviation and height error in % of the distance (docs/metrics.md) — for the paper's
published figures, ``--mode riccati`` (the paper's constant gain, ``postproc/ins/riccati.py``) and the
time-varying filter (the default), median and worst over the seeds; the paper's stance detectors
(``--detector shoe-literal`` / ``paper_accmag``) with the Riccati gain as the paper ran them; and each
detector's stance-phase count against the truth (8 and 13 on every seed).

Runtime: per-sample processing time of one paper-stairs recording with the plots (the paper's subplots:
``bootnav process`` with every output and chart) and without (position only: ``process()``), against the
paper's MATLAB figures 0.022525 s and 0.000578 s per input. The paper's CPU and MATLAB version are
unknown, so only the ratio and the real-time margin compare.

    .venv/bin/python benchmarks/paper_table1.py [--seeds 20] [--jobs 2]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

SCENARIOS = ("paper-straight", "paper-stairs")
PAPER = {"paper-straight": (5.5, 6.0, 1.0), "paper-stairs": (2.5, 2.0, 0.8)}  # distance, deviation, height %
PAPER_RUNTIME_S = (0.022525, 0.000578)  # per input, with / without subplots [Heidari2019, §5]
CONFIGS = {  # label: (filter mode, stance detector)
    "riccati (--mode riccati)": ("riccati", "adaptive"),
    "time-varying (default)": ("time_varying", "adaptive"),
    "riccati + shoe-literal": ("riccati", "shoe-literal"),
    "riccati + paper_accmag": ("riccati", "paper_accmag"),
}


def _simulate(job) -> str:
    scenario, seed, folder = job
    from bootnav.simulator import simulate, write_h5

    path = Path(folder) / f"{scenario}-{seed}.h5"
    write_h5(simulate(scenario, seed=seed), path)
    return str(path)


def _run(job) -> tuple:
    path, label = job
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings

    mode, detector = CONFIGS[label]
    s = ProcessSettings(reference="truth")
    s.filter.mode = mode
    s.detector = s.detector.with_method(detector)
    r = process(path, s)
    m = r.metrics
    return (path, label, m["distance_error_pct"], m["deviation_error_pct"], m["height_error_pct"],
            r.summary["stance"]["phases"])


def table1(paths: list[str], jobs: int) -> None:
    with ProcessPoolExecutor(jobs) as pool:
        rows = list(pool.map(_run, [(p, label) for label in CONFIGS for p in paths]))
    print("Table 1: error in % of the distance, median / worst over the seeds (MPU6050 profile)")
    print(f"{'':25s} {'':14s} {'distance':>13s} {'deviation':>13s} {'height':>13s}")
    for scenario in SCENARIOS:
        d, dev, h = PAPER[scenario]
        print(f"{'paper [Heidari2019]':25s} {scenario:14s} {d:13.1f} {dev:13.1f} {h:13.1f}")
        for label in CONFIGS:
            got = np.array([r[2:5] for r in rows if r[1] == label and Path(r[0]).name.startswith(scenario + "-")])
            med, worst = np.median(got, axis=0), got.max(axis=0)
            cells = " ".join(f"{a:5.2f} / {b:5.2f}" for a, b in zip(med, worst))
            print(f"{label:25s} {scenario:14s} {cells}")
    print("\nstance phases per recording (truth: 8 straight, 13 stairs): detector -> counts seen over the seeds")
    for detector in dict.fromkeys(d for _, d in CONFIGS.values()):
        for scenario in SCENARIOS:
            counts = sorted({r[5] for r in rows if CONFIGS[r[1]][1] == detector
                             and Path(r[0]).name.startswith(scenario + "-")})
            print(f"  {detector:13s} {scenario:14s} {counts}")


def runtime(path: str, folder: str) -> None:
    from bootnav.postproc.outputs import write_outputs
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings

    s = ProcessSettings()
    s.filter.mode = "riccati"
    process(path, s)  # compile / load the numba kernels once
    t0 = time.perf_counter()
    r = process(path, s)
    bare = time.perf_counter() - t0
    t0 = time.perf_counter()
    r = process(path, s)
    write_outputs(r, Path(folder) / "out")  # every output and the seven charts
    full = time.perf_counter() - t0
    n = len(r.t_s)
    rate = r.summary["input"]["rate_hz"]
    print(f"\nruntime per sample ({n} samples at {rate:.0f} Hz, paper-stairs seed 0, --mode riccati)")
    print(f"{'':28s} {'with plots':>12s} {'without':>12s} {'ratio':>7s}")
    print(f"{'paper (MATLAB, tic/toc)':28s} {PAPER_RUNTIME_S[0]:12.6f} {PAPER_RUNTIME_S[1]:12.6f} "
          f"{PAPER_RUNTIME_S[0] / PAPER_RUNTIME_S[1]:7.0f}")
    print(f"{'bootnav (this machine)':28s} {full / n:12.6f} {bare / n:12.6f} {full / bare:7.0f}")
    print(f"real-time margin at {rate:.0f} Hz (sample period / time per sample): with plots "
          f"{1 / rate / (full / n):.0f}x, without {1 / rate / (bare / n):.0f}x")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="paper_table1_") as folder:
        with ProcessPoolExecutor(args.jobs) as pool:
            paths = list(pool.map(_simulate, [(sc, seed, folder) for sc in SCENARIOS for seed in range(args.seeds)]))
        table1(paths, args.jobs)
        runtime(paths[args.seeds], folder)


if __name__ == "__main__":
    main()
