"""Position from steps.

Local path (seed-000 §5.4 R14, test T3), bearing h clockwise from north, ENU (x east, y north):
    x_k = x_{k-1} + L_k sin(h_k),   y_k = y_{k-1} + L_k cos(h_k)

seed-003 eq. 3.2 (theta counter-clockwise from north, degrees; literal form, test T7/T9):
    X(i+1) = cos(theta(i) + 90) l + X(i),   Y(i+1) = sin(theta(i) + 90) l + Y(i)
(identical to the above with h = -theta).

Map (seed-003 eq. 3.3, test T8), constants 40 000 000 m (meridian) and 40 075 696 m (equator) [literal]:
    lat(i+1) = lat(i) + cos(theta(i)) l 360 / 40 000 000
    lon(i+1) = lon(i) - sin(theta(i)) l 360 / (40 075 696 cos(lat(i)))     (cos of lat in DEGREES)
"""

from __future__ import annotations

import numpy as np

MERIDIAN_M = 40_000_000.0
EQUATOR_M = 40_075_696.0


def local_path(length_m, heading_rad, x0: float = 0.0, y0: float = 0.0):
    """Positions AFTER each step (N,), (N,) in metres."""
    L = np.asarray(length_m, float)
    h = np.asarray(heading_rad, float)
    return x0 + np.cumsum(L * np.sin(h)), y0 + np.cumsum(L * np.cos(h))


def seed003_local_path(theta_deg, l_m):
    """Eq. 3.2 verbatim; returns N+1 points starting at the origin."""
    th = np.radians(np.asarray(theta_deg, float) + 90.0)
    L = np.broadcast_to(np.asarray(l_m, float), th.shape)
    return np.r_[0.0, np.cumsum(np.cos(th) * L)], np.r_[0.0, np.cumsum(np.sin(th) * L)]


def seed003_geodetic_path(lat0_deg: float, lon0_deg: float, theta_deg, l_m):
    """Eq. 3.3 verbatim (sequential: cos(lat(i)) uses the previous latitude); N+1 points."""
    th = np.radians(np.asarray(theta_deg, float))
    L = np.broadcast_to(np.asarray(l_m, float), th.shape)
    dlat = np.cos(th) * L * 360.0 / MERIDIAN_M
    lat = lat0_deg + np.r_[0.0, np.cumsum(dlat)]
    dlon = -np.sin(th) * L * 360.0 / (EQUATOR_M * np.cos(np.radians(lat[:-1])))
    return lat, lon0_deg + np.r_[0.0, np.cumsum(dlon)]


def geodetic_path(lat0_deg: float, lon0_deg: float, length_m, heading_rad):
    """Eq. 3.3 with the bootnav bearing (theta = -h); positions after each step (N,)."""
    lat, lon = seed003_geodetic_path(lat0_deg, lon0_deg, -np.degrees(np.asarray(heading_rad, float)), length_m)
    return lat[1:], lon[1:]


def checkpoint_errors(est_xy, true_xy) -> np.ndarray:
    """seed-000 R21: Euclidean distance between estimated and true checkpoints (no reset)."""
    return np.linalg.norm(np.asarray(est_xy, float) - np.asarray(true_xy, float), axis=1)


def polyline_length(xy) -> float:
    return float(np.sum(np.linalg.norm(np.diff(np.asarray(xy, float), axis=0), axis=1)))
