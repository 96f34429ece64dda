"""JSON in and out: plain JSON types from numpy-laden objects, and a user JSON file read with a clear error.

Written JSON must be strict (``allow_nan=False`` everywhere), so an undefined number (NaN, inf) becomes
``null``; numpy scalars and arrays become Python numbers and lists; dataclasses become objects.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from bootnav.core.errors import InputError


def to_jsonable(obj: Any, *, max_array_size: int | None = 64) -> Any:
    """``obj`` as plain JSON types (dict, list, str, int, float, bool, None).

    Parameters
    ----------
    obj : any
        Nested dicts, lists, tuples, dataclasses, numpy scalars and arrays, paths, numbers.
    max_array_size : int or None
        Arrays with more elements are summarised as ``{"shape": [...], "dtype": "..."}`` instead of dumped
        (a JSON summary is no place for a signal); None dumps every array.

    Returns
    -------
    any
        NaN and ±inf as None, numpy values as Python values, tuples as lists, dict keys as str, paths and
        unknown objects as their ``str``.
    """
    if obj is None or isinstance(obj, (bool, int, str)):
        return obj
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, np.generic):
        return to_jsonable(obj.item(), max_array_size=max_array_size)
    if isinstance(obj, np.ndarray):
        if max_array_size is not None and obj.size > max_array_size:
            return {"shape": list(obj.shape), "dtype": str(obj.dtype)}
        return to_jsonable(obj.tolist(), max_array_size=max_array_size)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return to_jsonable(dataclasses.asdict(obj), max_array_size=max_array_size)
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v, max_array_size=max_array_size) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v, max_array_size=max_array_size) for v in obj]
    return str(obj)


def read_json_file(path: str | Path, what: str) -> Any:
    """Parsed JSON of a user's file (settings, calibration), with an error that names the file and the spot.

    Parameters
    ----------
    path : str or Path
        The file.
    what : str
        What the file is, for the message ("settings file").

    Returns
    -------
    any
        The parsed document.

    Raises
    ------
    InputError
        "PATH: WHAT not found" or "PATH: invalid JSON at line L column C: ...".
    """
    from bootnav.core.paths import regular_input

    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: {what} not found")
    regular_input(path, what)  # a FIFO would block forever, a device never end
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"{path}: {what} not found") from None
    except RecursionError:
        raise InputError(f"{path}: {what} is nested too deeply to read (thousands of nested [ or {{); a settings "
                         "file is a few levels deep: check that this is the right file") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}") from None
