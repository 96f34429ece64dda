"""The common output of every step detector: step times plus the intermediate signals for plots."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class StepEvents:
    """Detected steps.

    t_s:    (N,) step event times on the input clock, s (increasing).
    method: detector name.
    trace:  intermediate arrays for plots/diagnostics (e.g. ``t_s`` grid, ``signal``, ``threshold``),
            each documented by the detector that writes it.
    """

    t_s: np.ndarray
    method: str = ""
    trace: dict = field(default_factory=dict)

    def __post_init__(self):
        self.t_s = np.sort(np.asarray(self.t_s, dtype=float).ravel())

    @property
    def count(self) -> int:
        return int(self.t_s.size)


def step_intervals(t_steps: np.ndarray, max_step_s: float = 1.5) -> tuple[np.ndarray, np.ndarray]:
    """Start/end time of each step: step i runs from step i-1 to step i (the Leppäkoski and Li detectors of
    [Bayindir2014]: "the start of the next step is the end of the detected step"). The first step of a bout
    (gap to the previous step > ``max_step_s``, or no previous step) gets the median step duration of the
    run [engineered]."""
    t = np.asarray(t_steps, float)
    if t.size == 0:
        return t.copy(), t.copy()
    d = np.diff(t)
    ok = d[d <= max_step_s]
    med = float(np.median(ok)) if ok.size else 0.55
    dur = np.r_[med, d]
    dur[dur > max_step_s] = med
    return t - dur, t
