"""Position from steps.

Local path ([NKUA2009, appendix code Π5]), bearing h clockwise from north, ENU (x east, y north):
    x_k = x_{k-1} + L_k sin(h_k),   y_k = y_{k-1} + L_k cos(h_k)

[Lazarevskiy2021, eq. 3.2] (theta counter-clockwise from north, degrees; literal form):
    X(i+1) = cos(theta(i) + 90) l + X(i),   Y(i+1) = sin(theta(i) + 90) l + Y(i)
(identical to the above with h = -theta).

Map ([Lazarevskiy2021, eq. 3.3]), constants 40 000 000 m (meridian) and 40 075 696 m (equator) [literal]:
    lat(i+1) = lat(i) + cos(theta(i)) l 360 / 40 000 000
    lon(i+1) = lon(i) - sin(theta(i)) l 360 / (40 075 696 cos(lat(i)))     (cos of lat in DEGREES)
"""

from __future__ import annotations

import numpy as np

MERIDIAN_M = 40_000_000.0
EQUATOR_M = 40_075_696.0


def yaw_enu_from_bearing(bearing_rad) -> np.ndarray:
    """Bearing (clockwise from north, the sources' convention used inside this package) -> ``yaw_enu_rad``
    (counter-clockwise from east, ``bootnav.CONVENTIONS["heading"]``), in (-pi, pi]."""
    h = np.asarray(bearing_rad, float)
    return np.arctan2(np.cos(h), np.sin(h))


def local_path(length_m, bearing_rad, x0: float = 0.0, y0: float = 0.0):
    """Positions AFTER each step (N,), (N,) in metres; bearings clockwise from north."""
    L = np.asarray(length_m, float)
    h = np.asarray(bearing_rad, float)
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


def geodetic_path(lat0_deg: float, lon0_deg: float, length_m, bearing_rad):
    """Eq. 3.3 with the bootnav bearing (theta = -h); positions after each step (N,)."""
    lat, lon = seed003_geodetic_path(lat0_deg, lon0_deg, -np.degrees(np.asarray(bearing_rad, float)), length_m)
    return lat[1:], lon[1:]


def checkpoint_errors(est_xy, true_xy) -> np.ndarray:
    """Euclidean distance between estimated and true checkpoints, no reset ([NKUA2009, Table 6.3.3])."""
    return np.linalg.norm(np.asarray(est_xy, float) - np.asarray(true_xy, float), axis=1)


def polyline_length(xy) -> float:
    return float(np.sum(np.linalg.norm(np.diff(np.asarray(xy, float), axis=0), axis=1)))


def gps_fixes(t_s, lat_deg, lon_deg):
    """The valid, changed GPS fixes of a phone log: rows with a non-finite or (0, 0) position are dropped
    (no fix yet, [Lazarevskiy2021] R21), and a fix repeated on the following rows (the app re-sends the last
    one) is kept only at its first row. Returns (t_s, lat_deg, lon_deg), possibly empty."""
    t = np.asarray(t_s, float)
    lat = np.asarray(lat_deg, float)
    lon = np.asarray(lon_deg, float)
    ok = np.isfinite(t) & np.isfinite(lat) & np.isfinite(lon) & ((lat != 0.0) | (lon != 0.0))
    t, lat, lon = t[ok], lat[ok], lon[ok]
    new = np.r_[True, (np.diff(lat) != 0.0) | (np.diff(lon) != 0.0)] if t.size else np.zeros(0, bool)
    return t[new], lat[new], lon[new]


def latlon_to_local(lat_deg, lon_deg, lat0_deg: float, lon0_deg: float):
    """East, north (m) from (lat0, lon0) with the eq. 3.3 constants (its inverse, locally flat Earth)."""
    north = (np.asarray(lat_deg, float) - lat0_deg) * MERIDIAN_M / 360.0
    east = (np.asarray(lon_deg, float) - lon0_deg) * EQUATOR_M * np.cos(np.radians(lat0_deg)) / 360.0
    return east, north


def local_to_latlon(east_m, north_m, lat0_deg: float, lon0_deg: float):
    """Inverse of ``latlon_to_local``."""
    lat = lat0_deg + np.asarray(north_m, float) * 360.0 / MERIDIAN_M
    lon = lon0_deg + np.asarray(east_m, float) * 360.0 / (EQUATOR_M * np.cos(np.radians(lat0_deg)))
    return lat, lon


