"""Where a footprint walk loses its heading: per stride, the estimated stride direction against the surveyed
footprints, the yaw the filter turned in stance and in swing, and how close the gyro came to its rails.

Why (issue 28): koroglu_footprints runs 34 and 35 (out-and-back corridor walks) carry the set's mean error and
were thought to lose heading in a 180° turn on the spot (the foot pivoting while loaded). This prints what the
data say, for any set with footprint truth:

- ``dh``: estimated minus true direction of each stride (footprint to footprint, estimate aligned as METRICS.md
  aligns it), deg. A constant ``dh`` is harmless; its change along the walk is the heading error that moves
  the end point.
- ``dpsi``: change of the sensor's heading (yaw of the filter's attitude) from this footprint's stance to the
  next one's, deg (both with the foot near flat, so it is the foot's turn over the stride).
- ``turn_st``: yaw turned about the vertical in the stride's stance samples (∫ ω_n,z dt, deg): a pivot on the
  loaded foot shows up here.
- ``wz_st``: largest |ω_n,z| in the stride's stance samples, rad/s (a pivot turns the loaded foot at > 1 rad/s).
- ``rail``: samples of the stride within ``--rail-tol`` of the recording's per-axis, per-sign gyro extreme,
  on an axis whose extreme is approached in ≥ 3 separate excursions (a calibrated output clipped at a full-scale
  rail does not repeat one exact value, so ``bootnav.core.arrays.clipped_axes`` does not see it).

The trial line adds the filter's final gyro-bias estimate next to the mean gyro of the last still stance
(≥ 0.5 s; the true bias there, to its std). Reads the truth; changes nothing.

``--initial-gyro-bias gx gy gz`` (mrad/s) replaces the initial gyro bias the alignment took from the start
(an experiment: is a walk's heading drift its start's bias estimate?). Prints the footprint error too.

    nice -n 10 .venv/bin/python benchmarks/footprint_turns.py --trials koroglu_footprints/run34 [--set k=v ...]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))

from crossval import DEFAULT_ROOT, parse_value, settings_with  # noqa: E402


def near_rail(gyro: np.ndarray, rel_tol: float, min_excursions: int = 3) -> np.ndarray:
    """bool (N,): samples within ``rel_tol`` of a per-axis, per-sign extreme reached in ≥ ``min_excursions``
    separate runs (a rail, not one peak)."""
    out = np.zeros(len(gyro), dtype=bool)
    for k in range(gyro.shape[1]):
        for sign in (1.0, -1.0):
            x = sign * gyro[:, k]
            peak = float(np.max(x))
            if peak <= 0:
                continue
            m = x >= peak * (1.0 - rel_tol)
            starts = np.count_nonzero(np.diff(m.astype(np.int8)) == 1) + int(m[0])
            if starts >= min_excursions:
                out |= m
    return out


def yaw_rate_nav(q_nb: np.ndarray, gyro_b: np.ndarray) -> np.ndarray:
    """ω_n,z (rad/s): the body rate rotated into the nav frame (q_nb scalar first), its vertical part."""
    w, u = q_nb[:, :1], q_nb[:, 1:]
    t = 2.0 * np.cross(u, gyro_b)
    return (gyro_b + w * t + np.cross(u, t))[:, 2]


def _wrap(a):
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def trial_table(folder: Path, settings, rail_tol: float) -> tuple[str, list[str]]:
    from bootnav.postproc.evaluate.metrics import align_to_truth
    from bootnav.postproc.evaluate.runner import estimate_foot, read_csv_columns

    est = estimate_foot(folder / "imu.csv.gz", settings)
    res = est.result
    fp = read_csv_columns(folder / "truth_footprints.csv")
    fp_t, fp_xy = fp["t_s"], np.column_stack([fp["x_m"], fp["y_m"]])
    t = est.t_s
    aligned, _, _ = align_to_truth(t, est.pos_n, fp_t, np.column_stack([fp_xy, np.zeros(len(fp_xy))]),
                                   t_origin=fp_t[0])
    at = np.column_stack([np.interp(fp_t, t, aligned[:, k]) for k in range(2)])
    d_true, d_est = np.diff(fp_xy, axis=0), np.diff(at, axis=0)
    h_true = np.degrees(np.arctan2(d_true[:, 1], d_true[:, 0]))
    dh = (np.degrees(np.arctan2(d_est[:, 1], d_est[:, 0])) - h_true + 180.0) % 360.0 - 180.0
    q = np.asarray(res.q_nb)
    psi = np.arctan2(2.0 * (q[:, 0] * q[:, 3] + q[:, 1] * q[:, 2]), 1.0 - 2.0 * (q[:, 2] ** 2 + q[:, 3] ** 2))
    wz = yaw_rate_nav(np.asarray(res.q_nb), np.asarray(res.gyro_b))
    dt = np.gradient(t)
    st = np.asarray(res.stance, bool)
    rail = near_rail(np.asarray(res.gyro_b), rail_tol)
    idx = np.clip(np.searchsorted(t, fp_t), 0, len(t) - 1)
    rows = []
    for k in range(len(fp_t) - 1):
        s = slice(idx[k], idx[k + 1])
        turn = wz[s] * dt[s]
        wst = np.abs(wz[s][st[s]])
        rows.append(f"{k:4d} {fp_t[k]:7.2f} {np.hypot(*d_true[k]):6.2f} {np.hypot(*d_est[k]):6.2f} {h_true[k]:7.1f} "
                    f"{dh[k]:7.1f} {np.degrees(_wrap(psi[idx[k + 1]] - psi[idx[k]])):8.1f} {np.degrees(turn[st[s]].sum()):8.1f} "
                    f"{(wst.max() if wst.size else 0.0):6.2f} {int(rail[s].sum()):5d}")
    bias = getattr(res.nav, "gyro_bias_b", None)
    edges = np.flatnonzero(np.diff(np.r_[0, st.astype(np.int8), 0]))
    runs = [(a, b) for a, b in zip(edges[::2], edges[1::2]) if t[b - 1] - t[a] >= 0.5]
    last = ""
    if runs and bias is not None:
        a, b = runs[-1]
        g = np.asarray(res.gyro_b)[a:b]
        last = (f"; gyro bias mrad/s: filter at end {np.round(1e3 * np.asarray(bias)[-1], 1).tolist()}, last still "
                f"stance ({t[a]:.1f}-{t[b - 1]:.1f} s) mean {np.round(1e3 * g.mean(0), 1).tolist()} "
                f"std {np.round(1e3 * g.std(0), 1).tolist()}")
    from bootnav.postproc.evaluate.runner import score_foot

    scored, _ = score_foot(est, folder, ["footprints"], "imu.csv.gz")
    head = (f"final_fp_err_pct {scored.get('final_fp_err_pct', float('nan')):.2f}; stance samples turning > 1 rad/s about the vertical: {int(np.count_nonzero(st & (np.abs(wz) > 1.0)))}; "
            f"near-rail gyro samples {int(rail.sum())} (in stance {int((rail & st).sum())}){last}")
    return head, rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", type=Path, default=DEFAULT_ROOT)
    ap.add_argument("--trials", nargs="*", default=None, help="trial ids (default: every footprints trial)")
    ap.add_argument("--rail-tol", type=float, default=0.01, help="relative distance to the gyro extreme (0.01)")
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE", help="setting override")
    ap.add_argument("--initial-gyro-bias", nargs=3, type=float, default=None, metavar=("GX", "GY", "GZ"),
                    help="replace the alignment's initial gyro bias, mrad/s (experiment)")
    args = ap.parse_args(argv)
    if args.initial_gyro_bias is not None:
        import bootnav.postproc.calibration as cal

        forced, align = 1e-3 * np.asarray(args.initial_gyro_bias, dtype=float), cal.initial_alignment

        def forced_alignment(*a, **k):
            init = align(*a, **k)
            init.gyro_bias_b = forced.copy()
            return init

        cal.initial_alignment = forced_alignment  # the pipeline imports it from the module at call time
    overrides = {}
    for kv in args.set:
        k, v = kv.split("=", 1)
        overrides[k] = parse_value(v)
    settings = settings_with(overrides)
    manifest = json.loads((args.root / "manifest.json").read_text())
    for tr in manifest["trials"]:
        if "footprints" not in tr["truth"] or (args.trials and tr["id"] not in args.trials):
            continue
        head, rows = trial_table(args.root / tr["path"], settings, args.rail_tol)
        print(f"\n## {tr['id']}: {head}")
        print("   k     t_s L_true  L_est  h_true      dh     dpsi  turn_st  wz_st  rail")
        print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
