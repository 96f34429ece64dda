"""Input for ``bootnav pdr``: canonical ``acc.csv.gz`` / ``imu.csv.gz``, an HDF5 recording
(bootnav.logger.recording.load) or anything bootnav.logger.importers understands (Physics Toolbox, phyphox, the 20 Hz
waist log, other IMU CSVs)."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bootnav.errors import InputError


@dataclass
class PdrInput:
    t_s: np.ndarray
    acc_b: np.ndarray
    gyro_b: np.ndarray | None
    mag_b: np.ndarray | None
    source: str
    kind: str
    compass_deg: np.ndarray | None = None
    gps: tuple | None = None  # (t_s, lat_deg, lon_deg) rows of the GPS columns (Physics Toolbox), unfiltered
    device_id: str | None = None  # the recording's /meta device_id (which sensor calibration applies)
    temp_degc: np.ndarray | None = None  # sensor temperature per sample, when recorded


def calibrated(inp: PdrInput, sensor_calibration: str = "auto"):
    """``(inp with calibrated acc/gyro, calibration.AppliedCalibration)``: the sensor calibration ``process``
    would apply (``calibration.resolve_calibration`` / ``apply_calibration``)."""
    from dataclasses import replace

    from bootnav.postproc.calibration import CalibrationSettings, apply_calibration, resolve_calibration

    applied = resolve_calibration(CalibrationSettings(sensor_calibration=sensor_calibration), inp.device_id)
    if applied.calibration is None:
        return inp, applied
    gyro = inp.gyro_b if inp.gyro_b is not None else np.zeros_like(inp.acc_b)
    acc, gyro = apply_calibration(applied, inp.acc_b, gyro, inp.temp_degc)
    return replace(inp, acc_b=acc, gyro_b=gyro if inp.gyro_b is not None else None), applied


def _mag_from_aux(aux: dict) -> np.ndarray | None:
    keys = [f"mag_{a}" for a in "xyz"]
    if all(k in aux for k in keys):
        return np.column_stack([np.asarray(aux[k], float) for k in keys])
    return None


def _compass_from_aux(aux: dict) -> np.ndarray | None:
    for k in ("heading_deg", "compass_deg", "azimuth_deg"):
        if k in aux:
            return np.asarray(aux[k], float)
    return None


def _gps_from_aux(t_s, aux: dict):
    lat = next((aux[k] for k in ("latitude", "lat", "lat_deg") if k in aux), None)
    lon = next((aux[k] for k in ("longitude", "lon", "lon_deg") if k in aux), None)
    if lat is None or lon is None:
        return None
    return np.asarray(t_s, float), np.asarray(lat, float), np.asarray(lon, float)


def _gyro_or_none(g):
    if g is None:
        return None
    g = np.asarray(g, float)
    return None if g.size == 0 or not np.isfinite(g).any() else g


def load_input(path) -> PdrInput:
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    from bootnav.core.paths import regular_input

    regular_input(path, "recording or IMU")  # a FIFO would block forever, a device never end
    name = path.name.lower()
    if name.endswith((".h5", ".hdf5")):
        from bootnav.logger.recording import load

        rec = load(path, check_units=True)  # acc in g / gyro in deg/s refused as `import` does
        aux = {}
        try:
            from bootnav.logger.recording import load_aux

            aux = load_aux(path)
        except ImportError:
            pass
        return PdrInput(rec.t_s, rec.acc_mps2, _gyro_or_none(rec.gyro_radps), _mag_from_aux(aux), str(path), "hdf5",
                        _compass_from_aux(aux), _gps_from_aux(rec.t_s, aux), rec.meta.get("device_id"), rec.temp_degc)
    if name.endswith((".csv.gz", ".csv")):
        with (__import__("gzip").open(path, "rt") if name.endswith(".gz") else open(path)) as f:
            header = f.readline()
        if header.strip().startswith("t_s,ax_mps2"):
            from bootnav.core.csvio import read_imu_csv

            imu = read_imu_csv(path)
            if imu.bad_lines:
                print(f"warning: {path}: skipped {len(imu.bad_lines)} unreadable line(s): "
                      + "; ".join(f"line {ln}: {why}" for ln, why in imu.bad_lines[:5]), file=sys.stderr)
            return PdrInput(imu.t_s, imu.acc_mps2, _gyro_or_none(imu.gyro_radps), None, str(path), "canonical_csv")
    try:
        from bootnav.logger.importers import read_any
    except ImportError as exc:
        raise InputError(f"{path}: not a canonical acc/imu csv(.gz) or .h5 and no importer available ({exc})")
    res = read_any(path)
    return PdrInput(res.t_s, res.acc_mps2, _gyro_or_none(res.gyro_radps), _mag_from_aux(res.aux), str(path),
                    f"import:{res.profile}", _compass_from_aux(res.aux), _gps_from_aux(res.t_s, res.aux))
