"""pyshoe's published fixed-threshold ZUPT-EKF next to bootnav on the pyshoe_vicon developer trials.

What runs as "pyshoe's defaults" (read from github.com/utiasSTARS/pyshoe, ``ins_tools/INS.py``,
``ins_tools/EKF.py``, ``process_error_hallway.py`` / ``process_error_stairs.py``; reimplemented here, not
copied) [Wagstaff2017]:

* SHOE detector on non-overlapping windows of W = 5 samples: T = (1/W) Σ ‖a − g ā/‖ā‖‖²/σ_a² + ‖ω‖²/σ_ω²,
  stance where T < G, with the MicroStrain σ_a = 0.00098 m/s², σ_ω = 8.7266463e-5 rad/s, g = 9.8029 m/s² and
  the threshold of its published tables G = 8.5e7 (the hallway/stairs scripts' fixed SHOE value; the VICON
  table's per-trial optimised thresholds are not a default and are not used);
* 9-state error-state EKF in pyshoe's North-East-Down frame, fixed step T = 1/200 s, process noise per step
  G Q Gᵀ with σ = 0.5 m/s² and 0.5 °/s (G = dt·C_nb), zero-velocity measurement σ = 0.01 m/s, initial
  σ 1e-5 m / 1e-5 m/s / 0.1°, roll and pitch from the mean of the first 20 samples, no smoother, no bias
  states, no extras.

Its path (N, E, Up) is given y negated, which is the right-handed frame the dataset's truth uses (the
set README), and both are scored by ``bootnav.postproc.evaluate.metrics.trajectory_metrics`` (METRICS.md).
bootnav runs with its default settings through ``evaluate.runner.estimate_foot`` / ``score_foot`` (what
``bootnav eval`` does). Per trial the benchmark prints both ``armse_2d``, which wins, and what differs: the stance fraction
of each mask, each mask's per-sample precision/recall against the VICON stance labels, bootnav's stance
choice, confidence and stride flags.

    nice -n 10 .venv/bin/python benchmarks/pyshoe_baseline.py            # 16 trials, ~1-2 min on 2 cores
    nice -n 10 .venv/bin/python benchmarks/pyshoe_baseline.py --json out.json --jobs 2
    nice -n 10 .venv/bin/python benchmarks/pyshoe_baseline.py --swap     # + each filter with the other's mask
    nice -n 10 .venv/bin/python benchmarks/pyshoe_baseline.py --cut 0.5 1   # trials cut to start in motion

Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import os
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
DEFAULT_ROOT = next((p for p in (REPO.parent / "shared" / "datasets", Path("/work/shared/datasets")) if p.exists()),
                    REPO.parent / "shared" / "datasets")

# pyshoe's published values (ins_tools/INS.py, the MicroStrain scripts)
W = 5
G_SHOE = 8.5e7
SIGMA_A = 0.00098  # m/s², SHOE's accelerometer weight
SIGMA_W = 8.7266463e-5  # rad/s, SHOE's gyro weight
GRAV = 9.8029  # m/s²
T_STEP = 1.0 / 200.0  # s, fixed step of the MicroStrain scripts
SIGMA_ACC_Q = 0.5  # m/s² per step
SIGMA_GYRO_Q = np.deg2rad(0.5)  # rad/s per step
SIGMA_ZUPT = 0.01  # m/s


def shoe_mask(acc: np.ndarray, gyr: np.ndarray, w: int = W, thresh: float = G_SHOE) -> np.ndarray:
    """pyshoe's SHOE on non-overlapping windows of ``w`` samples; the tail shorter than a window is motion."""
    n = acc.shape[0]
    m = n // w
    a = acc[: m * w].reshape(m, w, 3)
    g = gyr[: m * w].reshape(m, w, 3)
    mean_a = a.mean(axis=1, keepdims=True)
    up = GRAV * mean_a / np.linalg.norm(mean_a, axis=2, keepdims=True)
    t = (np.sum((a - up) ** 2, axis=(1, 2)) / SIGMA_A**2 + np.sum(g**2, axis=(1, 2)) / SIGMA_W**2) / w
    zv = np.zeros(n, dtype=bool)
    zv[: m * w] = np.repeat(t < thresh, w)
    return zv