def position_at(t_query, t_steps, x_m, y_m, t_start: float):
    """PDR position at arbitrary times: the path (origin at ``t_start``, then the position after each step)
    interpolated linearly in time, held after the last step."""
    tt = np.r_[t_start, np.asarray(t_steps, float)]
    return (np.interp(t_query, tt, np.r_[0.0, np.asarray(x_m, float)]),
            np.interp(t_query, tt, np.r_[0.0, np.asarray(y_m, float)]))


def gps_comparison(t_steps, x_m, y_m, t_start: float, gps_t, gps_lat, gps_lon) -> dict:
    """Distance between the PDR path and the GPS track ([Lazarevskiy2021, §3.1.13], there visual only;
    R22 asks for numbers): both put in local east/north metres about the first fix, the PDR path shifted so
    that it passes the first fix at the fix's time; at every later fix within the walk, the horizontal
    distance between the two.

    Parameters
    ----------
    t_steps, x_m, y_m : array_like, shape (N,)
        Step times (s) and PDR positions after each step (m east, north of the start).
    t_start : float
        Time of the PDR origin (first sample), s.
    gps_t, gps_lat, gps_lon : array_like, shape (M,)
        Valid fixes (``gps_fixes``), same clock as ``t_steps``.

    Returns
    -------
    dict
        ``n_fixes``, ``mean_m``, ``rms_m``, ``max_m``, ``final_m`` (at the last fix), ``gps_distance_m``
        (length of the GPS track), ``first_fix`` [lat, lon], ``first_fix_t_s``, and the series ``t_s``,
        ``pdr_east_m``, ``pdr_north_m``, ``gps_east_m``, ``gps_north_m`` (for the plot).
    """
    gt = np.asarray(gps_t, float)
    if gt.size == 0:
        raise ValueError("no GPS fix")
    lat0, lon0 = float(gps_lat[0]), float(gps_lon[0])
    ge, gn = latlon_to_local(gps_lat, gps_lon, lat0, lon0)
    px, py = position_at(gt, t_steps, x_m, y_m, t_start)
    px, py = px - px[0], py - py[0]
    keep = gt <= (np.max(t_steps) if np.size(t_steps) else t_start)
    keep[0] = True
    d = np.hypot(px - ge, py - gn)[keep]
    later = d[1:] if d.size > 1 else d
    return {"n_fixes": int(keep.sum()), "mean_m": float(np.mean(later)), "rms_m": float(np.sqrt(np.mean(later ** 2))),
            "max_m": float(np.max(later)), "final_m": float(d[-1]),
            "gps_distance_m": polyline_length(np.column_stack([ge, gn])[keep]),
            "first_fix": [lat0, lon0], "first_fix_t_s": float(gt[0]),
            "t_s": gt[keep], "pdr_east_m": px[keep], "pdr_north_m": py[keep], "gps_east_m": ge[keep],
            "gps_north_m": gn[keep]}


def checkpoint_report(t_steps, x_m, y_m, t_start: float, t_check, x_true, y_true) -> dict:
    """[NKUA2009, Table 6.3.3] checkpoint evaluation of a PDR path: the estimated position at each
    checkpoint time against its true position (same local frame, origin at the start), no reset.

    Parameters
    ----------
    t_steps, x_m, y_m : array_like, shape (N,)
        Step times (s) and positions after each step (m).
    t_start : float
        Time of the origin (first sample), s.
    t_check, x_true, y_true : array_like, shape (K,)
        Checkpoint times (s, same clock) and true positions (m east, north of the start).

    Returns
    -------
    dict
        ``error_m`` per checkpoint, ``final_error_m``, ``max_error_m``, ``true_path_m`` (length of the
        start + checkpoints polyline, the thesis' 99.41 m), ``est_x_m``, ``est_y_m``.
    """
    ex, ey = position_at(np.asarray(t_check, float), t_steps, x_m, y_m, t_start)
    err = checkpoint_errors(np.column_stack([ex, ey]), np.column_stack([x_true, y_true]))
    return {"error_m": err.tolist(), "final_error_m": float(err[-1]), "max_error_m": float(err.max()),
            "true_path_m": polyline_length(np.r_[[[0.0, 0.0]], np.column_stack([x_true, y_true])]),
            "est_x_m": ex.tolist(), "est_y_m": ey.tolist()}
