"""``bootnav info FILE [--json]``: what is in a recording and how healthy it is.

Everything is computed from the data and the events table (not only from ``/meta``), so it also
works for a file whose recorder was killed before writing its final metadata, and for imported or
simulated recordings. ``FILE`` is what ``bootnav process`` reads: a recording, or any file ``bootnav
import`` reads (e.g. a canonical ``imu.csv.gz``), summarised as the recording ``import`` would write.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

AXES = ("ax", "ay", "az", "gx", "gy", "gz")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", metavar="FILE",
                        help="recording (.h5) or any file `bootnav import` reads (e.g. a canonical imu.csv.gz)")
    parser.add_argument("--json", action="store_true", help="print a machine-readable summary")


def load_any(path, boot=None):
    """A recording, or any other file through ``bootnav import``'s reader, as the ``Recording`` that
    ``import`` would store (written to a temporary file and loaded back, so ``info FILE`` and ``info`` of
    the imported recording agree). A ``.h5``/``.hdf5`` name is always read as a recording, so a damaged
    recording is reported as such rather than as an unreadable CSV.

    Parameters
    ----------
    path
        The file ``bootnav info`` was given.

    Returns
    -------
    Recording
        Without ``/truth``.
    """
    import tempfile
    from pathlib import Path

    import h5py

    from bootnav.logger.recording import load

    p = Path(path)
    if p.is_file() and p.suffix.lower() not in (".h5", ".hdf5") and not h5py.is_hdf5(p):
        from bootnav.logger.importers import read_any, write_result

        with tempfile.TemporaryDirectory(prefix="bootnav-info-") as tmp:
            return load(write_result(read_any(p), Path(tmp) / "imported.h5"), with_truth=False)
    return load(p, with_truth=False, boot=boot)


def summarize(path, boot=None) -> dict:
    """The summary ``bootnav info`` prints (also used by tests and other tools).

    Parameters
    ----------
    path
        A recording or any file ``bootnav import`` reads (``load_any``).
    boot
        The boot of a multi-boot recording (``bootnav.logger.recording.boot_labels``).

    Returns
    -------
    dict
        Timing, gaps, link errors, saturation, ranges, events, device metadata and data warnings.
    """
    import numpy as np

    from bootnav.core.timebase import gap_mask, missing_samples, nominal_period, timing_summary

    rec = load_any(path, boot)
    t = rec.t_s
    dt = np.diff(t)
    good = dt[np.isfinite(dt) & (dt > 0)]
    med = nominal_period(dt)
    timing = timing_summary(t)
    kinds = [k.decode() if isinstance(k, bytes) else str(k) for k in rec.events["kind"]]
    count_of = {k: kinds.count(k) for k in sorted(set(kinds))}
    gap_events = rec.events_of("gap")
    idx = np.flatnonzero(gap_mask(dt, med))  # holes in the time stamps, by the one gap rule
    time_gaps = [{"t_s": float(t[i + 1]), "sample_index": int(i + 1), "missing": int(m)}
                 for i, m in zip(idx, missing_samples(dt[idx], med))]
    if gap_events.size or rec.seq is not None:  # sequence numbers: the recorder's gap events are exact
        gaps = [{"t_s": float(e["t_s"]), "sample_index": int(e["sample_index"]), "missing": int(e["count"])}
                for e in gap_events]
        gap_source = "sequence numbers" if rec.seq is not None else "events"
        # a device that rebooted at a reconnect counts seq from 0 again: no seq gap, but a hole in time
        counted = {g["sample_index"] for g in gaps}
        restarts = [g for g in time_gaps if g["sample_index"] not in counted]
        if restarts:
            gaps = sorted(gaps + restarts, key=lambda g: g["sample_index"])
            gap_source += f" + timestamps ({len(restarts)} hole(s) across a device restart)"
    else:  # no seq numbers (imported data): gaps from the time stamps
        gaps, gap_source = time_gaps, "timestamps"
    sat = rec.saturated.astype(np.uint8)
    sat_counts = {a: int(((sat >> i) & 1).sum()) for i, a in enumerate(AXES)}
    meta = rec.meta

    def range_of(key, channel_attrs, scale_name):
        if meta.get(key) not in (None, ""):
            return float(meta[key])
        fs = float(channel_attrs.get("full_scale", float("nan")))
        if not math.isfinite(fs):
            return float("nan")
        si = fs * float(channel_attrs.get("scale_to_si", 1.0))
        return si / 9.80665 if scale_name == "g" else math.degrees(si)

    duration = float(t[-1] - t[0]) if rec.n > 1 else 0.0
    summary = {
        "file": str(path),
        "frames": rec.n,
        "duration_s": duration,
        "rate_hz": timing["rate_measured_hz"],
        "rate_nominal_hz": _num(meta.get("rate_nominal_hz")),
        "jitter_s": timing["jitter_s"],
        "dt_min_s": float(good.min()) if good.size else float("nan"),
        "dt_max_s": float(good.max()) if good.size else float("nan"),
        "gaps": len(gaps),
        "gap_source": gap_source,
        "dropped": int(sum(g["missing"] for g in gaps)),
        "crc_errors": count_of.get("crc_error", 0),
        "resyncs": count_of.get("resync", 0),
        "disconnects": count_of.get("disconnect", 0),
        "reconnects": count_of.get("reconnect", 0),
        "skipped_lines": count_of.get("skipped_line", 0),
        "saturated_samples": sat_counts,
        "saturated_any": int((sat != 0).sum()),
        "accel_range_g": range_of("accel_range_g", rec.raw["acc_attrs"], "g"),
        "gyro_range_dps": range_of("gyro_range_dps", rec.raw["gyro_attrs"], "dps"),
        "raw_units": {"acc": _text(rec.raw["acc_attrs"].get("units")), "gyro": _text(rec.raw["gyro_attrs"].get("units"))},
        "events": count_of,
        "device": meta.get("device", ""),
        "device_id": meta.get("device_id", ""),
        "firmware_version": meta.get("firmware_version", ""),
        "mount": meta.get("mount", ""),
        "start_utc": meta.get("start_utc", ""),
        "complete": "stop_reason" in meta or "rate_measured_hz" in meta,
        "data_warnings": data_warnings(rec),
        "gap_list": gaps[:100],
    }
    if boot is not None:  # the boot's place on the session clock (docs/recording-format.md)
        summary.update(boot=boot, start_s=float(t[0]) if rec.n else float("nan"),
                       **{k: meta.get(k) for k in ("clock_alignment", "clock_offset_s", "clock_scale",
                                                   "clock_residual_s")})
    return summary


#: Below these the sensor did not move at all (a still boot still shows > 0.3 rad/s peaks when walking).
STILL_GYRO_RADPS = 0.05
STILL_ACC_STD_MPS2 = 0.05


def data_warnings(rec) -> list[str]:
    """What makes a recording useless or suspicious though it opens: non-finite samples, all-zero
    channels, no motion at all. Empty when nothing is wrong."""
    import numpy as np

    out = []
    gyro_present = str(rec.meta.get("gyro_present", 1)) not in ("0", "False")
    channels = {"acc": rec.acc_mps2} | ({"gyro": rec.gyro_radps} if gyro_present else {})
    for name, arr in channels.items():
        bad = np.flatnonzero(~np.all(np.isfinite(arr), axis=1))
        if bad.size:
            out.append(f"{name}: {bad.size} non-finite samples (first at sample {int(bad[0])})")
        finite = arr[np.isfinite(arr)]
        if finite.size and np.all(finite == 0):
            out.append(f"{name}: all zero (sensor not delivering data?)")
    if rec.n > 1 and not out:
        still = np.nanstd(rec.acc_mps2, axis=0).max() < STILL_ACC_STD_MPS2
        if gyro_present:
            still = still and np.nanmax(np.abs(rec.gyro_radps)) < STILL_GYRO_RADPS
        if still:
            out.append("no motion: the sensor stayed still for the whole recording")
    return out


def _fmt(value) -> str:
    return f"{value:g}" if isinstance(value, float) and math.isfinite(value) else "?"


def _num(value):
    try:
        return float(value)
    except (TypeError, ValueError):
        return float("nan")


def _text(value):
    return value.decode() if isinstance(value, bytes) else ("" if value is None else str(value))


def run(args) -> int:
    labels = _boot_labels(args.file)
    s = {"file": str(args.file), "boots": {b: summarize(args.file, b) for b in labels}} if labels \
        else summarize(args.file)
    if args.json:
        from bootnav.core.jsonio import to_jsonable

        print(json.dumps(to_jsonable(s), indent=1, allow_nan=False))
        return 0
    if labels:
        print(f"{args.file}: multi-boot recording, boots {', '.join(labels)} on one session clock")
        for b, sb in s["boots"].items():
            lines = _lines(sb)
            lines[0] = f"boot {b}"
            fitted = str(sb["clock_alignment"]) == "host-receive"  # recorder: rate and residual of the fit
            lines.insert(1, f"  clock       {sb['clock_alignment'] or '?'}: starts at {_fmt(sb['start_s'])} s"
                            + (f", device clock {(1 / _num(sb['clock_scale']) - 1) * 1e6:+.1f} ppm, residual "
                               f"{_fmt(round(_num(sb['clock_residual_s']) * 1e3, 2))} ms" if fitted else ""))
            print("\n".join(lines))
        return 0
    print("\n".join(_lines(s)), file=sys.stdout)
    return 0


def _boot_labels(path) -> list[str]:
    """Labels of a multi-boot recording, [] for anything else (which ``summarize`` reports on)."""
    import h5py

    from bootnav.logger.recording import boot_labels

    try:
        return boot_labels(path) if h5py.is_hdf5(path) else []
    except (OSError, TypeError):
        return []


def _lines(s: dict) -> list[str]:
    """The text ``bootnav info`` prints for one recording (or one boot)."""
    sat = ", ".join(f"{a} {c}" for a, c in s["saturated_samples"].items() if c) or "none"
    lines = [
        f"{s['file']}",
        f"  device      {s['device'] or '?'} id {s['device_id'] or '?'} fw {s['firmware_version'] or '?'}"
        f"  mount {s['mount'] or '?'}  start {s['start_utc'] or '?'}",
        f"  samples     {s['frames']} over {s['duration_s']:.3f} s",
        f"  rate        {s['rate_hz']:.3f} Hz (nominal {_fmt(s['rate_nominal_hz'])}), jitter {s['jitter_s'] * 1e6:.1f} µs,"
        f" dt {s['dt_min_s'] * 1e3:.3f}..{s['dt_max_s'] * 1e3:.3f} ms",
        f"  ranges      ±{_fmt(s['accel_range_g'])} g, ±{_fmt(s['gyro_range_dps'])} °/s (raw units"
        f" {s['raw_units']['acc']}, {s['raw_units']['gyro']})",
        f"  gaps        {s['gaps']} ({s['dropped']} samples missing, from {s['gap_source']})",
        f"  link        {s['crc_errors']} CRC errors, {s['resyncs']} resyncs, {s['disconnects']} disconnects,"
        f" {s['reconnects']} reconnects, {s['skipped_lines']} skipped lines",
        f"  saturation  {sat}",
        f"  events      {', '.join(f'{k} {v}' for k, v in s['events'].items()) or 'none'}",
    ]
    for w in s["data_warnings"]:
        lines.append(f"  WARNING     {w}")
    if not s["complete"]:
        lines.append("  note        no final metadata: the writer did not close (crash or still recording)")
    return lines
