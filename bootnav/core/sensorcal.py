"""Per-device sensor calibration: the model, the file format, applying it, and the store keyed by device id.

Model
-----
Each triad (accelerometer, gyroscope) of the sensor reads::

    y = S x + b(T) + noise,        b(T) = b + k (T − T_ref)

with x the true specific force (m/s²) or angular rate (rad/s) in the body frame, S the 3×3 scale-and-
misalignment matrix, b the bias at the reference temperature T_ref (°C) and k its temperature coefficient
(per °C, zero when not fitted). bootnav applies the inverse::

    x̂ = C (y − b − k (T − T_ref)),      C = S⁻¹

Both triads are corrected into the accelerometer's (body) frame: the accelerometer's C is upper triangular
(the body frame is fixed to the accelerometer's axes, see ``postproc.sensorcal.accel_fit``), the gyroscope's C
is a full matrix that also rotates the gyro's axes into that frame. The accelerometer file of
``postproc.calibration`` (``{"bias_mps2": b, "matrix": M}``, ``f = M (f_raw − b)``) is the same model with
C = M and k = 0; ``load`` still reads it, as an accelerometer-only calibration.

Temperature: T is the MPU6050's die temperature recorded with the samples; outside the calibrated range
[lo, hi] the linear term is extrapolated and ``temperature_warning`` says so.

File format (JSON, strict)::

    {"format": "bootnav-sensor-calibration", "version": 1, "device_id": "0x0000BEEF" | null,
     "created_utc": "2026-...Z", "units": {...},
     "accelerometer": {"matrix": [[..]], "bias_mps2": [..], "bias_temp_coeff_mps2_per_degc": [..],
                       "sigma": {...}, "residual_rms_mps2": ..},
     "gyroscope": {"matrix": [[..]], "bias_radps": [..], "bias_temp_coeff_radps_per_degc": [..],
                   "sigma": {...}, "residual_rms_rad": ..},
     "temperature": {"ref_degc": .., "range_degc": [lo, hi] | null},
     "sessions": [{"file": .., "sha256": .., "duration_s": .., "temp_range_degc": [lo, hi]}, ...],
     "fit": {...}}                       (optional: fit settings, residuals per pose and motion)

A triad that was not calibrated is ``null``. ``sigma`` holds the 1σ uncertainty of each fitted parameter
(names as the fit reports them, SI units).

Store: ``store_dir()`` is ``$BOOTNAV_CALIBRATION_DIR`` or ``$XDG_DATA_HOME/bootnav/calibrations`` (default
``~/.local/share/bootnav/calibrations``); one file per calibration,
``<device_id>_<created_utc compact>.json``; ``find_calibration`` returns the newest for a device and
``store_calibration`` never overwrites an earlier one.
"""

from __future__ import annotations

import json
import math
import os
import re
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from bootnav.core.atomic import write_text
from bootnav.core.jsonio import to_jsonable
from bootnav.core.errors import InputError

FORMAT = "bootnav-sensor-calibration"
VERSION = 1
UNITS = {
    "accelerometer.matrix": "1 (corrected = matrix @ (raw - bias - temp_coeff (T - T_ref)))",
    "accelerometer.bias": "m/s^2", "accelerometer.bias_temp_coeff": "m/s^2 per degC",
    "accelerometer.residual_rms": "m/s^2 (|corrected| - g over the static poses)",
    "gyroscope.matrix": "1", "gyroscope.bias": "rad/s", "gyroscope.bias_temp_coeff": "rad/s per degC",
    "gyroscope.residual_rms": "rad (rotation error between poses)",
    "temperature": "degC",
}
# JSON key names per triad: (bias key, temp-coefficient key, residual key)
_KEYS = {
    "accelerometer": ("bias_mps2", "bias_temp_coeff_mps2_per_degc", "residual_rms_mps2"),
    "gyroscope": ("bias_radps", "bias_temp_coeff_radps_per_degc", "residual_rms_rad"),
}
_DEVICE_ID_RE = re.compile(r"^0x[0-9A-F]{8}$")


