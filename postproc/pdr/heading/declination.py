"""Magnetic declination ([NKUA2009, §4.4]): heading_true = heading_mag + declination, declination
EAST-positive. Example from the thesis: New York, October 2008, 13°7' W = -13.1167 deg, changing
0°1' E per year."""

from __future__ import annotations

import numpy as np


def dms_to_deg(deg: float, minutes: float = 0.0, hemisphere: str = "E") -> float:
    """13°7' W -> -13.1167 (east positive)."""
    v = abs(deg) + minutes / 60.0
    return -v if hemisphere.upper() == "W" else v


def apply_declination(heading_mag_rad, declination_deg: float) -> np.ndarray:
    """True bearing = magnetic bearing + declination (east positive), wrapped to (-pi, pi]."""
    h = np.asarray(heading_mag_rad, float) + np.radians(declination_deg)
    return np.angle(np.exp(1j * h))
