"""Stance (zero-velocity) detectors for a foot-mounted IMU.

Each detector is a configured object with one entry method, ``detect(acc_b, gyro_b, t_s) ->
StanceResult`` (``base.StanceDetector``), in a module of its own with its equations and references, and
registered by name in ``DETECTORS``: ``adaptive`` (the default: a per-stride threshold read off the
recording itself, no tuning), ``shoe`` (SHOE/GLRT [Skog2010], the source paper's eq. 2 [Heidari2019], squared
or the paper's printed form), ``shoe-literal`` (the printed form as the paper used it), ``ared``, ``mv``,
``mag`` [Skog2010], ``paper_accmag`` (the paper's empirical acceleration threshold), ``xio`` (x-io filtered
magnitude [Madgwick]), ``learned`` (a tiny network trained on motion-capture stance labels, shipped with its
weights and provenance [Wagstaff2020]; docs/learned-stance.md). ``postprocess`` holds the mask post-processing they share (hysteresis, minimum
stance / swing durations).

Entry point of the pipeline: ``detect_stance(t_s, acc_b, gyro_b, settings, gravity, saturated=None) ->
StanceResult``; it builds the detector named by ``DetectorSettings.method`` (the saved settings) and
excludes saturated samples (the recording's bitmask and/or automatically detected clipping plateaus).
"""

from __future__ import annotations

import typing
from dataclasses import MISSING, dataclass, field, fields
from typing import Any

from bootnav.core.validate import check_value
from bootnav.core.conventions import STANDARD_GRAVITY_MPS2
from bootnav.errors import InputError

from . import postprocess
from bootnav.core.arrays import as_imu_arrays, clipped_samples, saturation_mask
from .base import DETECTORS, StanceDetector, StanceResult, detector_class, register

from . import adaptive, ared, learned, mag, mv, paper_accmag, shoe, xio  # noqa: F401  (importing them fills DETECTORS)

__all__ = ["DETECTORS", "DetectorSettings", "StanceDetector", "StanceResult", "detect_stance", "detector_class", "parameter_fields",
           "postprocess", "register"]


#: the flat fields of ``DetectorSettings`` before 2026-12 (``<method>_<parameter>`` or ``<parameter>``): a settings
#: file or summary.json saved with them still loads (``DetectorSettings.upgrade_saved``)
#: (name -> its type, checked as it was then, even when the chosen method ignores it)
LEGACY_FIELDS: dict[str, Any] = {
    "window_samples": int | None, "threshold": float | None, "literal_paper_form": bool,
    **{name: float for name in (
        "window_s", "sigma_acc_mps2", "sigma_gyro_radps", "hysteresis_ratio", "min_stance_s", "min_swing_s",
        "saturation_guard_s", "adaptive_window_s", "adaptive_span_s", "adaptive_alpha", "adaptive_floor_decades",
        "adaptive_noise_quantile", "adaptive_min_stance_s", "adaptive_isolated_min_stance_s", "adaptive_isolation_s",
        "adaptive_min_swing_s", "adaptive_max_rate_radps", "shoe_literal_min_stance_s", "shoe_literal_min_swing_s",
        "paper_accmag_min_stance_s", "paper_accmag_min_swing_s", "xio_min_stance_s", "xio_min_swing_s")}}


class DetectorParams(dict):
    """The resolved parameters of one detector (a dict that remembers whose they are: given to another
    ``method``, as ``dataclasses.replace(settings, method="shoe")`` does, they are dropped for that detector's
    defaults; a plain dict is always validated against the method)."""

    def __init__(self, *args, method: str = "", **kwargs):
        super().__init__(*args, **kwargs)
        self.method = method


