"""One check of a settings value against its dataclass field's type: the rule every settings object applies
(``postproc.settings`` for files and API keywords, ``postproc.detectors.DetectorSettings`` for a detector's
parameters, CLI flags through the same objects), so a value is refused the same way wherever it comes from.
"""

from __future__ import annotations

import json
import math
import types
import typing

from bootnav.core.errors import InputError


#: Ranges of settings (exact dotted path -> (lo, hi, unit, why)); a value outside is refused with its range,
#: never used. Above all the limits that guard against garbage must not be switched off by a huge value.
SETTING_RANGES: dict[str, tuple[float | None, float | None, str, str]] = {
    ".checks.max_gap_s": (0.0, 5.0, "s", "a longer gap hides strides no integration recovers; crop around it"),
    ".checks.max_stride_length_m": (0.5, 10.0, "m", "no foot moves further between two stance phases"),
    ".checks.max_stance_gyro_radps": (0.01, 2.0, "rad/s", "a foot flat on the ground turns at < 0.1 rad/s"),
    ".checks.min_duration_s": (0.0, 600.0, "s", ""),
    ".checks.min_stance_phases": (1, 100000, "", "a stride goes from one stance phase to the next"),
    ".output.plot_max_points": (100, 10_000_000, "points", ""),
    ".length_params.length_m": (0.1, 3.0, "m", "a walking or running step of a person"),
    ".length_params.k": (0.01, 2.0, "", "the model's factor; published values are 0.3-0.7"),
    ".height_m": (0.5, 2.5, "m", "the walker's body height"),  # PdrSettings (process's is .calibration.height_m)
    ".length_params.height_m": (0.5, 2.5, "m", "the walker's body height"),
}
#: Any ``*_s`` setting longer than this is a typo (a session is bounded to 6 h, ``bootnav.core.limits``).
SETTING_MAX_S = 6 * 3600.0


def check_bounds(value, where: str) -> None:
    """Refuse a number outside its range (``SETTING_RANGES`` by exact dotted path, then rules by name: fractions
    in [0, 1], standard deviations not negative, durations up to ``SETTING_MAX_S``)."""
    from bootnav.core.limits import check_range

    name = where.rsplit(".", 1)[-1]
    rng = SETTING_RANGES.get(where)
    if rng is None and name.endswith("_fraction"):
        rng = (0.0, 1.0, "", "a fraction")
    elif rng is None and (name.startswith("sigma_") or "_sigma_" in name or name.endswith("_sigma")):
        rng = (0.0, None, "", "a standard deviation")
    elif rng is None and name.endswith("_s"):
        rng = (0.0, SETTING_MAX_S, "s", "a duration, up to 6 h")
    if rng is not None:
        lo, hi, unit, why = rng
        check_range(f"settings{where}", value, lo, hi, unit, why=why)


def check_value(hint, value, where: str) -> None:
    """Refuse a value of the wrong JSON type for a scalar setting, a non-finite number, a negative duration.

    JSON ``true`` is not a number here (Python would take it as 1), and every ``*_s`` setting is a
    duration, so a negative one is a typo that would silently change the result. Numbers are range-checked
    (``check_bounds``).

    Parameters
    ----------
    hint
        The field's type hint (``float``, ``int | None``, ...); other hints are not checked here.
    value
        The value read from a file, a flag or a keyword.
    where
        Dotted path of the setting for the message (e.g. ``.detector.params.threshold``).

    Raises
    ------
    InputError
        ``settings<where>: what is wrong``.
    """
    args = typing.get_args(hint) if typing.get_origin(hint) in (typing.Union, types.UnionType) else (hint,)
    if value is None:
        if type(None) not in args:
            raise InputError(f"settings{where}: null is not allowed here")
        return
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if float in args:
        if not number or not math.isfinite(value):
            raise InputError(f"settings{where}: expected a finite number, got {json.dumps(value)}")
        if where.endswith("_s") and value < 0:
            raise InputError(f"settings{where}: a duration cannot be negative, got {value}")
        check_bounds(value, where)
    elif int in args:
        if not (number and isinstance(value, int)):
            raise InputError(f"settings{where}: expected an integer, got {json.dumps(value)}")
        check_bounds(value, where)
    elif bool in args:
        if not isinstance(value, bool):
            raise InputError(f"settings{where}: expected true or false, got {json.dumps(value)}")
    elif str in args and not isinstance(value, str):
        raise InputError(f"settings{where}: expected a string, got {json.dumps(value)}")
