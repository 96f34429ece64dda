"""Local maxima of a sampled signal: the one peak finder of the step and gait detectors."""

from __future__ import annotations

import numpy as np


def local_maxima(x: np.ndarray, plateau: str = "middle") -> np.ndarray:
    """Indices of the local maxima of ``x``: a sample, or a run of equal samples, higher than both neighbours
    (the first and last samples are never peaks; NaN is never part of a peak).

    With ``plateau="middle"`` a run is reported by its middle index (rounded down): exactly the peaks
    ``scipy.signal.find_peaks(x)`` returns without conditions (numpy only: importing ``scipy.signal`` costs
    ~0.7 s). ``"last"``: by its last index.

    Parameters
    ----------
    x : (N,) float array.
    plateau : {"middle", "last"}

    Returns
    -------
    (K,) int64 array of indices, increasing.
    """
    x = np.asarray(x)
    n = len(x)
    if n < 3:
        return np.zeros(0, np.int64)
    change = np.flatnonzero(x[1:] != x[:-1]) + 1  # first index of each run of equal values but the first
    first = np.concatenate(([0], change))
    last = np.concatenate((change, [n])) - 1
    inner = (first > 0) & (last < n - 1)
    first, last = first[inner], last[inner]
    peak = (x[first - 1] < x[first]) & (x[last + 1] < x[first])
    top = last[peak] if plateau == "last" else (first[peak] + last[peak]) // 2
    return top.astype(np.int64)
