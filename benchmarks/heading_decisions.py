"""What ``filter.heading_aid = "auto"`` decides on every foot-mounted recording of the dataset tree, and why.

Prints one row per IMU file: set, trial, file, on/off, share of straight strides on a 90° grid, cross share
(aligned strides at right angles to the main axis), straight strides, windows. Reads no truth.

    nice -n 10 .venv/bin/python benchmarks/heading_decisions.py [--sets koroglu_footprints ...] [--set k=v ...]
"""

from __future__ import annotations

import argparse
import json
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))

from crossval import DEFAULT_ROOT, PRIMARY, parse_value, settings_with  # noqa: E402


def _one(args):
    path, overrides = args
    from bootnav.postproc.evaluate.runner import estimate_foot

    est = estimate_foot(Path(path), settings_with(overrides))
    return est.result.nav.info.get("heading_decision", {})


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", type=Path, default=DEFAULT_ROOT)
    ap.add_argument("--sets", nargs="*", default=list(PRIMARY))
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE", help="extra setting override")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)
    overrides = {"filter.heading_aid": "auto"}
    for kv in args.set:
        k, v = kv.split("=", 1)
        overrides[k] = parse_value(v)
    manifest = json.loads((args.root / "manifest.json").read_text())
    jobs = []
    for t in manifest["trials"]:
        if t["set"] not in args.sets:
            continue
        for name, mount in (t.get("imu_files") or {"imu.csv.gz": t["mount"]}).items():
            if mount == "foot":
                jobs.append((t["set"], t["id"], name, str(args.root / t["path"] / name)))
    with ProcessPoolExecutor(args.jobs) as ex:
        results = list(ex.map(_one, [(j[3], overrides) for j in jobs]))
    print(f"{'set':20s} {'trial':34s} {'file':16s} {'aid':4s} {'share':>6s} {'cross':>6s} {'straight':>8s} "
          f"{'windows':>7s} {'aided':>5s} {'strides':>7s}")
    for (s, tid, name, _), d in zip(jobs, results):
        print(f"{s:20s} {tid:34s} {name:16s} {'on' if d.get('on') else 'off':4s} {d.get('share', float('nan')):6.2f} "
              f"{d.get('cross', float('nan')):6.2f} {d.get('n_straight', 0):8d} {len(d.get('windows', [])):7d} "
              f"{(d.get('segments') or {}).get('aided', '-'):>5} {d.get('n_strides', 0):7d}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
