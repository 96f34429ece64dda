"""The chart stage of `bootnav process` (charts 1-7 and path.html, issue 18): CPU and wall time of its parts.

Runs ``process`` once on a recording (not timed), then, in this process: the matplotlib import, the decimated
stream of the whole run (``plots.ChartStream.from_result``), the seven PNGs (``plots.draw_charts``) and
``path.html`` (``plots.make_html``: its own path stream), each ``--repeat`` times (the minimum is printed;
the import once). CPU = user + system of this process (``time.process_time``), so figures stay comparable on
a shared machine. Prints; asserts nothing.

    .venv/bin/python benchmarks/bench_plots.py /tmp/bootnav_bench_long/shift_1h_seed0.h5 [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recording", help="a bootnav HDF5 recording (e.g. a simulated shift, benchmarks/bench_long.py)")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    from bootnav.postproc import plots
    from bootnav.postproc.pipeline import process

    result = process(args.recording)

    def timed(fn):
        c, w = time.process_time(), time.perf_counter()
        out = fn()
        return out, time.process_time() - c, time.perf_counter() - w

    _, cpu, wall = timed(plots._pyplot)
    rows = [("matplotlib import", cpu, wall)]
    best: dict[str, tuple[float, float]] = {}
    with tempfile.TemporaryDirectory() as d:
        for _ in range(max(args.repeat, 1)):
            stream, c1, w1 = timed(lambda: plots.ChartStream.from_result(result))
            _, c2, w2 = timed(lambda: plots.draw_charts(stream, d))
            _, c3, w3 = timed(lambda: plots.make_html(result, d))
            for name, c, w in (("stream (decimation)", c1, w1), ("charts 1-7 (PNG)", c2, w2), ("path.html", c3, w3)):
                best[name] = min(best.get(name, (c, w)), (c, w))
        sizes = {name: os.path.getsize(os.path.join(d, name)) for name in (*plots.FILES.values(), "path.html")}
    rows += [(name, c, w) for name, (c, w) in best.items()]
    print(f"{args.recording}: {len(result.t_s)} samples, load average {os.getloadavg()[0]:.1f}")
    print(f"{'part':<22} {'CPU s':>7} {'wall s':>7}")
    for name, c, w in rows:
        print(f"{name:<22} {c:7.3f} {w:7.3f}")
    print(f"{'total':<22} {sum(r[1] for r in rows):7.3f} {sum(r[2] for r in rows):7.3f}")
    print("files (kB): " + ", ".join(f"{k} {v / 1e3:.0f}" for k, v in sizes.items()))


if __name__ == "__main__":
    main()