def normalize_device_id(device_id: Any) -> str | None:
    """``"0x%08X"`` of a device id given as int or string (``"0xbeef"``, ``"48879"``); None for empty/None.

    Raises
    ------
    ValueError
        Not an integer in [0, 2³²).
    """
    if device_id is None:
        return None
    if isinstance(device_id, (bytes, np.bytes_)):
        device_id = device_id.decode("utf-8", "replace")
    if isinstance(device_id, str):
        s = device_id.strip()
        if not s or s == "?":
            return None
        value = int(s, 0) if s.lower().startswith("0x") else int(s, 16 if re.search(r"[a-fA-F]", s) else 10)
    else:
        value = int(device_id)
    if not 0 <= value < 2**32:
        raise ValueError(f"device id {device_id!r} is not a 32-bit unsigned integer")
    return f"0x{value:08X}"


@dataclass(frozen=True)
class TriadCalibration:
    """One triad's correction x̂ = C (y − b − k (T − T_ref)) (module docstring).

    Attributes
    ----------
    matrix : (3, 3) ndarray
        C = S⁻¹ (scale and misalignment correction), dimensionless.
    bias : (3,) ndarray
        b at T_ref, m/s² (accelerometer) or rad/s (gyroscope).
    bias_temp_coeff : (3,) ndarray
        k, per °C in the bias unit; zeros when not fitted.
    sigma : dict
        1σ uncertainty of each fitted parameter (name -> float, SI).
    residual_rms : float
        RMS fit residual: m/s² (accelerometer), rad (gyroscope); NaN if unknown.
    """

    matrix: np.ndarray
    bias: np.ndarray
    bias_temp_coeff: np.ndarray = field(default_factory=lambda: np.zeros(3))
    sigma: dict = field(default_factory=dict)
    residual_rms: float = float("nan")

    def __post_init__(self):
        object.__setattr__(self, "matrix", _readonly(np.array(self.matrix, dtype=np.float64)))
        object.__setattr__(self, "bias", _readonly(np.array(self.bias, dtype=np.float64)))
        object.__setattr__(self, "bias_temp_coeff", _readonly(np.array(self.bias_temp_coeff, dtype=np.float64)))
        object.__setattr__(self, "sigma", {str(k): float(v) for k, v in dict(self.sigma).items()})
        object.__setattr__(self, "residual_rms", float(self.residual_rms))
        if self.matrix.shape != (3, 3) or self.bias.shape != (3,) or self.bias_temp_coeff.shape != (3,):
            raise ValueError(f"TriadCalibration needs a 3x3 matrix and 3-vectors; got {self.matrix.shape}, "
                             f"{self.bias.shape}, {self.bias_temp_coeff.shape}")

    @classmethod
    def identity(cls) -> "TriadCalibration":
        return cls(np.eye(3), np.zeros(3))

    def is_identity(self) -> bool:
        return bool(np.array_equal(self.matrix, np.eye(3)) and not self.bias.any() and not self.bias_temp_coeff.any())

    def apply(self, y, temp_delta=None) -> np.ndarray:
        """C (y − b − k ΔT) for (N, 3) or (3,) ``y``; ``temp_delta`` = T − T_ref (scalar or (N,)) or None."""
        y = np.asarray(y, dtype=np.float64)
        if self.is_identity():
            return np.array(y, dtype=np.float64)  # bit-identical copy (no -0.0 / rounding from the product)
        d = y - self.bias
        if temp_delta is not None and self.bias_temp_coeff.any():
            dt = np.asarray(temp_delta, dtype=np.float64)
            d = d - (dt[..., None] if dt.ndim else dt) * self.bias_temp_coeff
        return np.ascontiguousarray(d @ self.matrix.T)


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class SensorCalibration:
    """A device's calibration (both triads, temperature, provenance); see the module docstring.

    ``acc`` / ``gyro`` is None for a triad that was not calibrated (``apply`` passes it through).
    """

    device_id: str | None = None
    acc: TriadCalibration | None = None
    gyro: TriadCalibration | None = None
    temp_ref_degc: float = 25.0
    temp_range_degc: tuple[float, float] | None = None
    created_utc: str = ""
    sessions: list = field(default_factory=list)
    source: str | None = None
    fit: dict | None = None  # how it was fitted: settings, residuals per pose / motion (optional "fit" record)

    def __post_init__(self):
        if self.temp_range_degc is not None:
            lo, hi = (float(v) for v in self.temp_range_degc)
            object.__setattr__(self, "temp_range_degc", (lo, hi))
        object.__setattr__(self, "temp_ref_degc", float(self.temp_ref_degc))
        object.__setattr__(self, "sessions", [dict(s) for s in self.sessions])

    # ----------------------------------------------------------------------------------------------------------
    @classmethod
    def identity(cls, device_id: str | None = None) -> "SensorCalibration":
        """Both triads identity (applying it returns copies of the inputs, bit-identical)."""
        return cls(device_id=device_id, acc=TriadCalibration.identity(), gyro=TriadCalibration.identity(),
                   created_utc=utc_now())

    def is_identity(self) -> bool:
        return all(t is None or t.is_identity() for t in (self.acc, self.gyro))

    def apply(self, acc_b, gyro_b, temp_degc=None):
        """Corrected ``(acc_b, gyro_b)`` (new (N, 3) float64 arrays; inputs untouched).

        Parameters
        ----------
        acc_b, gyro_b : (N, 3) or (3,) array_like
            Raw specific force (m/s²) and angular rate (rad/s), body frame.
        temp_degc : float or (N,) array_like or None
            Sensor temperature (°C); None (or NaN samples) applies the bias at T_ref.
        """
        dt = None
        if temp_degc is not None:
            dt = np.asarray(temp_degc, dtype=np.float64) - self.temp_ref_degc
            dt = np.where(np.isfinite(dt), dt, 0.0)
        acc = np.array(acc_b, dtype=np.float64) if self.acc is None else self.acc.apply(acc_b, dt)
        gyro = np.array(gyro_b, dtype=np.float64) if self.gyro is None else self.gyro.apply(gyro_b, dt)
        return acc, gyro

    # ----------------------------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        doc: dict[str, Any] = {"format": FORMAT, "version": VERSION, "device_id": self.device_id,
                               "created_utc": self.created_utc, "units": dict(UNITS)}
        for name, tri in (("accelerometer", self.acc), ("gyroscope", self.gyro)):
            if tri is None:
                doc[name] = None
                continue
            kb, kk, kr = _KEYS[name]
            doc[name] = {"matrix": tri.matrix.tolist(), kb: tri.bias.tolist(), kk: tri.bias_temp_coeff.tolist(),
                         "sigma": dict(tri.sigma), kr: tri.residual_rms}
        doc["temperature"] = {"ref_degc": self.temp_ref_degc,
                              "range_degc": list(self.temp_range_degc) if self.temp_range_degc else None}
        doc["sessions"] = [dict(s) for s in self.sessions]
        if self.fit is not None:
            doc["fit"] = self.fit
        return to_jsonable(doc, max_array_size=None)

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n"

    @classmethod
    def from_json(cls, text: str, source: str | None = None) -> "SensorCalibration":
        """Parse a calibration document (or the old accelerometer file); InputError naming ``source``."""
        where = source or "calibration"
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as e:
            raise InputError(f"{where}: invalid JSON at line {e.lineno} column {e.colno}: {e.msg}") from None
        return cls.from_dict(doc, source=source)

    @classmethod
    def from_dict(cls, doc: Any, source: str | None = None) -> "SensorCalibration":
        where = source or "calibration"
        if not isinstance(doc, dict):
            raise InputError(f"{where}: a calibration file must hold a JSON object, not {type(doc).__name__}")
        if doc.get("format") is None and "bias_mps2" in doc and "matrix" in doc:  # old accelerometer-only file
            acc = _triad(doc, "bias_mps2", None, where, "")
            return cls(acc=acc, gyro=None, created_utc="", source=source)
        if doc.get("format") != FORMAT:
            raise InputError(f"{where}: 'format' must be {FORMAT!r} (or an accelerometer file with 'bias_mps2' "
                             f"and 'matrix'); got {doc.get('format')!r}")
        if doc.get("version") != VERSION:
            raise InputError(f"{where}: calibration file version {doc.get('version')!r} is not supported "
                             f"(this bootnav reads version {VERSION})")
        try:
            device_id = normalize_device_id(doc.get("device_id"))
        except (ValueError, TypeError):
            raise InputError(f"{where}: 'device_id' must be a 32-bit id like \"0x0000BEEF\"; "
                             f"got {doc.get('device_id')!r}") from None
        tris = {}
        for name in ("accelerometer", "gyroscope"):
            sub = doc.get(name)
            if sub is None:
                tris[name] = None
                continue
            if not isinstance(sub, dict):
                raise InputError(f"{where}: '{name}' must be an object or null")
            kb, kk, kr = _KEYS[name]
            tris[name] = _triad(sub, kb, kk, where, f"{name}.", residual_key=kr)
        if tris["accelerometer"] is None and tris["gyroscope"] is None:
            raise InputError(f"{where}: neither 'accelerometer' nor 'gyroscope' is calibrated")
        temp = doc.get("temperature") or {}
        if not isinstance(temp, dict):
            raise InputError(f"{where}: 'temperature' must be an object")
        ref = _finite(temp.get("ref_degc", 25.0), where, "temperature.ref_degc")
        rng = temp.get("range_degc")
        if rng is not None:
            r = _vector(rng, 2, where, "temperature.range_degc")
            if r[0] > r[1]:
                raise InputError(f"{where}: 'temperature.range_degc' must be [low, high]; got {rng}")
            rng = (float(r[0]), float(r[1]))
        sessions = doc.get("sessions") or []
        if not isinstance(sessions, list) or not all(isinstance(s, dict) for s in sessions):
            raise InputError(f"{where}: 'sessions' must be a list of objects")
        created = doc.get("created_utc") or ""
        if not isinstance(created, str):
            raise InputError(f"{where}: 'created_utc' must be an ISO time string")
        fit = doc.get("fit")
        return cls(device_id=device_id, acc=tris["accelerometer"], gyro=tris["gyroscope"], temp_ref_degc=ref,
                   temp_range_degc=rng, created_utc=created, sessions=sessions, source=source,
                   fit=fit if isinstance(fit, dict) else None)

    def save(self, path: str | Path, force: bool = False) -> Path:
        """Write the JSON file crash-safely; an existing file is kept unless ``force``."""
        path = Path(path)
        if path.exists() and not force:
            raise InputError(f"{path}: exists; use --force to overwrite it or choose another --out")
        write_text(path, self.to_json())
        return path

    @classmethod
    def load(cls, path: str | Path) -> "SensorCalibration":
        """Read a calibration file (this format or the old accelerometer file); one-line InputError."""
        path = Path(path)
        try:
            text = path.read_text()
        except FileNotFoundError:
            raise InputError(f"{path}: calibration file not found") from None
        except IsADirectoryError:
            raise InputError(f"{path}: is a directory, not a calibration file") from None
        except UnicodeDecodeError:
            raise InputError(f"{path}: not a text (JSON) calibration file") from None
        except OSError as e:
            raise InputError(f"{path}: cannot read calibration file: {e.strerror or e}") from None
        return cls.from_json(text, source=str(path))

    def provenance(self) -> dict:
        """A small dict for summary.json / results.h5: which calibration ran."""
        return to_jsonable({
            "file": self.source, "device_id": self.device_id, "created_utc": self.created_utc,
            "identity": self.is_identity(),
            "accelerometer_residual_rms_mps2": None if self.acc is None else self.acc.residual_rms,
            "gyroscope_residual_rms_rad": None if self.gyro is None else self.gyro.residual_rms,
            "temp_ref_degc": self.temp_ref_degc,
            "temp_range_degc": list(self.temp_range_degc) if self.temp_range_degc else None,
        })

    def with_source(self, source: str | None) -> "SensorCalibration":
        return replace(self, source=source)


