"""Regenerate the SYNTHETIC import samples in tests/data/ (deterministic, seed 0).

These files imitate formats for which no public sample sits in /work/shared/datasets/raw-formats/:
Physics Toolbox Sensor Suite (Android: semicolon + decimal comma; iOS: comma + date-time text, repeated
rows), phyphox 'Acceleration with g' (comma and semicolon/decimal-comma exports), a 20 Hz waist-belt log
in the spirit of seed-000 (H48C accelerometer in g + compass heading), and the 19-column SensorConnect
est* export. The signals are a made-up walk: gravity on one axis plus 2 Hz step oscillations; no real
person walked. Run: python tests/data/make_synthetic.py
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
G = 9.80665


def walk(n: int, rate: float, rng: np.random.Generator, rest_s: float = 2.0):
    """Specific force (g units, z up) and angular rate (rad/s) of a waist/phone during a walk."""
    t = np.arange(n) / rate
    moving = (t > rest_s).astype(float)
    acc_g = np.zeros((n, 3))
    acc_g[:, 0] = 0.15 * np.sin(2 * np.pi * 1.0 * t) * moving
    acc_g[:, 1] = 0.10 * np.sin(2 * np.pi * 2.0 * t + 0.5) * moving
    acc_g[:, 2] = 1.0 + 0.25 * np.sin(2 * np.pi * 2.0 * t) * moving
    acc_g += rng.normal(0, 0.004, (n, 3))
    gyro = np.zeros((n, 3))
    gyro[:, 0] = 0.6 * np.sin(2 * np.pi * 1.0 * t) * moving
    gyro[:, 2] = 0.3 * np.sin(2 * np.pi * 2.0 * t) * moving
    gyro += rng.normal(0, 0.003, (n, 3))
    return t, acc_g, gyro


def dc(x: float, fmt: str) -> str:
    return format(x, fmt).replace(".", ",")


def main() -> None:
    rng = np.random.default_rng(0)

    # Physics Toolbox Sensor Suite, Android, German locale: ';' + decimal comma; stale rows repeated.
    t, a, w = walk(1000, 100.0, rng)
    lines = ["time;gFx;gFy;gFz;wx;wy;wz;TgF"]
    for i in range(t.size):
        j = i - 1 if i % 7 == 3 else i  # the app re-sends the previous sample now and then
        row = [dc(t[i], ".3f")] + [dc(v, ".3f") for v in a[j]] + [dc(v, ".4f") for v in w[j]]
        row.append(dc(float(np.linalg.norm(a[j])), ".3f"))
        lines.append(";".join(row))
    (HERE / "physics_toolbox_android_synthetic.csv").write_text("\n".join(lines) + "\n")

    # Physics Toolbox, iOS: ',' + date-time text, g-force only, rows repeated with identical time.
    t, a, _ = walk(600, 100.0, rng)
    t0 = dt.datetime(2018, 10, 3, 17, 23, 55, 464000)
    lines = ["time,gFx,gFy,gFz,gFTotal"]
    for i in range(t.size):
        stamp = (t0 + dt.timedelta(seconds=float(t[i]))).strftime("%Y-%m-%d %H:%M:%S.%f")[:-2]
        row = f"{stamp}," + ",".join(f"{v:.3f}" for v in a[i]) + f",{np.linalg.norm(a[i]):.3f}"
        lines.append(row)
        if i % 50 == 10:
            lines.append(row)  # exact repeat, as the iOS app does
    (HERE / "physics_toolbox_ios_synthetic.csv").write_text("\r\n".join(lines) + "\r\n")

    # phyphox "Acceleration with g": comma export and semicolon/decimal-comma export.
    t, a, _ = walk(800, 100.0, rng)
    t = t - 0.0021  # phyphox time starts slightly negative
    hdr = ['"Time (s)"', '"Acceleration x (m/s^2)"', '"Acceleration y (m/s^2)"', '"Acceleration z (m/s^2)"',
           '"Absolute acceleration (m/s^2)"']
    rows = [[t[i], *(a[i] * G), np.linalg.norm(a[i]) * G] for i in range(t.size)]
    (HERE / "phyphox_acc_comma_synthetic.csv").write_text(
        ",".join(hdr) + "\n" + "\n".join(",".join(f"{v:.9E}" for v in r) for r in rows))  # no final newline
    (HERE / "phyphox_acc_semicolon_decimal_comma_synthetic.csv").write_text(
        ";".join(hdr) + "\n" + "\n".join(";".join(dc(v, ".9E") for v in r) for r in rows) + "\n")

    # 20 Hz waist belt (seed-000): time in ms from a PDA tick counter, acc in g, compass heading.
    t, a, _ = walk(600, 20.0, rng)
    heading = (90.0 + 5 * np.sin(2 * np.pi * 0.1 * t) + rng.normal(0, 1.0, t.size)) % 360
    lines = ["# waist belt log, 20 Hz, H48C +-3 g, HMR3300 heading (SYNTHETIC sample for bootnav tests)",
             "time_ms\tacc_x_g\tacc_y_g\tacc_z_g\theading_deg"]
    tick0 = 5_123_450
    lines += [f"{tick0 + int(round(t[i] * 1000))}\t{a[i, 0]:.3f}\t{a[i, 1]:.3f}\t{a[i, 2]:.3f}\t{heading[i]:.1f}"
              for i in range(t.size)]
    (HERE / "waist20_seed000_synthetic.txt").write_text("\n".join(lines) + "\n")

    # SensorConnect est* export (19 columns, 250 Hz): channel then its :valid flag.
    t, a, w = walk(1250, 250.0, rng)
    dev = "inertial-6253.76535:"
    names = ["Time"]
    for ch in ("estCompensatedAccelX", "estCompensatedAccelY", "estCompensatedAccelZ",
               "estAngularRateX", "estAngularRateY", "estAngularRateZ", "estRoll", "estPitch", "estYaw"):
        names += [dev + ch, dev + ch + ":valid"]
    lines = [",".join(names)]
    for i in range(t.size):
        vals = [*(a[i] * G), *w[i], 0.01, -0.02, 1.2]
        valid = 0 if i < 5 else 1  # the filter output is not valid for the first samples
        lines.append(f"{t[i]:.8g}," + ",".join(f"{v:.9g},{valid}" for v in vals))
    (HERE / "koroglu_sensorconnect_est_synthetic.csv").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
