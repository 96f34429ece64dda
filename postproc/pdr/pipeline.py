"""The PDR pipeline: detector -> step features -> step-length model -> heading -> path.

    run_pdr(t_s, acc_b, gyro_b=None, settings=PdrSettings(), mag_b=None) -> PdrResult

Every tunable lives in ``PdrSettings`` (saved with the results as summary.json["settings"]).
Heading methods: "auto" (gyro if a gyro is present, else a device compass column if present, else
"none"), "none" (every step keeps the start bearing: a straight line; heading is unobservable without
gyro/magnetometer), "gyro", "mag", "complementary", "compass" (a heading column delivered by the device,
e.g. the HMR3300 of seed-000, averaged circularly over the 0.4 s = 8 samples at 20 Hz before each step,
seed-000 R5/R6; seed-003: "if the device can calculate the direction ... this data is transmitted"). Bearing convention: clockwise from north (heading/__init__.py).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from bootnav.errors import InputError


@dataclass
class PdrSettings:
    detector: str = "robust"
    detector_params: dict = field(default_factory=dict)
    length: str = "frequency_variance"
    length_params: dict = field(default_factory=dict)
    height_m: float | None = None  # used by the models that need it (footpath, renaudin)
    heading: str = "auto"
    heading0_deg: float = 0.0  # start bearing (clockwise from north)
    declination_deg: float = 0.0  # east positive
    forward_axis: tuple = (0.0, 1.0, 0.0)  # body axis pointing forward (magnetometer heading)
    complementary_tau_s: float = 10.0
    start_lat_lon: tuple | None = None

    def to_dict(self) -> dict:
        d = asdict(self)
        d["forward_axis"] = list(self.forward_axis)
        d["start_lat_lon"] = list(self.start_lat_lon) if self.start_lat_lon else None
        return d


@dataclass
class PdrResult:
    t_s: np.ndarray  # (N,) step times
    length_m: np.ndarray
    heading_rad: np.ndarray  # bearing, clockwise from north
    x_m: np.ndarray  # east after each step
    y_m: np.ndarray  # north after each step
    events: object  # StepEvents (with the detector's trace)
    features: object  # StepFeatures
    settings: PdrSettings
    lat_deg: np.ndarray | None = None
    lon_deg: np.ndarray | None = None
    heading_source: str = "none"
    gravity_restored: bool = False

    @property
    def count(self) -> int:
        return int(self.t_s.size)

    def summary(self) -> dict:
        d = float(np.sum(self.length_m))
        return {
            "steps": self.count,
            "distance_m": d,
            "mean_step_length_m": float(np.mean(self.length_m)) if self.count else None,
            "cadence_steps_per_min": float(60.0 * (self.count - 1) / (self.t_s[-1] - self.t_s[0]))
            if self.count > 2 else None,
            "final_x_m": float(self.x_m[-1]) if self.count else 0.0,
            "final_y_m": float(self.y_m[-1]) if self.count else 0.0,
            "heading_source": self.heading_source,
            "gravity_restored": self.gravity_restored,
            "heading_convention": "bearing, rad, clockwise from north; x east, y north",
            "settings": self.settings.to_dict(),
        }


def _check_inputs(t_s, acc_b):
    t = np.asarray(t_s, float)
    a = np.asarray(acc_b, float)
    if a.ndim != 2 or a.shape[1] != 3 or a.shape[0] != t.shape[0]:
        raise InputError(f"acc_b must be (N, 3) with N = len(t_s) = {t.shape[0]}; got {a.shape}")
    if t.size < 10 or not np.isfinite(t).any() or np.nanmax(t) - np.nanmin(t) <= 0:
        raise InputError(f"need at least 10 samples spanning a positive time; got {t.size}")
    bad = ~np.isfinite(a).all(axis=1)
    if bad.any():
        keep = ~bad & np.isfinite(t)
        return t[keep], a[keep], keep
    return t, a, None


def restore_gravity(acc_b: np.ndarray, g: float = 9.80665) -> list[np.ndarray]:
    """Phones may export LINEAR acceleration (gravity removed by the OS, e.g. phyphox "Linear
    Acceleration"): |a| at rest ~ 0 instead of g. Every detector here expects specific force with gravity,
    so when median |a| < g/2 we add g along the dominant oscillation axis (walking: mostly vertical).
    Its sign cannot be known, so BOTH candidates are returned ([acc] when gravity is present);
    ``run_pdr`` keeps the one giving more steps (the wrong polarity merges or skips steps), then the
    more regular sequence (``irregularity``)."""
    a = np.asarray(acc_b, float)
    if np.median(np.linalg.norm(a, axis=1)) >= 0.5 * g:
        return [a]
    c = a - a.mean(axis=0)
    _, v = np.linalg.eigh(c.T @ c)
    e = v[:, -1]
    return [a + g * e, a - g * e]


def irregularity(t_steps: np.ndarray, gap_s: float = 1.6) -> float:
    """Median |successive difference| of step intervals / median interval (walking: small; a wrong
    polarity picks alternating short/long intervals). inf when fewer than 4 intervals."""
    d = np.diff(np.asarray(t_steps, float))
    d = d[d < gap_s]
    if d.size < 4:
        return float("inf")
    return float(np.median(np.abs(np.diff(d))) / np.median(d))


def _length_model(settings: PdrSettings):
    from bootnav.postproc.pdr.length import LENGTH_MODELS

    if settings.length not in LENGTH_MODELS:
        raise InputError(f"unknown step-length model {settings.length!r}; choose one of {sorted(LENGTH_MODELS)}")
    params = dict(settings.length_params)
    cls = LENGTH_MODELS[settings.length]
    if settings.height_m is not None and "height_m" in cls.__dataclass_fields__:
        params.setdefault("height_m", settings.height_m)
    return cls(**params)


def compass_at_steps(t, compass_deg, t_steps, window_s: float = 0.4) -> np.ndarray:
    """Circular mean (mean of unit vectors) of the compass bearing over [t_step - window, t_step], rad."""
    z = np.exp(1j * np.radians(np.asarray(compass_deg, float)))
    c = np.r_[0.0, np.cumsum(z)]
    lo = np.searchsorted(t, np.asarray(t_steps) - window_s)
    hi = np.maximum(np.searchsorted(t, t_steps, side="right"), lo + 1)
    hi = np.minimum(hi, len(t))
    lo = np.minimum(lo, hi - 1)
    return np.angle(c[hi] - c[lo])


def _heading(settings, t, acc, gyro, mag, t_steps, compass=None):
    from bootnav.postproc.pdr.heading.complementary import complementary_heading
    from bootnav.postproc.pdr.heading.declination import apply_declination
    from bootnav.postproc.pdr.heading.gyro import gyro_heading
    from bootnav.postproc.pdr.heading.magnetometer import tilt_compensated_heading
    from bootnav.postproc.pdr.signals import gravity_direction, nominal_rate_hz

    method = settings.heading
    if method not in ("auto", "none", "gyro", "mag", "complementary", "compass"):
        raise InputError(f"unknown heading method {method!r}; choose auto, none, gyro, mag, complementary, compass")
    if method == "auto":
        method = "gyro" if gyro is not None else ("compass" if compass is not None else "none")
    psi0 = np.radians(settings.heading0_deg)
    if method == "none":
        return np.full(t_steps.size, psi0), "none"
    if method == "compass":
        if compass is None:
            raise InputError("heading 'compass' needs a device heading column (e.g. heading_deg); this input has none")
        return apply_declination(compass_at_steps(t, compass, t_steps), settings.declination_deg), "compass"
    if method in ("gyro", "complementary") and gyro is None:
        raise InputError(f"heading {method!r} needs a gyroscope; this input has none")
    if method in ("mag", "complementary") and mag is None:
        raise InputError(f"heading {method!r} needs a magnetometer; this input has none")
    if method == "gyro":
        tt, psi = gyro_heading(t, gyro, acc, psi0)
    else:
        up = gravity_direction(acc, nominal_rate_hz(t))
        psi_m = np.unwrap(apply_declination(tilt_compensated_heading(mag, up, settings.forward_axis),
                                            settings.declination_deg))
        tt = t
        psi = psi_m
        if method == "complementary":
            tg, psi_g = gyro_heading(t, gyro, acc, 0.0)
            psi_m_g = np.interp(tg, t, psi_m)
            psi = complementary_heading(tg, psi_g, psi_m_g, settings.complementary_tau_s)
            tt = tg
    if method not in ("gyro", "mag", "complementary"):
        raise InputError(f"unknown heading method {settings.heading!r}; "
                         "choose auto, none, gyro, mag, complementary, compass")
    return np.angle(np.exp(1j * np.interp(t_steps, tt, psi))), method


def run_pdr(t_s, acc_b, gyro_b=None, settings: PdrSettings | None = None, mag_b=None,
            compass_deg=None) -> PdrResult:
    """Step-and-heading dead reckoning on one recording (SI units, sensor frame, gravity included).

    mag_b: (N, 3) magnetometer (any unit); compass_deg: (N,) device heading, deg clockwise from north."""
    from bootnav.postproc.pdr.detectors import make_detector
    from bootnav.postproc.pdr.length.features import step_features
    from bootnav.postproc.pdr.path import geodetic_path, local_path

    settings = settings or PdrSettings()
    t, acc, keep = _check_inputs(t_s, acc_b)
    gyro = None if gyro_b is None else np.asarray(gyro_b, float)
    mag = None if mag_b is None else np.asarray(mag_b, float)
    compass = None if compass_deg is None else np.asarray(compass_deg, float)
    if keep is not None:
        gyro = gyro[keep] if gyro is not None else None
        mag = mag[keep] if mag is not None else None
        compass = compass[keep] if compass is not None else None
    detector = make_detector(settings.detector, **settings.detector_params)
    candidates = restore_gravity(acc)
    gravity_restored = len(candidates) > 1
    runs = [(cand, detector.detect(t, cand)) for cand in candidates]
    # the wrong polarity merges or skips steps (seen on phyphox exports): keep the larger count, then the
    # more regular sequence
    acc, events = min(runs, key=lambda r: (-r[1].count, irregularity(r[1].t_s)))
    feats = step_features(events.t_s, t, acc)
    length = _length_model(settings).estimate(feats)
    heading, source = _heading(settings, t, acc, gyro, mag, events.t_s, compass)
    x, y = local_path(length, heading)
    res = PdrResult(events.t_s, np.asarray(length, float), heading, x, y, events, feats, settings,
                    heading_source=source, gravity_restored=gravity_restored)
    if settings.start_lat_lon:
        res.lat_deg, res.lon_deg = geodetic_path(settings.start_lat_lon[0], settings.start_lat_lon[1], length, heading)
    return res
