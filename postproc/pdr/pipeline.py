"""The PDR pipeline: detector -> step features -> step-length model -> heading -> path.

    run_pdr(t_s, acc_b, gyro_b=None, settings=PdrSettings(), mag_b=None, compass_deg=None) -> PdrResult

Every tunable lives in ``PdrSettings`` (saved with the results as summary.json["settings"]; ``from_dict``
/ ``from_file`` read a full or partial dict back, ``save`` writes one).
Heading methods: "auto" (gyro if a gyro is present, else a device compass column if present, else
"none"), "none" (every step keeps the start bearing: a straight line; heading is unobservable without
gyro/magnetometer), "gyro", "mag", "complementary", "compass" (a heading column delivered by the device,
e.g. the HMR3300 compass of [NKUA2009], averaged circularly over the 0.4 s = 8 samples at 20 Hz before each
step as its code does; [Lazarevskiy2021] also prefers a device-computed direction when there is one).
The magnetometer ("mag", "complementary") is first corrected by ``mag_calibration``
(``heading.mag_calibration.calibrate_mag``), then levelled by ``mag_tilt``: "gravity" (low-passed gravity
direction, engineered), "weights" (the [NKUA2009, §4.2] tilt weights) or "none" (a level device,
[Lazarevskiy2021, eq. 3.2] literal).
With GPS fixes (``gps=``), the geodetic path starts at the first fix unless ``start_lat_lon`` is set, and
``PdrResult.gps`` compares the two paths (``path.gps_comparison``).

Inside the package headings are bearings, clockwise from north, as in the sources (``heading/__init__.py``);
``PdrResult`` and every output file give ``yaw_enu_rad`` instead (``bootnav.CONVENTIONS["heading"]``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

import numpy as np

from bootnav.core.conventions import CONVENTIONS, SOFTWARE, STANDARD_GRAVITY_MPS2
from bootnav.errors import InputError


HEADING_METHODS = ("auto", "none", "gyro", "mag", "complementary", "compass")
MAG_TILTS = ("gravity", "weights", "none")


@dataclass
class PdrSettings:
    """All settings of one PDR run (``run_pdr``, ``bootnav pdr``), saved with its results.

    The parameters of the chosen detector and step-length model are the fields of their dataclasses
    (``detectors.DETECTORS``, ``length.LENGTH_MODELS``); ``detector_params`` / ``length_params`` hold the
    ones that differ from those defaults and are checked like every other setting (``validate``).

    Attributes
    ----------
    detector, detector_params : str, dict
        Step detector and its parameter overrides.
    length, length_params : str, dict
        Step-length model and its parameter overrides (``calibrate_length`` fits them).
    height_m : float or None, m
        Walker height for the models that use it (footpath, renaudin); None = the model's default.
    heading : str
        One of ``HEADING_METHODS`` (module docstring).
    heading0_deg, declination_deg : float, deg
        Start bearing (clockwise from north) of "gyro" and "none"; magnetic declination, east positive.
    forward_axis : (float, float, float)
        Body axis pointing forward (magnetometer heading).
    complementary_tau_s : float, s
        Crossover time constant of the gyro / magnetometer fusion.
    gravity_cutoff_hz : float, Hz
        Low-pass cut-off of the gravity direction about which the gyro is integrated and the magnetometer
        levelled (walking at 1.5-2.5 steps/s is well above it).
    gyro_signed_magnitude : bool
        Integrate sgn(w_v) |w| instead of the vertical rate w_v [Lazarevskiy2021, eqs. 2.7-2.8].
    compass_window_s : float, s
        Circular averaging of a device compass before each step ([NKUA2009] code: 8 samples at 20 Hz).
    mag_tilt : str
        One of ``MAG_TILTS``: "gravity" (engineered), "weights" ([NKUA2009, §4.2] tilt weights), "none"
        (level device, [Lazarevskiy2021, eq. 3.2]).
    tilt_weight_window_s : float, s
        Moving average of the tilt-weight correction ([NKUA2009, §4.2]: 8 samples at 20 Hz).
    mag_calibration : str
        ``heading.mag_calibration.MAG_CALIBRATIONS``.
    mag_percentiles : (float, float)
        Percentiles of the "percentile" calibrations ([NKUA2009, §4.3]: 5 and 95).
    mag_calibration_window_s : (float, float) or None, s
        Fit the magnetometer calibration on this window after the first sample (e.g. a turn on the spot);
        None = the whole recording.
    start_lat_lon : (float, float) or None, deg
        Start of the geodetic path; None = the first GPS fix (if any).
    use_gps : bool
        Use the GPS fixes of the input (start point and comparison).
    sensor_calibration : str
        The IMU calibration applied to the input (``bootnav.postproc.calibration.resolve_calibration``): "auto"
        = the stored calibration of the recording's device id, if any; "none"; or a calibration file.
    """

    detector: str = "robust"
    detector_params: dict = field(default_factory=dict)
    length: str = "frequency_variance"
    length_params: dict = field(default_factory=dict)
    height_m: float | None = None
    heading: str = "auto"
    heading0_deg: float = 0.0
    declination_deg: float = 0.0
    forward_axis: tuple[float, float, float] = (0.0, 1.0, 0.0)
    complementary_tau_s: float = 10.0
    gravity_cutoff_hz: float = 0.3
    gyro_signed_magnitude: bool = False
    compass_window_s: float = 0.4
    mag_tilt: str = "gravity"
    tilt_weight_window_s: float = 0.4
    mag_calibration: str = "none"
    mag_percentiles: tuple[float, float] = (5.0, 95.0)
    mag_calibration_window_s: tuple[float, float] | None = None
    start_lat_lon: tuple[float, float] | None = None
    use_gps: bool = True
    sensor_calibration: str = "auto"

    def to_dict(self) -> dict:
        """Plain JSON-able dict of every setting (tuples as lists)."""
        d = asdict(self)
        for k, v in d.items():
            if isinstance(v, tuple):
                d[k] = list(v)
        return d

    @classmethod
    def from_dict(cls, data: dict | None) -> "PdrSettings":
        """Settings from a full or partial dict (missing keys keep their defaults), as ``to_dict`` writes it;
        a whole summary.json of ``bootnav pdr`` is accepted too (its "settings").

        Parameters
        ----------
        data : dict or None
            Field name -> value; None = defaults.

        Returns
        -------
        PdrSettings

        Raises
        ------
        InputError
            An unknown key, a value of the wrong type, a negative duration, an unknown method name or an
            out-of-range value, named by its key path (e.g. ``settings.detector_params.max_step_s``).
        """
        from bootnav.postproc.settings import from_plain

        if isinstance(data, dict) and isinstance(data.get("settings"), dict) and "conventions" in data:
            data = data["settings"]
        s = from_plain(cls, data if data is not None else {}, "")
        s._check()
        return s

    def validate(self) -> "PdrSettings":
        """Raise InputError naming the first bad setting (the checks of ``from_dict``); returns self."""
        PdrSettings.from_dict(self.to_dict())
        return self

    def _check(self) -> None:
        from bootnav.postproc.pdr.detectors import DETECTORS
        from bootnav.postproc.pdr.heading.mag_calibration import MAG_CALIBRATIONS
        from bootnav.postproc.pdr.length import LENGTH_MODELS
        from bootnav.postproc.settings import from_plain

        def bad(key, why):
            raise InputError(f"settings.{key}: {why}")

        for key, choices in (("detector", DETECTORS), ("length", LENGTH_MODELS), ("heading", HEADING_METHODS),
                             ("mag_tilt", MAG_TILTS), ("mag_calibration", MAG_CALIBRATIONS)):
            if getattr(self, key) not in choices:
                bad(key, f"unknown {key.replace('_', ' ')} {getattr(self, key)!r}; choose one of {sorted(choices)}")
        for key, registry, name in (("detector_params", DETECTORS, self.detector),
                                    ("length_params", LENGTH_MODELS, self.length)):
            from_plain(registry[name], getattr(self, key), f".{key}")  # unknown keys, types, durations
        for key, n in (("forward_axis", 3), ("mag_percentiles", 2), ("mag_calibration_window_s", 2),
                       ("start_lat_lon", 2)):
            v = getattr(self, key)
            if v is None:
                continue
            if not isinstance(v, (list, tuple)) or len(v) != n or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x)
                                      for x in v):
                bad(key, f"expected {n} finite numbers, got {list(v)}")
            setattr(self, key, tuple(float(x) for x in v))
        if not np.any(self.forward_axis):
            bad("forward_axis", "the zero vector has no direction")
        lo, hi = self.mag_percentiles
        if not 0 <= lo < hi <= 100:
            bad("mag_percentiles", f"expected 0 <= low < high <= 100, got {[lo, hi]}")
        w = self.mag_calibration_window_s
        if w is not None and not 0 <= w[0] < w[1]:
            bad("mag_calibration_window_s", f"expected 0 <= t0 < t1 (s after the first sample), got {list(w)}")
        ll = self.start_lat_lon
        if ll is not None and not (-90 <= ll[0] <= 90 and -180 <= ll[1] <= 180):
            bad("start_lat_lon", f"latitude must be in [-90, 90] and longitude in [-180, 180], got {list(ll)}")
        for key in ("height_m", "complementary_tau_s", "gravity_cutoff_hz", "compass_window_s",
                    "tilt_weight_window_s"):
            v = getattr(self, key)
            if v is not None and not v > 0:
                bad(key, f"must be positive, got {v}")

    @classmethod
    def from_file(cls, path) -> "PdrSettings":
        """``from_dict`` of a JSON file; errors name the file."""
        from bootnav.postproc.settings import settings_from_file

        return settings_from_file(cls, path, "PDR settings file")

    def save(self, path) -> Path:
        """Write ``to_dict`` as JSON to ``path`` (temp file + rename: never a half-written file); returns it."""
        import json

        from bootnav.core import atomic

        return atomic.write_text(Path(path), json.dumps(self.to_dict(), indent=1) + "\n")


@dataclass
class PdrResult:
    t_s: np.ndarray  # (N,) step times
    length_m: np.ndarray
    yaw_enu_rad: np.ndarray  # direction of each step, counter-clockwise from east (bootnav.CONVENTIONS)
    x_m: np.ndarray  # east after each step
    y_m: np.ndarray  # north after each step
    events: object  # StepEvents (with the detector's trace)
    features: object  # StepFeatures
    settings: PdrSettings
    lat_deg: np.ndarray | None = None
    lon_deg: np.ndarray | None = None
    heading_source: str = "none"
    gravity_restored: bool = False
    gps: dict | None = None  # path.gps_comparison, when the input had GPS fixes
    start_lat_lon: tuple | None = None  # start of lat_deg/lon_deg (settings.start_lat_lon or from the first fix)
    notes: list = field(default_factory=list)  # warnings of the run (e.g. no walking motion, motion.walking_bouts)

    @property
    def count(self) -> int:
        return int(self.t_s.size)

    def summary(self) -> dict:
        d = float(np.sum(self.length_m))
        return {
            "software": dict(SOFTWARE),
            "steps": self.count,
            "distance_m": d,
            "mean_step_length_m": float(np.mean(self.length_m)) if self.count else None,
            "cadence_steps_per_min": float(60.0 * (self.count - 1) / (self.t_s[-1] - self.t_s[0]))
            if self.count > 2 else None,
            "final_x_m": float(self.x_m[-1]) if self.count else 0.0,
            "final_y_m": float(self.y_m[-1]) if self.count else 0.0,
            "heading_source": self.heading_source,
            "is_path": self.heading_source != "none",
            "warnings": list(self.notes) + ([] if self.heading_source != "none" else
                         ["no heading source (no gyroscope, no magnetometer or compass): steps and distance only; "
                          "x_m/y_m keep the start bearing and are not a path"]),
            "gravity_restored": self.gravity_restored,
            "conventions": CONVENTIONS,
            "settings": self.settings.to_dict(),
            "gps_comparison": None if self.gps is None else
            {k: v for k, v in self.gps.items() if not isinstance(v, np.ndarray)},
        }


def _check_inputs(t_s, acc_b):
    t = np.asarray(t_s, float)
    a = np.asarray(acc_b, float)
    if a.ndim != 2 or a.shape[1] != 3 or a.shape[0] != t.shape[0]:
        raise InputError(f"acc_b must be (N, 3) with N = len(t_s) = {t.shape[0]}; got {a.shape}")
    if t.size < 10 or not np.isfinite(t).any() or np.nanmax(t) - np.nanmin(t) <= 0:
        raise InputError(f"need at least 10 samples spanning a positive time; got {t.size}")
    fin = np.flatnonzero(np.isfinite(t))
    back = np.flatnonzero(np.diff(t[fin]) < 0)
    if back.size:  # a clock restart: sorting would interleave the two parts' steps (as process, refuse)
        i, j = int(fin[back[0] + 1]), int(fin[back[0]])
        raise InputError(f"sample {i}: time goes backwards ({t[j]:.6f} s -> {t[i]:.6f} s, a clock restart?); "
                         f"samples are never reordered: split the recording at sample {i} and run each part")
    bad = ~np.isfinite(a).all(axis=1)
    if bad.any():
        keep = ~bad & np.isfinite(t)
        return t[keep], a[keep], keep
    return t, a, None


def restore_gravity(acc_b: np.ndarray, g: float = STANDARD_GRAVITY_MPS2) -> list[np.ndarray]:
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


def _mag_bearing(settings, t, acc, mag):
    """Magnetic bearing per sample (rad): ``mag_calibration`` fitted on the recording (or its window), then
    levelled as ``mag_tilt`` says."""
    from bootnav.postproc.pdr.heading.mag_calibration import calibrate_mag
    from bootnav.postproc.pdr.heading.magnetometer import (tilt_compensated_heading, tilt_weight_heading,
                                                           untilted_heading)
    from bootnav.postproc.pdr.signals import gravity_direction, nominal_rate_hz

    mask = None
    if settings.mag_calibration_window_s is not None:
        lo, hi = settings.mag_calibration_window_s
        mask = (t - t[0] >= lo) & (t - t[0] <= hi)
    try:
        mag = calibrate_mag(mag, settings.mag_calibration, mask, settings.mag_percentiles)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    if settings.mag_tilt == "gravity":
        up = gravity_direction(acc, nominal_rate_hz(t), settings.gravity_cutoff_hz)
        return tilt_compensated_heading(mag, up, settings.forward_axis)
    if settings.mag_tilt == "weights":
        return tilt_weight_heading(t, mag, acc, settings.forward_axis, settings.tilt_weight_window_s)
    return untilted_heading(mag, settings.forward_axis)  # "none" (names checked by PdrSettings)


def _heading(settings, t, acc, gyro, mag, t_steps, compass=None):
    from bootnav.postproc.pdr.heading.complementary import complementary_heading
    from bootnav.postproc.pdr.heading.declination import apply_declination
    from bootnav.postproc.pdr.heading.gyro import gyro_heading

    method = settings.heading  # one of HEADING_METHODS (checked by PdrSettings)
    if method == "auto":
        method = "gyro" if gyro is not None else ("compass" if compass is not None else "none")
    psi0 = np.radians(settings.heading0_deg)
    if method == "none":
        return np.full(t_steps.size, psi0), "none"
    if method == "compass":
        if compass is None:
            raise InputError("heading 'compass' needs a device heading column (e.g. heading_deg); this input has none")
        bearing = compass_at_steps(t, compass, t_steps, settings.compass_window_s)
        return apply_declination(bearing, settings.declination_deg), "compass"
    if method in ("gyro", "complementary") and gyro is None:
        raise InputError(f"heading {method!r} needs a gyroscope; this input has none")
    if method in ("mag", "complementary") and mag is None:
        raise InputError(f"heading {method!r} needs a magnetometer; this input has none")
    gyro_opts = {"signed_magnitude": settings.gyro_signed_magnitude, "gravity_cutoff_hz": settings.gravity_cutoff_hz}
    if method == "gyro":
        tt, psi = gyro_heading(t, gyro, acc, psi0, **gyro_opts)
    else:
        psi_m = np.unwrap(apply_declination(_mag_bearing(settings, t, acc, mag), settings.declination_deg))
        tt = t
        psi = psi_m
        if method == "complementary":
            tg, psi_g = gyro_heading(t, gyro, acc, 0.0, **gyro_opts)
            psi_m_g = np.interp(tg, t, psi_m)
            psi = complementary_heading(tg, psi_g, psi_m_g, settings.complementary_tau_s)
            tt = tg
    return np.angle(np.exp(1j * np.interp(t_steps, tt, psi))), method


def run_pdr(t_s, acc_b, gyro_b=None, settings: PdrSettings | None = None, mag_b=None,
            compass_deg=None, gps=None) -> PdrResult:
    """Step-and-heading dead reckoning of one recording: steps, their lengths and directions, the path.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Sample times, s (any clock, never going backwards; irregular sampling and repeated times are
        fine, detectors resample).
    acc_b : array_like, shape (N, 3)
        Specific force in the sensor frame, m/s², gravity included. Linear acceleration (gravity removed
        by a phone's OS) is accepted: gravity is restored (``restore_gravity``). Rows with a non-finite
        value are dropped.
    gyro_b : array_like, shape (N, 3), optional
        Angular rate in the sensor frame, rad/s (heading "gyro", "complementary", and "auto").
    settings : PdrSettings, optional
        Detector, step-length model, heading method and their parameters (default ``PdrSettings()``).
    mag_b : array_like, shape (N, 3), optional
        Magnetometer in the sensor frame, any unit (heading "mag", "complementary").
    compass_deg : array_like, shape (N,), optional
        Heading computed by the device, deg clockwise from north (heading "compass", and "auto" without a
        gyro).
    gps : tuple of 3 array_like, optional
        (t_s, lat_deg, lon_deg) of a phone's GPS columns, same clock as ``t_s`` (rows without a fix allowed).
        Used when ``settings.use_gps``: the geodetic path starts at the first fix (unless
        ``settings.start_lat_lon``) and ``PdrResult.gps`` holds ``path.gps_comparison``.

    Returns
    -------
    PdrResult
        Per detected step: time ``t_s`` (s), ``length_m``, direction ``yaw_enu_rad`` (counter-clockwise
        from east), position after the step ``x_m`` (east), ``y_m`` (north) from the origin at the start,
        and ``lat_deg``/``lon_deg`` when ``settings.start_lat_lon`` is set or a GPS fix is given; plus the
        detector's events and trace, the step features, the heading source actually used and whether gravity was restored.

    Raises
    ------
    InputError
        Wrong array shapes, fewer than 10 samples, time going backwards (a clock restart), a bad setting
        (``PdrSettings.validate``), or a heading method whose sensor is missing.
    """
    from bootnav.postproc.pdr.detectors import make_detector
    from bootnav.postproc.pdr.length.features import step_features
    from bootnav.postproc.pdr.path import (geodetic_path, gps_comparison, gps_fixes, local_path, local_to_latlon,
                                           position_at, yaw_enu_from_bearing)

    settings = (settings or PdrSettings()).validate()
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
    from bootnav.postproc.pdr.motion import walking_bouts

    walking, motion_note = walking_bouts(t, acc, events.t_s)  # steps in pure sensor noise are not steps
    if not walking.all():
        events = replace(events, t_s=events.t_s[walking])
    feats = step_features(events.t_s, t, acc)
    length = _length_model(settings).estimate(feats)
    heading, source = _heading(settings, t, acc, gyro, mag, events.t_s, compass)  # bearings, cw from north
    x, y = local_path(length, heading)
    res = PdrResult(events.t_s, np.asarray(length, float), yaw_enu_from_bearing(heading), x, y, events, feats,
                    settings, heading_source=source, gravity_restored=gravity_restored,
                    notes=[motion_note] if motion_note else [])
    start = settings.start_lat_lon
    if gps is not None and settings.use_gps:
        fixes = gps_fixes(*gps)
        if fixes[0].size:
            res.gps = gps_comparison(res.t_s, x, y, float(t[0]), *fixes)
            if not start:  # the start point that puts the path on the first fix at the fix's time
                x0, y0 = position_at(fixes[0][0], res.t_s, x, y, float(t[0]))
                start = tuple(float(v) for v in local_to_latlon(-x0, -y0, fixes[1][0], fixes[2][0]))
    if start:
        res.start_lat_lon = tuple(start)
        res.lat_deg, res.lon_deg = geodetic_path(start[0], start[1], length, heading)
    return res


def calibrate_length(settings: PdrSettings, walks) -> dict:
    """Fit the step-length model of ``settings`` on calibration walks of known distance ([NKUA2009, §5.4]:
    20 m at normal, slow and fast pace): each walk's steps get the length distance / count, and the model's
    ``fit`` solves for its parameters by least squares over all steps.

    Parameters
    ----------
    settings : PdrSettings
        Detector, length model and its starting parameters.
    walks : iterable of (t_s, acc_b, distance_m)
        Sample times (s), specific force (N, 3) in m/s² and the walked distance (m) of each walk.

    Returns
    -------
    dict
        The fitted model's parameters (for ``settings.length_params``).

    Raises
    ------
    InputError
        The model has no ``fit``, or a walk yields fewer than 2 steps.
    """
    from bootnav.postproc.pdr.length.features import StepFeatures

    model = _length_model(settings)
    if not hasattr(model, "fit"):
        raise InputError(f"step-length model {settings.length!r} has no fit; calibrate ladetto, weinberg, "
                         "constant or footpath")
    parts, truth = [], []
    for t, acc, dist in walks:
        res = run_pdr(t, acc, None, PdrSettings(**{**asdict(settings), "heading": "none", "use_gps": False}))
        if res.count < 2:
            raise InputError(f"calibration walk of {dist} m: only {res.count} step(s) detected")
        parts.append(res.features)
        truth.append(np.full(res.count, float(dist) / res.count))
    feats = StepFeatures(*(np.concatenate([getattr(p, f.name) for p in parts]) for f in fields(StepFeatures)))
    return model.fit(feats, np.concatenate(truth)).to_dict()
