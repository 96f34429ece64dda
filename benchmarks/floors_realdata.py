"""Height by floors on the public recordings: are stairs kept, do level walks keep their height?

For every recording with stairs or a known-level walk (gaitmap stairs up/down, both feet; x-io x-IMU stairs
and spiral stairs; the iez and x-io NGIMU closed loops on one floor) run ``process`` with the height free
(``off``), the level-stride hold only (``hold``) and hold + storeys (``on``, the default) and print the
height change end − start, the highest and lowest footprint, and what the storeys found (flights, risers,
riser estimate). No height truth exists for these sets except "the loop is level" (iez, NGIMU: end height
= start height) and "both feet climb the same" (gaitmap): the checks are that ``on`` keeps every climb of
``off`` within a riser or so (stairs not flattened), and that the level loops end nearer their start height.

Usage: ``nice -n 10 .venv/bin/python benchmarks/floors_realdata.py [--root /work/shared/datasets]``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

FILES = [("gaitmap_example/stair_up/imu_left.csv.gz", "stairs"), ("gaitmap_example/stair_up/imu_right.csv.gz", "stairs"),
         ("gaitmap_example/stair_down/imu_left.csv.gz", "stairs"),
         ("gaitmap_example/stair_down/imu_right.csv.gz", "stairs"),
         ("xio_ximu/stairsAndCorridor/imu.csv.gz", "stairs"), ("xio_ximu/spiralStairs/imu.csv.gz", "stairs"),
         ("xio_ximu/straightLine/imu.csv.gz", "level")]
LEVEL_SETS = ("iez_mpu6050", "xio_ngimu_loops")
CONFIGS = {"off": (False, False), "hold": (True, False), "on": (True, True)}


def run(path: Path, config: str) -> dict:
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings
    from bootnav.postproc.strides import footprints

    s = ProcessSettings()
    s.filter.level_height, s.floor_storeys = CONFIGS[config]
    r = process(path, s)
    _, fp = footprints(r.t_s, r.pos_n, r.stance)
    z = fp[:, 2] - fp[0, 2]
    st = r.summary["path"].get("storeys") or {}
    return {"dz_end_m": float(z[-1]), "z_max_m": float(z.max()), "z_min_m": float(z.min()),
            "flights": st.get("flights", 0), "risers": st.get("risers", 0),
            "riser_m": st.get("riser_estimate_m", float("nan")), "final_floor": r.summary["path"].get("final_floor")}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--root", type=Path, default=Path("/work/shared/datasets"))
    a = ap.parse_args(argv)
    files = [(a.root / f, kind) for f, kind in FILES]
    for s in LEVEL_SETS:
        files += [(p, "level") for p in sorted((a.root / s).glob("*/imu.csv.gz"))]
    level_abs = {c: [] for c in CONFIGS}
    for path, kind in files:
        if not path.exists():
            print(f"missing {path}")
            continue
        for config in CONFIGS:
            try:
                m = run(path, config)
            except Exception as exc:  # a recording the pipeline refuses: say so, go on
                print(f"{path.relative_to(a.root)} {config}: {type(exc).__name__}: {exc}")
                continue
            if kind == "level":
                level_abs[config].append(abs(m["dz_end_m"]))
            print(f"{str(path.relative_to(a.root)):55s} {kind:6s} {config:4s} "
                  + " ".join(f"{k}={v:.3f}" if isinstance(v, float) else f"{k}={v}" for k, v in m.items()), flush=True)
    for config, v in level_abs.items():
        if v:
            print(f"SUMMARY level recordings n={len(v)} {config}: |end - start height| median {np.median(v):.3f} m, "
                  f"max {np.max(v):.3f} m")


if __name__ == "__main__":
    main()