def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _rot_from_rpy(roll, pitch, yaw):
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def _orthonormal(c):
    u, _, vt = np.linalg.svd(c)
    return u @ vt


def pyshoe_ekf(acc: np.ndarray, gyr: np.ndarray, zv: np.ndarray) -> np.ndarray:
    """(N, 3) positions in pyshoe's output frame (North, East, Up) of its 9-state ZUPT-EKF (module docstring)."""
    n = acc.shape[0]
    dt = T_STEP
    a0 = acc[:20].mean(axis=0)
    roll = np.arctan2(-a0[1], -a0[2])
    pitch = np.arctan2(a0[0], np.hypot(a0[1], a0[2]))
    c_nb = _rot_from_rpy(roll, pitch, 0.0)
    p, v = np.zeros(3), np.zeros(3)
    P = np.diag([1e-10] * 6 + [np.deg2rad(0.1) ** 2] * 3)
    Q = np.diag([SIGMA_ACC_Q**2] * 3 + [SIGMA_GYRO_Q**2] * 3)
    H = np.zeros((3, 9))
    H[:, 3:6] = np.eye(3)
    R = np.eye(3) * SIGMA_ZUPT**2
    gvec = np.array([0.0, 0.0, GRAV])
    out = np.zeros((n, 3))
    eye3, eye9 = np.eye(3), np.eye(9)
    for k in range(1, n):
        w = gyr[k]
        nw = np.linalg.norm(w)
        c_prev = c_nb
        if nw * dt > 0:  # exact rotation over the step (pyshoe's quaternion exponential)
            ax = w / nw
            ang = nw * dt
            K_ = _skew(ax)
            c_nb = c_nb @ (eye3 + np.sin(ang) * K_ + (1 - np.cos(ang)) * K_ @ K_)
        f_n = c_nb @ acc[k] + gvec
        v = v + dt * f_n
        p = p + dt * v + 0.5 * dt * dt * f_n
        F = eye9.copy()
        F[0:3, 3:6] = dt * eye3
        F[3:6, 6:9] = -dt * _skew(c_prev @ acc[k])
        Gm = np.zeros((9, 6))
        Gm[3:6, 0:3] = dt * c_prev
        Gm[6:9, 3:6] = -dt * c_prev
        P = F @ P @ F.T + Gm @ Q @ Gm.T
        P = 0.5 * (P + P.T)
        if zv[k]:
            S = H @ P @ H.T + R
            K = P @ H.T @ np.linalg.inv(S)
            dx = K @ (-v)
            p, v = p + dx[0:3], v + dx[3:6]
            c_nb = _orthonormal((eye3 + _skew(dx[6:9])) @ c_nb)
            P = (eye9 - K @ H) @ P
            P = 0.5 * (P + P.T)
        out[k] = p
    out[:, 2] = -out[:, 2]
    return out


def _stance_pr(t_est, stance_est, folder: Path) -> tuple[float, float]:
    from bootnav.postproc.evaluate.metrics import stance_metrics
    from bootnav.postproc.evaluate.runner import read_csv_columns

    ts = read_csv_columns(folder / "truth_stance.csv.gz")
    inside = (ts["t_s"] >= t_est[0]) & (ts["t_s"] <= t_est[-1])
    m = stance_metrics(t_est, stance_est, ts["t_s"][inside], ts["stance"][inside])
    return m["stance_precision"], m["stance_recall"]


