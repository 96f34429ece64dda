"""Piecewise septic Hermite trajectories: C3 curves with exact analytic derivatives.

A channel (x, y, z, yaw, pitch, roll) is given at knots ``t_k`` by its value and first three time
derivatives ``(p, v, a, j)``. On each piece ``[t_k, t_k+1]`` with ``h = t_k+1 - t_k`` and
``tau = (t - t_k) / h`` the unique degree-7 polynomial matching both ends is

    P(tau) = c0 + c1 tau + ... + c7 tau^7,
    c0 = p0,  c1 = v0 h,  c2 = a0 h^2 / 2,  c3 = j0 h^3 / 6,
    [c4..c7] = M^-1 [A, B, C, D],   M = [[1, 1, 1, 1], [4, 5, 6, 7], [12, 20, 30, 42], [24, 60, 120, 210]],
    A = p1 - (c0 + c1 + c2 + c3),  B = v1 h - (c1 + 2 c2 + 3 c3),
    C = a1 h^2 - (2 c2 + 6 c3),    D = j1 h^3 - 6 c3,

and ``d^n P / dt^n = P^(n)(tau) / h^n``. Position, velocity, acceleration and jerk are continuous
everywhere (C3, so specific force is C1 and angular rate C2) and exact (no numerical
differentiation). A piece whose two end knots are equal with zero derivatives has c1..c7 == 0 exactly,
so the foot is *exactly* still there (stance). A polynomial generator of degree <= 7 sampled at the
knots (e.g. minimum-jerk) is reproduced exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CHANNELS = ("x", "y", "z", "yaw", "pitch", "roll")  # m, m, m, rad (ZYX Euler angles of the foot)
DEGREE = 7
_M_INV = np.linalg.inv(np.array([[1, 1, 1, 1], [4, 5, 6, 7], [12, 20, 30, 42], [24, 60, 120, 210]], dtype=float))


def hermite_coefficients(t: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """Monomial coefficients (K-1, C, 8) in tau for knots ``(K, C, 4)`` = (value, d1, d2, d3)."""
    h = np.diff(t)[:, None]
    p0, v0, a0, j0 = (knots[:-1, :, i] for i in range(4))
    p1, v1, a1, j1 = (knots[1:, :, i] for i in range(4))
    c0, c1, c2, c3 = p0, v0 * h, a0 * h**2 / 2.0, j0 * h**3 / 6.0
    rhs = np.stack([p1 - (c0 + c1 + c2 + c3), v1 * h - (c1 + 2 * c2 + 3 * c3), a1 * h**2 - (2 * c2 + 6 * c3),
                    j1 * h**3 - 6 * c3], axis=-1)
    # rest pieces: exact zeros stay exact zeros (0 * finite = 0), so stance is exactly still
    high = rhs @ _M_INV.T
    return np.concatenate([np.stack([c0, c1, c2, c3], axis=-1), high], axis=-1)


# falling factorials k! / (k - n)! for derivative order n <= 3 and power k <= 7
_FALL = np.array([[float(np.prod(np.arange(k - n + 1, k + 1))) if k >= n else 0.0 for k in range(DEGREE + 1)]
                  for n in range(4)])


def poly_eval(c: np.ndarray, tau: np.ndarray, h: np.ndarray, order: int = 2) -> list[np.ndarray]:
    """Value and time derivatives up to ``order`` of monomials ``c[..., k]`` at ``tau`` (Horner)."""
    out = []
    deg = c.shape[-1] - 1
    for n in range(order + 1):
        f = _FALL[n]
        acc = f[deg] * c[..., deg]
        for k in range(deg - 1, n - 1, -1):
            acc = acc * tau + f[k] * c[..., k]
        out.append(acc / h**n)
    return out


@dataclass
class Trajectory:
    """Foot trajectory: knot times (K,), knot data (K, 6, 4) for CHANNELS, stance flag per piece.

    ``evaluate(t)`` returns value, first and second time derivative of every channel, (N, 6) each.
    """

    t_knots: np.ndarray
    knots: np.ndarray
    piece_still: np.ndarray  # (K-1,) bool, True where the foot is flat and exactly still

    def __post_init__(self):
        self.t_knots = np.asarray(self.t_knots, dtype=np.float64)
        if np.any(np.diff(self.t_knots) <= 0):
            raise ValueError("trajectory knot times must increase strictly")
        self._coef = hermite_coefficients(self.t_knots, self.knots)
        self._h = np.diff(self.t_knots)

    def mirrored_roll(self) -> "Trajectory":
        """The same path with the roll channel negated (left foot)."""
        knots = self.knots.copy()
        knots[:, 5, :] *= -1.0
        return Trajectory(self.t_knots, knots, self.piece_still)

    @property
    def duration_s(self) -> float:
        return float(self.t_knots[-1] - self.t_knots[0])

    def piece_index(self, t: np.ndarray) -> np.ndarray:
        idx = np.searchsorted(self.t_knots, t, side="right") - 1
        return np.clip(idx, 0, len(self._h) - 1)

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(value, d/dt, d2/dt2) each (N, 6), and stance (N,) bool, at times ``t``."""
        t = np.asarray(t, dtype=np.float64)
        idx = self.piece_index(t)
        still = self.piece_still[idx]
        p = self._coef[idx, :, 0]  # stance pieces are constant: value c0, derivatives exactly 0
        d1 = np.zeros_like(p)
        d2 = np.zeros_like(p)
        move = np.flatnonzero(~still)
        if move.size:
            im = idx[move]
            h = self._h[im][:, None]
            tau = ((t[move] - self.t_knots[im]) / self._h[im])[:, None]
            p[move], d1[move], d2[move] = poly_eval(self._coef[im], tau, h, 2)
        return p, d1, d2, still
