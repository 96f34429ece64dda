"""Axis helpers for detectors that need a "vertical" or "horizontal" acceleration."""

from __future__ import annotations

import numpy as np

from bootnav.postproc.pdr.signals import G0, gravity_direction


def vertical_and_horizontal(acc: np.ndarray, fs_hz: float, mode: str):
    """Return (vertical, horiz_1, horiz_2) specific-force components, m/s^2.

    mode "sensor": sensor z, x, y as they are (literal: a belt/level phone with z up, [NKUA2009]).
    mode "gravity": projection on the low-passed gravity direction and on two horizontal unit vectors
    orthogonal to it (engineered: any mounting)."""
    acc = np.asarray(acc, float)
    if mode == "sensor":
        return acc[:, 2], acc[:, 0], acc[:, 1]
    up = gravity_direction(acc, fs_hz)
    ref = np.where(np.abs(up[:, [0]]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    e1 = np.cross(up, ref)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(up, e1)
    dot = lambda u: np.einsum("ij,ij->i", acc, u)  # noqa: E731
    return dot(up), dot(e1), dot(e2)


def to_unit(x: np.ndarray, unit: str) -> np.ndarray:
    """m/s^2 -> the unit a source's thresholds are written in ("g" or "m/s2")."""
    return np.asarray(x, float) / G0 if unit == "g" else np.asarray(x, float)