def one(args) -> dict:
    trial, root, swap, cut = args
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from bootnav.postproc.evaluate.metrics import trajectory_metrics
    from bootnav.postproc.evaluate.runner import estimate_foot, read_csv_columns, read_imu, score_foot

    folder = Path(root) / trial["path"]
    t, acc, gyr = read_imu(folder / "imu.csv.gz")
    tr = read_csv_columns(folder / "truth_trajectory.csv.gz")
    truth = np.column_stack([tr["x_m"], tr["y_m"], tr["z_m"]])
    imu_path = folder / "imu.csv.gz"
    tmp = None
    if cut != (0.0, 1.0):  # the trial cut to [a, b) of its samples: it starts (and ends) with the foot in motion
        import gzip
        import tempfile

        a, b = int(cut[0] * len(t)), int(cut[1] * len(t))
        t, acc, gyr = t[a:b], acc[a:b], gyr[a:b]
        tmp = tempfile.TemporaryDirectory()
        imu_path = Path(tmp.name) / "imu.csv.gz"
        with gzip.open(imu_path, "wt") as fh:
            fh.write("t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps\n")
            np.savetxt(fh, np.column_stack([t, acc, gyr]), delimiter=",", fmt="%.6f")
    zv = shoe_mask(acc, gyr)
    pos = pyshoe_ekf(acc, gyr, zv)
    pos[:, 1] = -pos[:, 1]  # (N, E, Up) -> the right-handed frame of the set's truth
    ps = trajectory_metrics(t, pos, tr["t_s"], truth)
    ps_p, ps_r = _stance_pr(t, zv, folder)
    row = {"id": trial["id"], "pyshoe_armse_2d": ps["armse_2d"], "pyshoe_stance_frac": float(zv.mean()),
           "pyshoe_stance_precision": ps_p, "pyshoe_stance_recall": ps_r}
    from bootnav.errors import BootnavError
    from bootnav.postproc.settings import ProcessSettings

    try:
        fe = estimate_foot(imu_path, ProcessSettings())
    except BootnavError as exc:  # a refusal counts (METRICS.md: never silently skipped)
        row.update(bootnav_armse_2d=float("nan"), refused=str(exc)[:160])
        return row
    finally:
        if tmp is not None:
            tmp.cleanup()
    scored, _ = score_foot(fe, folder, [k for k in trial["truth"] if k != "none"], "imu.csv.gz")
    b_p, b_r = _stance_pr(fe.t_s, fe.stance, folder)
    nav = fe.result.summary["navigation"]
    row.update(bootnav_armse_2d=scored["armse_2d"], bootnav_stance_frac=float(fe.stance.mean()),
               bootnav_stance_precision=b_p, bootnav_stance_recall=b_r, choice=nav.get("stance_choice"),
               confidence=nav.get("confidence"), configured_failed=nav.get("configured_failed"),
               stride_flags=nav.get("stride_flags"), implausible=nav.get("implausible_stride_fraction"))
    if swap:  # what differs: each filter with the other's stance mask
        if len(fe.stance) == len(t):
            pos2 = pyshoe_ekf(acc, gyr, np.asarray(fe.stance, bool))
            pos2[:, 1] = -pos2[:, 1]
            row["pyshoe_ekf_bootnav_mask"] = trajectory_metrics(t, pos2, tr["t_s"], truth)["armse_2d"]
        row["bootnav_pyshoe_mask"] = _bootnav_with_mask(folder, trial, lambda a, g: shoe_mask(a, g))
    return row