def _finite(v: Any, where: str, name: str) -> float:
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise InputError(f"{where}: '{name}' must be a number; got {v!r}") from None
    if not math.isfinite(x):
        raise InputError(f"{where}: '{name}' must be finite; got {v!r}")
    return x


def _vector(v: Any, n: int, where: str, name: str) -> np.ndarray:
    try:
        a = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{where}: '{name}' must be {n} numbers; got {v!r}") from None
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise InputError(f"{where}: '{name}' must be {n} finite numbers; got {v!r}")
    return a


def _triad(sub: dict, kb: str, kk: str | None, where: str, prefix: str, residual_key: str | None = None):
    if "matrix" not in sub:
        raise InputError(f"{where}: '{prefix}matrix' is missing (3x3 numbers)")
    if kb not in sub:
        raise InputError(f"{where}: '{prefix}{kb}' is missing (3 numbers)")
    try:
        mat = np.asarray(sub["matrix"], dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{where}: '{prefix}matrix' must be 3x3 numbers") from None
    if mat.shape != (3, 3) or not np.all(np.isfinite(mat)):
        raise InputError(f"{where}: '{prefix}matrix' must be 3x3 finite numbers; got shape {mat.shape}")
    det = float(np.linalg.det(mat))
    if abs(det) < 1e-6:
        raise InputError(f"{where}: '{prefix}matrix' is singular (det {det:.3g})")
    bias = _vector(sub[kb], 3, where, prefix + kb)
    coeff = np.zeros(3) if kk is None or sub.get(kk) is None else _vector(sub[kk], 3, where, prefix + kk)
    sigma = sub.get("sigma") or {}
    if not isinstance(sigma, dict):
        raise InputError(f"{where}: '{prefix}sigma' must be an object of numbers")
    try:
        sigma = {str(k): float("nan") if v is None else float(v) for k, v in sigma.items()}
    except (TypeError, ValueError):
        raise InputError(f"{where}: '{prefix}sigma' must map names to numbers") from None
    rms = sub.get(residual_key) if residual_key else None
    rms = float("nan") if rms is None else _finite(rms, where, prefix + residual_key)
    return TriadCalibration(matrix=mat, bias=bias, bias_temp_coeff=coeff, sigma=sigma, residual_rms=rms)


def utc_now() -> str:
    """Current UTC time as ISO 8601 with a Z, second resolution."""
    return datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def temperature_warning(cal: SensorCalibration | None, temp_degc) -> str | None:
    """A one-line warning when the recording's temperatures leave the calibrated range, else None.

    Parameters
    ----------
    cal : SensorCalibration or None
    temp_degc : float or array_like
        Recorded sensor temperatures (°C); NaNs ignored.
    """
    if cal is None or temp_degc is None:
        return None
    t = np.asarray(temp_degc, dtype=np.float64).ravel()
    t = t[np.isfinite(t)]
    if t.size == 0:
        return None
    lo_rec, hi_rec = float(t.min()), float(t.max())
    if cal.temp_range_degc is None:
        lo, hi = cal.temp_ref_degc, cal.temp_ref_degc
        tol = 10.0  # an untemperature-calibrated device: MPU6050 bias drift is specified over ±10 °C windows
        if lo_rec >= lo - tol and hi_rec <= hi + tol:
            return None
        what = f"the calibration's reference temperature {cal.temp_ref_degc:.1f} °C (no temperature fit)"
    else:
        lo, hi = cal.temp_range_degc
        if lo_rec >= lo and hi_rec <= hi:
            return None
        what = f"the calibrated range {lo:.1f}..{hi:.1f} °C"
    return (f"sensor temperature {lo_rec:.1f}..{hi_rec:.1f} °C leaves {what}"
            f"{' of ' + cal.source if cal.source else ''}: bias corrections are extrapolated; "
            "calibrate the boot over a wider temperature range (bootnav calibrate with sessions warm and cold)")


# ---------------------------------------------------------------------------------------------------------------
# store

def store_dir() -> Path:
    """``$BOOTNAV_CALIBRATION_DIR``, else ``$XDG_DATA_HOME/bootnav/calibrations`` (``~/.local/share`` default)."""
    env = os.environ.get("BOOTNAV_CALIBRATION_DIR")
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_DATA_HOME") or os.path.join(os.path.expanduser("~"), ".local", "share")
    return Path(base) / "bootnav" / "calibrations"


def find_calibration(device_id: Any) -> SensorCalibration | None:
    """The newest stored calibration of ``device_id`` (by created_utc, then file name), or None.

    A corrupt newest file raises its one-line InputError (it is not silently skipped: the user must know).
    """
    try:
        dev = normalize_device_id(device_id)
    except (ValueError, TypeError):
        return None
    if dev is None:
        return None
    d = store_dir()
    if not d.is_dir():
        return None
    files = sorted(d.glob(f"{dev}_*.json"))
    if not files:
        return None
    # file names carry the creation time (compact ISO, sortable) and a counter: the last one is the newest
    return SensorCalibration.load(files[-1])


def store_calibration(cal: SensorCalibration) -> Path:
    """Save ``cal`` into the store under its device id; earlier calibrations are kept (never overwritten).

    Returns the path written. Raises InputError for a calibration without a device id.
    """
    if not cal.device_id:
        raise InputError("a calibration without a device id cannot be stored by device: give --device-id "
                         "or write it with --out")
    d = store_dir()
    d.mkdir(parents=True, exist_ok=True)
    stamp = re.sub(r"[^0-9TZ]", "", cal.created_utc or utc_now()) or "unknown"
    n = 0
    while True:
        path = d / f"{cal.device_id}_{stamp}_{n:03d}.json"
        if not path.exists():
            break
        n += 1
    cal.save(path, force=False)
    return path