@dataclass
class DetectorSettings:
    """The stance detector of a run, as saved with the results: ``{"method": "shoe", "params": {...}}``.

    The registered detector class is the schema of its parameters (as gaitmap nests
    ``zupt_detector=NormZuptDetector(...)`` [Kuderle2024]): ``params`` holds exactly the fields of
    ``DETECTORS[method]`` (but ``gravity_mps2``, which comes from the calibration), each default is the class
    field's default (defined once, in the detector's module), and every value is checked on construction
    against the field's type (``bootnav.core.validate.check_value``) and physical range
    (``StanceDetector.check``). A settings file, an API keyword (``detector={"method": "shoe", "params":
    {"threshold": 2e5}}``) and a CLI flag (``--detector``, ``--threshold``: ``with_params``) all end here.

    method: registry name of the detector (``DETECTORS``; ``bootnav process --list-detectors``), default
        "adaptive" (the per-stride threshold read off the recording, no tuning).
    params: the detector's parameters by name (its class docstring says what each means); missing ones
        take the class default, an unknown one is an error that lists the known ones. ``threshold: None``
        means the detector's own default.
    detect_clipping: also treat per-axis full-scale plateaus as saturated (files without a mask); not a
        parameter of the detector but of what it is given.
    """

    method: str = "adaptive"
    params: dict[str, Any] = field(default_factory=dict)
    detect_clipping: bool = True

    def __setattr__(self, name, value):
        """Every assignment is validated; assigning another ``method`` selects that detector with its default
        parameters (the old ones belong to the old detector)."""
        ready = "params" in self.__dict__ and "detect_clipping" in self.__dict__
        if not ready or name not in ("method", "params", "detect_clipping"):
            object.__setattr__(self, name, value)
            return
        before = dict(self.__dict__)
        if name == "method" and value != self.method:
            object.__setattr__(self, "params", {})
        object.__setattr__(self, name, value)
        try:
            self.__post_init__()
        except ValueError:
            self.__dict__.update(before)  # a refused value leaves the settings as they were
            raise

    def __post_init__(self):
        cls = detector_class(self.method)  # unknown name: ValueError listing the registered ones
        if not isinstance(self.params, dict):
            raise ValueError(f"params of {self.method!r} must be an object of parameters, got {self.params!r}")
        if isinstance(self.params, DetectorParams) and self.params.method != self.method:
            # another detector's resolved parameters (``dataclasses.replace(s, method=...)``): its defaults
            object.__setattr__(self, "params", {})
        known = parameter_fields(cls)
        unknown = sorted(set(self.params) - set(known))
        if unknown:
            raise ValueError(f"stance detector {self.method!r} has no parameter(s) {unknown}; its parameters: "
                             f"{', '.join(known)}")
        hints = typing.get_type_hints(cls)
        resolved = {}
        for name, f in known.items():
            value = self.params[name] if name in self.params else _field_default(f)
            if isinstance(value, list):  # JSON has no tuples
                value = tuple(value)
            try:
                check_value(hints.get(name), value, f".detector.params.{name}")
            except InputError as exc:
                raise ValueError(str(exc).removeprefix("settings.detector.")) from None
            resolved[name] = value
        object.__setattr__(self, "params", DetectorParams(resolved, method=self.method))
        try:
            cls(**resolved).check()
        except ValueError as exc:
            raise ValueError(f"params.{exc}") from None

    @classmethod
    def upgrade_saved(cls, data: dict) -> dict:
        """A saved detector section in the current form: the flat fields of earlier versions
        (``LEGACY_FIELDS``: ``<method>_<parameter>``, else ``<parameter>``) become ``params``; a current
        section is returned unchanged. Flat fields the chosen method does not have are dropped (they held
        another detector's parameters). A missing flat field meant its old default, which is the class
        default of the parameter it filled: the detector built is the one the older version built."""
        if not isinstance(data, dict) or not set(data) & set(LEGACY_FIELDS):
            return data
        if "params" in data:
            raise InputError(f"settings.detector: both 'params' and the flat fields {sorted(set(data) & set(LEGACY_FIELDS))} "
                             "of an older version; keep one")
        for key in set(data) & set(LEGACY_FIELDS):
            check_value(LEGACY_FIELDS[key], data[key], f".detector.{key}")
        method = data.get("method", cls.method)
        try:
            known = parameter_fields(detector_class(method))
        except ValueError as exc:
            raise InputError(f"settings.detector.method: {exc}") from None
        prefix = method.replace("-", "_") + "_"
        params = {}
        for name in known:
            for key in (prefix + name, name):
                if key in data:
                    params[name] = data[key]
                    break
                if key in LEGACY_FIELDS:  # an older file without it meant its old default, the class default
                    break
        return {**{k: v for k, v in data.items() if k not in LEGACY_FIELDS}, "params": params}

    def to_dict(self) -> dict:
        return {"method": self.method, "params": dict(self.params), "detect_clipping": self.detect_clipping}

    def with_params(self, **changes) -> "DetectorSettings":
        """The same detector with some parameters changed (validated; an unknown one is an error)."""
        return DetectorSettings(self.method, {**self.params, **changes}, self.detect_clipping)

    def with_method(self, method: str, **params) -> "DetectorSettings":
        """Detector ``method`` with ``params`` over its defaults — over this one's parameters when it is the
        same method (another detector's parameters do not carry over); ``detect_clipping`` is kept."""
        base = self.params if method == self.method else {}
        return DetectorSettings(method, {**base, **params}, self.detect_clipping)

    def build(self, gravity: float = STANDARD_GRAVITY_MPS2) -> StanceDetector:
        """The configured detector of ``method`` (an instance of ``DETECTORS[method]``) at local gravity
        ``gravity`` (m/s²)."""
        return detector_class(self.method)(gravity_mps2=float(gravity), **self.params)


def parameter_fields(cls: type[StanceDetector]) -> dict:
    """The settable parameters of a detector class, {name: dataclass field} (``gravity_mps2`` comes from the
    calibration, not from the settings)."""
    return {f.name: f for f in fields(cls) if f.init and f.name != "gravity_mps2"}


def _field_default(f):
    return f.default_factory() if f.default is MISSING else f.default


def detect_stance(t_s, acc_b, gyro_b, settings: DetectorSettings | None = None,
                  gravity: float = STANDARD_GRAVITY_MPS2, *, saturated=None) -> StanceResult:
    """Stance mask of one recording with the detector the settings name.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Sample times, s.
    acc_b, gyro_b : array_like, shape (N, 3)
        Specific force (m/s², gravity included) and angular rate (rad/s) in the body frame.
    settings : DetectorSettings, optional
        Detector and its parameters (default: ``DetectorSettings()``, the adaptive detector).
    gravity : float
        Local gravity, m/s².
    saturated : array_like, shape (N,) or (N, k), optional
        The recording's saturation bitmask or bool mask; with ``settings.detect_clipping`` the full-scale
        plateaus found in the data are added. Saturated samples are never stance.

    Returns
    -------
    StanceResult
        Stance mask, statistic, threshold, method and ``info`` (with ``n_saturated``).
    """
    s = settings or DetectorSettings()
    t_s, acc_b, gyro_b = as_imu_arrays(t_s, acc_b, gyro_b)
    sat = saturation_mask(saturated, t_s.shape[0])
    if s.detect_clipping:
        sat = sat | clipped_samples(acc_b) | clipped_samples(gyro_b)
    result = s.build(gravity).detect(acc_b, gyro_b, t_s, excluded=sat)
    result.info["n_saturated"] = int(sat.sum())
    return result
