"""Runs of a boolean mask: the one run-length helper (stance phases, saturated bursts, gaps, swings).

A run is a maximal block of consecutive True samples. Stance phases, saturated bursts and missing-sample
blocks are all runs of some mask, so they are all found here, vectorised: the edges of the mask padded
with False on both ends are where ``diff`` is +1 (a run starts) or -1 (the previous sample ended one).
"""

from __future__ import annotations

import numpy as np


def runs(mask, *, min_samples: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop indices of the runs of True in a 1-D mask.

    Parameters
    ----------
    mask : array_like, shape (N,)
        Anything ``np.asarray(mask, dtype=bool)`` accepts (nonzero counts as True).
    min_samples : int, optional
        Keep only the runs at least this many samples long (default 1: every run).

    Returns
    -------
    starts, stops : ndarray of int64, shape (K,)
        ``mask[starts[k]:stops[k]]`` is the k-th run, in order; ``stops`` are exclusive, so the run lengths
        are ``stops - starts``. Both are empty when the mask has no True sample.
    """
    m = np.asarray(mask, dtype=bool)
    if m.ndim != 1:
        raise ValueError(f"runs: mask must be 1-D, got shape {m.shape}")
    edges = np.diff(np.concatenate(([0], m.view(np.int8), [0])))
    starts = np.flatnonzero(edges == 1).astype(np.int64, copy=False)
    stops = np.flatnonzero(edges == -1).astype(np.int64, copy=False)
    if min_samples > 1:
        keep = stops - starts >= min_samples
        starts, stops = starts[keep], stops[keep]
    return starts, stops
