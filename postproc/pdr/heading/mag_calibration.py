"""Hard/soft-iron magnetometer calibration.

[NKUA2009, §4.3], 2-axis percentile method [literal scale factors]:
    X_sf = max(1, (H_y95 - H_y05) / (H_x95 - H_x05))
    Y_sf = max(1, (H_x95 - H_x05) / (H_y95 - H_y05))
    X_off = ((H_x95 - H_x05)/2 - H_x95) X_sf,  Y_off likewise        [centring form, Honeywell; the
                                                                     thesis' OCR shows a different,
                                                                     non-centring form: uncertain]
    H^_x = X_sf H_x + X_off,  H^_y = Y_sf H_y + Y_off,  azimuth = atan2(H^_y, H^_x)
``literal_offset=True`` uses the OCR form c[(H95 - H05)/2 - H05] sf with c = 1 (as read; does not centre).

Ellipsoid fit [engineered, standard]: fit the quadric x^T A x + b^T x + c = 0 to 3-D samples by least
squares (A symmetric positive definite), centre o = -A^{-1} b / 2, soft-iron correction W = sqrtm(A / k)
with k = o^T A o - c, so that |W (m - o)| = 1 (scaled to the mean field norm).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class PercentileCalibration:
    x_sf: float
    y_sf: float
    x_off: float
    y_off: float

    def apply(self, hx, hy):
        return self.x_sf * np.asarray(hx, float) + self.x_off, self.y_sf * np.asarray(hy, float) + self.y_off

    def azimuth_rad(self, hx, hy):
        cx, cy = self.apply(hx, hy)
        return np.arctan2(cy, cx)


def percentile_calibration(hx, hy, lo: float = 5.0, hi: float = 95.0,
                           literal_offset: bool = False) -> PercentileCalibration:
    hx = np.asarray(hx, float)
    hy = np.asarray(hy, float)
    x05, x95 = np.percentile(hx, [lo, hi])
    y05, y95 = np.percentile(hy, [lo, hi])
    dx, dy = x95 - x05, y95 - y05
    x_sf = max(1.0, dy / dx)
    y_sf = max(1.0, dx / dy)
    if literal_offset:
        x_off, y_off = (dx / 2 - x05) * x_sf, (dy / 2 - y05) * y_sf
    else:
        x_off, y_off = (dx / 2 - x95) * x_sf, (dy / 2 - y95) * y_sf
    return PercentileCalibration(x_sf, y_sf, x_off, y_off)


@dataclass
class EllipsoidCalibration:
    offset: np.ndarray  # hard iron (3,)
    soft_iron: np.ndarray  # (3, 3) W
    field_norm: float

    def apply(self, mag_b):
        return (np.asarray(mag_b, float) - self.offset) @ self.soft_iron.T * self.field_norm


def ellipsoid_fit(mag_b) -> EllipsoidCalibration:
    """General ellipsoid fit (needs samples spread over many orientations; >= 9 points)."""
    m = np.asarray(mag_b, float)
    x, y, z = m.T
    D = np.column_stack([x * x, y * y, z * z, 2 * x * y, 2 * x * z, 2 * y * z, 2 * x, 2 * y, 2 * z])
    # normalise: sum of the quadric = 1 (the constant term moved to the right-hand side)
    p, *_ = np.linalg.lstsq(D, np.ones(len(m)), rcond=None)
    A = np.array([[p[0], p[3], p[4]], [p[3], p[1], p[5]], [p[4], p[5], p[2]]])
    b = 2 * p[6:9]
    o = -0.5 * np.linalg.solve(A, b)
    k = o @ A @ o + 1.0
    M = A / k
    w, V = np.linalg.eigh(M)
    if np.any(w <= 0):
        raise ValueError("ellipsoid fit failed: samples do not span enough orientations")
    W = V @ np.diag(np.sqrt(w)) @ V.T
    norm = float(np.mean(np.linalg.norm(m - o, axis=1)))
    return EllipsoidCalibration(o, W, norm)


def ellipse_fit_2d(hx, hy) -> EllipsoidCalibration:
    """2-D ellipse fit (level device turned in the horizontal plane): the z axis is left unchanged."""
    hx = np.asarray(hx, float)
    hy = np.asarray(hy, float)
    D = np.column_stack([hx * hx, hy * hy, 2 * hx * hy, 2 * hx, 2 * hy])
    p, *_ = np.linalg.lstsq(D, np.ones(hx.size), rcond=None)
    A = np.array([[p[0], p[2]], [p[2], p[1]]])
    o = -0.5 * np.linalg.solve(A, 2 * p[3:5])
    k = o @ A @ o + 1.0
    w, V = np.linalg.eigh(A / k)
    if np.any(w <= 0):
        raise ValueError("ellipse fit failed: the samples do not trace an ellipse")
    W2 = V @ np.diag(np.sqrt(w)) @ V.T
    W = np.eye(3)
    W[:2, :2] = W2
    norm = float(np.mean(np.hypot(hx - o[0], hy - o[1])))
    return EllipsoidCalibration(np.r_[o, 0.0], W, norm)


MAG_CALIBRATIONS = ("none", "percentile", "percentile_literal", "ellipse", "ellipsoid")


def calibrate_mag(mag_b, method: str = "none", fit_mask=None, percentiles=(5.0, 95.0)) -> np.ndarray:
    """The magnetometer samples corrected by one of the calibrations above, fitted on the recording itself.

    Parameters
    ----------
    mag_b : array_like, shape (N, 3)
        Field in the sensor frame, any unit.
    method : str
        "none"; "percentile" ([NKUA2009, §4.3] scale factors, centring offsets; x and y only, z kept);
        "percentile_literal" (the offsets as the thesis' OCR reads them); "ellipse" (2-D fit, z kept);
        "ellipsoid" (3-D fit, needs samples over many orientations).
    fit_mask : array_like of bool, shape (N,), optional
        Samples to fit on (e.g. a calibration turn at the start of the walk); default all.
    percentiles : (float, float)
        Lower and upper percentile of the "percentile" methods (the thesis' 5 and 95: a few outliers
        from nearby iron do not set the range).

    Returns
    -------
    ndarray, shape (N, 3)
        The corrected field (every sample, fitted on ``fit_mask``).
    """
    m = np.array(mag_b, float)
    if method == "none":
        return m
    if method not in MAG_CALIBRATIONS:
        raise ValueError(f"unknown magnetometer calibration {method!r}; choose one of {MAG_CALIBRATIONS}")
    f = m if fit_mask is None else m[np.asarray(fit_mask, bool)]
    if len(f) < 9:
        raise ValueError(f"magnetometer calibration {method!r} needs at least 9 samples to fit; got {len(f)}")
    if method.startswith("percentile"):
        cal = percentile_calibration(f[:, 0], f[:, 1], *percentiles, literal_offset=method == "percentile_literal")
        m[:, 0], m[:, 1] = cal.apply(m[:, 0], m[:, 1])
        return m
    cal = ellipse_fit_2d(f[:, 0], f[:, 1]) if method == "ellipse" else ellipsoid_fit(f)
    out = cal.apply(m)
    if method == "ellipse":
        out[:, 2] = m[:, 2]
    return out
