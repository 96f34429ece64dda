"""How a stance mask is judged from the data alone: the ZUPT innovations at stance onsets
(``onset_innovations``; the passes of ``pipeline`` take their RMS over forward runs) and the confidence of a path (``confidence``); see
``bootnav.postproc.selftune``."""

from __future__ import annotations

import numpy as np

from bootnav.core.runs import runs

from .settings import SelfTuneSettings


def onset_innovations(t_s, vel_n, stance, filter_settings) -> np.ndarray:
    """Predicted velocity at each zero-velocity-update onset after a swing (the ZUPT innovation, negated).

    The onset is the first aided sample after the onset delay (``ins.prepare.delay_zupt_onsets``), and the
    value is the unaided prediction one sample before it. The initial still period (a phase starting at
    sample 0) has no swing before it and is skipped.

    Parameters
    ----------
    t_s : (N,) sample times, s.
    vel_n : (N, 3) velocity of a filter run WITHOUT smoother, m/s.
    stance : (N,) bool stance mask given to that run.
    filter_settings : its ``FilterSettings`` (onset delay and cap).

    Returns
    -------
    (K, 3) velocities, one per update onset, m/s.
    """
    from bootnav.postproc.ins.prepare import delay_zupt_onsets

    aided = delay_zupt_onsets(t_s, stance, filter_settings.zupt_onset_delay_s,
                              filter_settings.zupt_onset_max_fraction)
    k0, _ = runs(aided)
    k0 = k0[k0 > 0]
    return np.asarray(vel_n)[k0 - 1]


def confidence(innovation_rms_mps: float, bad_fraction: float, period_s: float,
               settings: SelfTuneSettings | None = None) -> float:
    """Confidence in [0, 1] of a path: (1 − b) · exp(−e / v_scale); 0 without a periodic gait (module docstring)."""
    s = settings or SelfTuneSettings()
    if not (np.isfinite(period_s) and np.isfinite(innovation_rms_mps)):
        return 0.0
    return float(np.clip((1.0 - bad_fraction) * np.exp(-innovation_rms_mps / s.v_scale_mps), 0.0, 1.0))
