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


def check_value(hint, value, where: str) -> None:
    """Refuse a value of the wrong JSON type for a scalar setting, a non-finite number, a negative duration.

    JSON ``true`` is not a number here (Python would take it as 1), and every ``*_s`` setting is a
    duration, so a negative one is a typo that would silently change the result.

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
    elif int in args:
        if not (number and isinstance(value, int)):
            raise InputError(f"settings{where}: expected an integer, got {json.dumps(value)}")
    elif bool in args:
        if not isinstance(value, bool):
            raise InputError(f"settings{where}: expected true or false, got {json.dumps(value)}")
    elif str in args and not isinstance(value, str):
        raise InputError(f"settings{where}: expected a string, got {json.dumps(value)}")
