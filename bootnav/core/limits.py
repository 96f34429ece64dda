"""Range checks of numbers given by a user (flags, settings), with the range in the message.

One function, ``check_range``, used where a value is parsed: a value outside its physical or practical range is
refused before any work with ``FLAG VALUE: must be LO <= X <= HI UNIT (why)``, never silently clipped, never
passed on to become a 31-year simulation, a negative distance or an exception of a library.
"""

from __future__ import annotations

import math
import os

from bootnav.core.errors import InputError

#: Longest walk a command simulates or a recorder session is bounded to (s): a firefighter's breathing-apparatus
#: shift is under an hour; 6 h covers a long exercise, and keeps a simulation in memory (~0.5 GB per hour at
#: 200 Hz) and in minutes.
MAX_SESSION_S = 6 * 3600.0

#: Most worker processes a command starts (--jobs): beyond a few per core only memory grows.
MAX_JOBS = 4 * (os.cpu_count() or 1) + 4


def check_range(flag: str, value, lo: float | None = None, hi: float | None = None, unit: str = "", *,
                lo_open: bool = False, hi_open: bool = False, why: str = "", integer: bool = False):
    """Return ``value`` if it is a finite number within the range; else ``InputError`` stating the range.

    Parameters
    ----------
    flag
        How the user gave it: ``--duration`` or ``settings .checks.max_gap_s``.
    value
        The parsed number (None passes: "not given").
    lo, hi
        Bounds (None: unbounded on that side).
    unit
        Unit shown after the range ("s", "m", "Hz").
    lo_open, hi_open
        Exclude the bound itself (``0 < X``).
    why
        A few words on where the range comes from.
    integer
        The value must be a whole number.
    """
    if value is None:
        return None
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    ok = number and math.isfinite(value)
    if ok and integer and float(value) != int(value):
        ok = False
    if ok and lo is not None:
        ok = value > lo if lo_open else value >= lo
    if ok and hi is not None:
        ok = value < hi if hi_open else value <= hi
    if ok:
        return value
    left = "" if lo is None else f"{lo:g} {'<' if lo_open else '<='} "
    right = "" if hi is None else f" {'<' if hi_open else '<='} {hi:g}"
    kind = "a whole number" if integer else "a number"
    unit = f" {unit}" if unit else ""
    shown = value if not isinstance(value, float) else f"{value:g}"
    raise InputError(f"{flag} {shown}: must be {kind} with {left}X{right}{unit}" + (f" ({why})" if why else ""))


def check_jobs(flag: str, jobs) -> int | None:
    """``--jobs N``: None (all cores) or 1 <= N <= ``MAX_JOBS``."""
    return check_range(flag, jobs, 1, MAX_JOBS, "processes", integer=True,
                       why=f"worker processes; this machine has {os.cpu_count() or 1} cores")


def check_duration(flag: str, seconds, hi: float = MAX_SESSION_S) -> float | None:
    """A session length in seconds: 0 < S <= ``hi`` (default 6 h, ``MAX_SESSION_S``)."""
    return check_range(flag, seconds, 0.0, hi, "s", lo_open=True,
                       why=f"up to {hi / 3600:g} h; split a longer session" if hi >= 3600 else "")