def _bootnav_with_mask(folder, trial, mask_fn) -> float:
    """bootnav's pipeline (filter, timing calibration, smoother, fallback policy) with its configured stance
    detector replaced by ``mask_fn(acc_b, gyro_b)``; armse_2d."""
    import bootnav.postproc.detectors as det
    from bootnav.postproc.detectors.base import StanceResult
    from bootnav.postproc.evaluate.runner import estimate_foot, score_foot
    from bootnav.postproc.settings import ProcessSettings

    orig = det.detect_stance
    calls = []

    def patched(t_s, acc_b, gyro_b, settings=None, gravity=9.80665, *, saturated=None):
        calls.append(1)
        if len(calls) > 1:  # the fallback's candidates stay bootnav's
            return orig(t_s, acc_b, gyro_b, settings, gravity, saturated=saturated)
        m = mask_fn(np.asarray(acc_b), np.asarray(gyro_b))
        return StanceResult(m, np.zeros(len(m)), 0.0, "pyshoe-shoe", {})

    det.detect_stance = patched
    try:
        fe = estimate_foot(folder / "imu.csv.gz", ProcessSettings())
        return score_foot(fe, folder, [k for k in trial["truth"] if k != "none"], "imu.csv.gz")[0]["armse_2d"]
    except Exception as exc:
        return float("nan")
    finally:
        det.detect_stance = orig


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", default=str(DEFAULT_ROOT))
    ap.add_argument("--trials", nargs="*", help="only these trial ids")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json", help="write every figure here")
    ap.add_argument("--swap", action="store_true", help="also run each filter with the other's stance mask")
    ap.add_argument("--cut", nargs=2, type=float, default=[0.0, 1.0], metavar=("FROM", "TO"),
                    help="run the trials cut to this fraction of their samples (e.g. 0.5 1: from half-way)")
    a = ap.parse_args(argv)
    if a.swap and tuple(a.cut) != (0.0, 1.0):
        ap.error("--swap runs whole trials only")
    man = json.loads((Path(a.root) / "manifest.json").read_text())
    trials = [t for t in man["trials"] if t["set"] == "pyshoe_vicon" and (not a.trials or t["id"] in a.trials)]
    with ProcessPoolExecutor(a.jobs) as ex:
        rows = list(ex.map(one, [(t, a.root, a.swap, tuple(a.cut)) for t in trials]))
    print("| trial | pyshoe armse_2d m | bootnav armse_2d m | winner | stance frac ps / bn | stance P/R ps | "
          "stance P/R bn | bootnav choice | conf |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        b = r["bootnav_armse_2d"]
        win = "pyshoe" if not (b <= r["pyshoe_armse_2d"]) else "bootnav"
        print(f"| {r['id'].split('/')[-1]} | {r['pyshoe_armse_2d']:.3f} | {b:.3f} | {win} | "
              f"{r['pyshoe_stance_frac']:.2f} / {r.get('bootnav_stance_frac', float('nan')):.2f} | "
              f"{r['pyshoe_stance_precision']:.2f}/{r['pyshoe_stance_recall']:.2f} | "
              f"{r.get('bootnav_stance_precision', float('nan')):.2f}/{r.get('bootnav_stance_recall', float('nan')):.2f} | "
              f"{r.get('choice', r.get('refused', ''))} | {r.get('confidence', float('nan')):.2f} |")
    if a.swap:
        print("\n| trial | pyshoe EKF + pyshoe mask | pyshoe EKF + bootnav mask | bootnav + pyshoe mask | bootnav |")
        print("|---|---|---|---|---|")
        for r in rows:
            print(f"| {r['id'].split('/')[-1]} | {r['pyshoe_armse_2d']:.3f} | {r.get('pyshoe_ekf_bootnav_mask', float('nan')):.3f} | "
                  f"{r.get('bootnav_pyshoe_mask', float('nan')):.3f} | {r['bootnav_armse_2d']:.3f} |")
    ps = np.array([r["pyshoe_armse_2d"] for r in rows])
    bn = np.array([r["bootnav_armse_2d"] for r in rows])
    wins = [r["id"] for r in rows if not (r["bootnav_armse_2d"] <= r["pyshoe_armse_2d"])]
    print(f"\npyshoe defaults: mean {np.nanmean(ps):.3f} m, median {np.nanmedian(ps):.3f}, worst {np.nanmax(ps):.3f}")
    print(f"bootnav:         mean {np.nanmean(bn):.3f} m, median {np.nanmedian(bn):.3f}, worst {np.nanmax(bn):.3f}"
          f" ({int(np.isnan(bn).sum())} refused or failed)")
    print(f"pyshoe's defaults win on {len(wins)} of {len(rows)} trials: {', '.join(w.split('/')[-1] for w in wins)}")
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
