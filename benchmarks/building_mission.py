"""Building missions with the heading aid off / auto / forced on (issue 24): simulated searches of seeded
buildings (``bootnav simulate --scenario building``), processed by ``process`` with ``filter.heading_aid``
``none``, ``auto`` and ``dominant_directions``, per sensor profile.

``none+revisits`` and ``auto+revisits``: the revisit pose graph (``filter.revisits = "entry+stairs"``,
``postproc.building.revisits``) applied to that run's result. Figures per walk (after a yaw alignment over the first 10 m of the true path, as an entry door would give it;
the same rule as ``benchmarks/mission.py``): final and RMS horizontal error, the share of true stance samples
whose height is within 1.5 m of the truth, and what ``auto`` decided (on/off, share of straight strides on a
90° grid). Printed as medians and worst values over the seeds (asserts nothing); ``--json`` keeps every row.

    nice -n 10 .venv/bin/python benchmarks/building_mission.py --seeds 2001-2020 \
        --profiles mpu6050-16g-2000dps mpu6050-noise-only ideal --jobs 2 --json building_mission.json

Recordings are cached under ``--cache`` (scenario, seed, profile, duration, rate), so a re-run only processes.
Seeds 2001-2020 were never used while designing the scenario or the rule (those used 0-12, 100).
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from multiprocessing import get_context
from pathlib import Path

import numpy as np

ALIGN_M = 10.0
HEIGHT_TOL_M = 1.5
AIDS = ("none", "auto", "dominant_directions")
REVISIT_AFTER = ("none", "auto")


def seeds_arg(text: str) -> list[int]:
    out = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b) + 1)) if b else [int(a)]
    return out


def metrics(pos_est: np.ndarray, pos_true: np.ndarray, stance_true: np.ndarray) -> dict:
    est = pos_est - pos_est[0]
    tru = pos_true - pos_true[0]
    walked = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(tru[:, :2], axis=0), axis=1))))
    k = int(min(np.searchsorted(walked, ALIGN_M), len(walked) - 1))
    yaw = math.atan2(*(tru[k, 1::-1])) - math.atan2(*(est[k, 1::-1]))
    c, s = math.cos(yaw), math.sin(yaw)
    xy = est[:, :2] @ np.array([[c, s], [-s, c]])
    h = np.linalg.norm(xy - tru[:, :2], axis=1)
    v = np.abs(est[:, 2] - tru[:, 2])
    st = np.asarray(stance_true, bool)
    return {"final_h_m": float(h[-1]), "armse_h_m": float(np.sqrt(np.mean(h**2))), "worst_h_m": float(h.max()),
            "stance_within_tol_pct": float(100.0 * np.mean(v[st] <= HEIGHT_TOL_M))}


def recording(seed: int, profile: str, duration: float, rate: float, cache: Path) -> Path:
    from bootnav.simulator import simulate, write_h5

    path = cache / f"building_s{seed}_{profile}_{duration:g}s_{rate:g}hz.h5"
    if not path.exists():
        tmp = path.with_suffix(".tmp.h5")
        tmp.unlink(missing_ok=True)
        write_h5(simulate("building", seed=seed, profile=profile, rate_hz=rate, duration_s=duration), tmp)
        tmp.rename(path)
    return path


def run_one(args) -> list[dict]:
    seed, profile, duration, rate, cache = args
    from dataclasses import replace
    from types import SimpleNamespace

    import h5py

    from bootnav.postproc.building.revisits import apply_revisits
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings

    t0 = time.perf_counter()
    path = recording(seed, profile, duration, rate, Path(cache))
    t_sim = time.perf_counter() - t0
    with h5py.File(path, "r") as f:
        truth = {k: f["truth"][k][()] for k in ("pos_n_m", "stance")}
    rows = []
    for aid in AIDS:
        s = ProcessSettings.from_dict({"filter": {"heading_aid": aid}})
        s.output.plots = False
        t1 = time.perf_counter()
        res = process(path, s)
        dec = res.nav.info.get("heading_decision", {})
        row = {"seed": seed, "profile": profile, "aid": aid, "sim_s": t_sim, "process_s": time.perf_counter() - t1,
               **metrics(np.asarray(res.pos_n), truth["pos_n_m"], truth["stance"]),
               "auto_on": dec.get("on"), "auto_share": dec.get("share"), "auto_cross": dec.get("cross"),
               "heading_aid_updates": res.nav.info.get("heading_aid_updates")}
        rows.append(row)
        if aid in REVISIT_AFTER:  # the pose graph on this result (what revisits = "entry+stairs" would do)
            nav = SimpleNamespace(pos_n=np.asarray(res.pos_n), pos_sigma_n=res.nav.pos_sigma_n, info={})
            nav = apply_revisits(nav, np.asarray(res.t_s), np.asarray(res.stance, bool),
                                 replace(s.filter, revisits="entry+stairs"))
            kinds = [e["kind"] for e in nav.info["revisits"]["edges"]]
            rows.append({**row, "aid": f"{aid}+revisits", **metrics(nav.pos_n, truth["pos_n_m"], truth["stance"]),
                         "revisit_edges": {k: kinds.count(k) for k in set(kinds)}})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=seeds_arg, default=seeds_arg("2001-2020"))
    ap.add_argument("--profiles", nargs="+", default=["mpu6050-16g-2000dps", "mpu6050-noise-only", "ideal"])
    ap.add_argument("--duration", type=float, default=1800.0)
    ap.add_argument("--rate", type=float, default=200.0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "bootnav-building-cache")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    args.cache.mkdir(parents=True, exist_ok=True)
    todo = [(s, p, args.duration, args.rate, str(args.cache)) for p in args.profiles for s in args.seeds]
    rows: list[dict] = []
    with get_context("spawn").Pool(args.jobs) as pool:
        for part in pool.imap_unordered(run_one, todo):
            rows += part
            r = part[0]
            print(f"  seed {r['seed']} {r['profile']}: " + ", ".join(
                f"{x['aid']} {x['final_h_m']:.1f}/{x['armse_h_m']:.1f} m" for x in part) +
                f" (final/ARMSE; auto {'on' if part[2]['auto_on'] else 'off'}, share {part[2]['auto_share'] or 0:.2f})",
                flush=True)
            if args.json:
                args.json.write_text(json.dumps({"rows": rows}, indent=1))
    print(f"\n{'profile':22s} {'aid':20s} {'n':>3s} {'final med':>9s} {'final max':>9s} {'ARMSE med':>9s} "
          f"{'floor% med':>10s} {'auto on':>7s}")
    for p in args.profiles:
        for aid in ("none", "none+revisits", "auto", "auto+revisits", "dominant_directions"):
            sel = [r for r in rows if r["profile"] == p and r["aid"] == aid]
            if not sel:
                continue
            f = np.array([r["final_h_m"] for r in sel])
            a = np.array([r["armse_h_m"] for r in sel])
            z = np.array([r["stance_within_tol_pct"] for r in sel])
            on = sum(bool(r["auto_on"]) for r in sel) if aid.startswith("auto") else ""
            print(f"{p:22s} {aid:20s} {len(sel):3d} {np.median(f):9.2f} {f.max():9.2f} {np.median(a):9.2f} "
                  f"{np.median(z):10.1f} {on!s:>7s}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
