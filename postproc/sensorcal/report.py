"""What ``bootnav calibrate`` prints and writes after a fit (shared by the file and the live mode): the
parameters with 1σ and the residuals as a small table, the calibration file (``--out``) and the store."""

from __future__ import annotations

import math
import sys


def finish(args, res) -> None:
    """Attach the fit record, write --out and the store, print the table (shared with the live mode)."""
    from dataclasses import replace

    from bootnav.core import sensorcal

    cal = replace(res.calibration, fit=res.fit_record())
    written = []
    if args.out:
        cal.save(args.out, force=args.force)
        written.append(str(args.out))
    if not args.no_store and cal.device_id:
        written.append(str(sensorcal.store_calibration(cal)))
    elif not args.no_store:
        print("bootnav calibrate: warning: no device id: not stored (written to --out only)", file=sys.stderr)
    cal = cal.with_source(written[0] if written else None)
    if args.json:
        print(cal.to_json(), end="")
    else:
        print(format_report(res, cal))
    if not args.quiet:
        for w in res.warnings:
            print(f"bootnav calibrate: warning: {w}", file=sys.stderr)
        for p in written:
            print(f"bootnav calibrate: wrote {p}", file=sys.stderr)


def format_report(res, cal=None) -> str:
    """The parameters with 1σ and the residuals, as a small table."""
    import numpy as np

    cal = cal or res.calibration
    lines = []
    n_poses = sum(len(p) for p in res.poses)
    n_turns = int(np.count_nonzero(res.motions.turn_n))
    tr = f", {cal.temp_range_degc[0]:.1f}..{cal.temp_range_degc[1]:.1f} °C" if cal.temp_range_degc else \
        f", T_ref {cal.temp_ref_degc:.1f} °C"
    lines.append(f"device {cal.device_id or '?'}: {len(res.poses)} session(s), {n_poses} static poses, "
                 f"{len(res.motions.label)} motions ({n_turns} full turns){tr}")
    lines.append(f"  {'parameter':<32}{'value':>14}{'1σ':>12}")

    def row(label, value, sd, fmt):
        lines.append(f"  {label:<32}{value:>14{fmt}}{sd:>12{fmt}}")

    def rows(title, tri, bias_unit, scale_bias, k_unit):
        lines.append(title)
        for i, a in enumerate("xyz"):
            row(f"scale correction {a} (C_{a}{a}-1) %", 100 * (tri.matrix[i, i] - 1),
                100 * tri.sigma.get(f"C_{a}{a}", float("nan")), ".4f")
        for i, a in enumerate("xyz"):
            for j, b in enumerate("xyz"):
                key = f"C_{a}{b}"
                if i != j and key in tri.sigma:
                    row(f"misalignment {key} °", math.degrees(tri.matrix[i, j]), math.degrees(tri.sigma[key]), ".4f")
        for i, a in enumerate("xyz"):
            row(f"bias {a} {bias_unit}", tri.bias[i] * scale_bias,
                tri.sigma.get(f"bias_{a}", float("nan")) * scale_bias, ".5f")
        if np.any(tri.bias_temp_coeff):
            for i, a in enumerate("xyz"):
                row(f"bias temp coeff {a} {k_unit}", tri.bias_temp_coeff[i] * scale_bias,
                    tri.sigma.get(f"temp_coeff_{a}", float("nan")) * scale_bias, ".6f")

    rows("accelerometer (C upper triangular: body frame = accelerometer axes)", cal.acc, "m/s²", 1.0, "m/s²/°C")
    rows("gyroscope (C full: into the accelerometer frame)", cal.gyro, "°/s", math.degrees(1.0), "°/s/°C")
    ar = res.accel.residuals
    lines.append(f"residuals: accelerometer |f| - g per pose rms {np.sqrt(np.mean(ar**2)):.4f} m/s², "
                 f"max {np.max(np.abs(ar)):.4f} m/s²")
    gr = res.gyro.residual_rad
    lines.append(f"           gyroscope up-direction error per motion rms {math.degrees(np.sqrt(np.mean(gr**2))):.4f}°, "
                 f"max {math.degrees(np.max(gr)):.4f}°")
    tres = res.gyro.turn_residual_rad[np.isfinite(res.gyro.turn_residual_rad)]
    if tres.size:
        lines.append(f"           full-turn heading residuals {', '.join(f'{math.degrees(v):+.2f}°' for v in tres)}")
    worst = int(np.argmax(gr)) if gr.size else None
    if worst is not None:
        lines.append(f"           worst motion: {res.motions.label[worst]}")
    return "\n".join(lines)
