"""What a filter run needs besides the samples: initial state and covariance, paper-mode gain, kernel
parameters (``prepare_filter``), and the per-sample variance of saturated samples (``saturation_variance``).

Shared by ``filter.run_filter`` (both engines) and ``stream.StreamNavigator``, so that a whole-record run
and a stream start from the very same numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bootnav.core.runs import runs
from bootnav.errors import InputError
from bootnav.postproc.ins.params import kernel_params
from bootnav.postproc.ins.settings import FilterSettings


# a run's info lists its timestamp gaps (sample index, Δt) up to this many (bounded memory and summary.json;
# ``n_gaps`` of a stream counts them all)
MAX_LISTED_GAPS = 1000


def initial_covariance(settings: FilterSettings) -> np.ndarray:
    """P₀ = diag of the initial error sigmas (yaw separately: alignment cannot see it)."""
    s = [settings.init_pos_sigma_m] * 3 + [settings.init_vel_sigma_mps] * 3
    s += [settings.init_att_sigma_rad] * 2 + [settings.init_yaw_sigma_rad]
    if settings.n_states == 15:
        s += [settings.init_acc_bias_sigma_mps2] * 3 + [settings.init_gyro_bias_sigma_radps] * 3
    return np.diag(np.square(s))


def _init_vector(init, name, default):
    v = getattr(init, name, None)
    if v is None:
        return np.array(default, dtype=float)
    v = np.asarray(v, dtype=float).reshape(-1)
    if not np.all(np.isfinite(v)):
        raise InputError(f"initial state {name} is not finite: {v}")
    return v


def saturation_variance(saturated, n: int, settings: FilterSettings) -> np.ndarray | None:
    """Extra per-sample variance of each body axis (ax, ay, az, gx, gy, gz) of saturated samples, (N, 6), or
    None when nothing is saturated.

    A clipped sample says only "at least full scale": the true value is unknown, so instead of trusting the
    clipped number with the normal noise the filter adds ``sat_acc_sigma_mps2``² / ``sat_gyro_sigma_radps``²
    to that sample's per-sample variance (process noise) ALONG THE CLIPPED BODY AXIS (the other axes are
    fine), i.e. the velocity / attitude uncertainty grows in that direction through the clipped burst and
    the next ZUPTs correct the error it caused. ``saturated``: (N,) bitmask (bits ax, ay, az, gx, gy, gz as
    ``bootnav.logger.recording.SATURATION_BITS``), or (N, 6) bool, or (N,) bool (every axis).
    """
    if saturated is None:
        return None
    sat = np.asarray(saturated)
    if sat.shape[0] != n:
        raise InputError(f"saturated must have {n} rows like t_s, got shape {sat.shape}")
    if sat.ndim == 2:
        axes = sat[:, :6].astype(bool)
    elif sat.dtype == bool:
        axes = np.repeat(sat[:, None], 6, axis=1)
    else:
        bits = sat.astype(np.uint8)
        axes = np.column_stack([(bits >> b) & 1 for b in range(6)]).astype(bool)
    if not axes.any():
        return None
    sig2 = np.array([settings.sat_acc_sigma_mps2**2] * 3 + [settings.sat_gyro_sigma_radps**2] * 3)
    out = axes * sig2
    return out if out.any() else None


@dataclass
class FilterSetup:
    """What a filter run needs besides the samples, prepared once by ``prepare_filter`` (both engines and the
    streaming navigator start from it)."""

    q0_nb: np.ndarray  # (4,) initial attitude, wxyz, w >= 0
    gyro_bias0_b: np.ndarray  # (3,) rad/s
    acc_bias0_b: np.ndarray  # (3,) m/s²
    P0: np.ndarray  # (n, n) initial error covariance
    zupt_gain: object  # riccati.ZuptGain in the paper mode, else None
    prm: object  # params.KernelParams
    warnings: list


def prepare_filter(init, gravity: float, settings: FilterSettings, nominal_dt_s: float, t_s=None,
                   zupt_mask=None) -> FilterSetup:
    """Initial state, initial covariance, paper-mode gain and kernel parameters of a run.

    Parameters
    ----------
    init : object
        Initial state (``run_filter``'s ``init``).
    gravity : float
        Local gravity magnitude, m/s² (5-15).
    settings : FilterSettings
        Validated settings.
    nominal_dt_s : float
        Nominal sample period Δt₀, s: the per-sample noise, the smoother's segment cap and the paper-mode
        gain are defined at it.
    t_s, zupt_mask : (N,) arrays, optional
        The whole record's times and ZUPT mask, for the paper mode's per-sample open-loop durations τ that
        the reference engine reads (the fast engine computes τ as it goes).

    Returns
    -------
    FilterSetup

    Raises
    ------
    InputError
        Bad gravity or initial state.
    ValueError
        The paper mode's Riccati equation has no stabilising solution.
    """
    if not (np.isfinite(gravity) and 5.0 < gravity < 15.0):
        raise InputError(f"gravity must be the local magnitude in m/s² (about 9.8), got {gravity!r}")
    if not (np.isfinite(nominal_dt_s) and nominal_dt_s > 0):
        raise InputError(f"the nominal sample period must be a positive number of seconds, got {nominal_dt_s!r}")
    warnings: list[str] = []
    q0 = _init_vector(init, "q_nb", [1.0, 0.0, 0.0, 0.0])
    if q0.shape != (4,) or not 0.5 < np.linalg.norm(q0) < 1.5:
        raise InputError(f"init.q_nb must be a unit quaternion (w, x, y, z), got {q0}")
    q0 = q0 / np.linalg.norm(q0) * (1.0 if q0[0] >= 0 else -1.0)
    bg0 = _init_vector(init, "gyro_bias_b", np.zeros(3))
    ba0 = _init_vector(init, "acc_bias_b", np.zeros(3))
    zupt_gain = None
    smooth = settings.smoother == "rts"
    if settings.mode == "riccati":
        from bootnav.postproc.ins.riccati import paper_zupt_gain, still_period_acc_bias

        zupt_gain = paper_zupt_gain(settings, gravity, nominal_dt_s, t_s, zupt_mask)
        if getattr(init, "acc_bias_b", None) is None and getattr(init, "acc_mean_b", None) is not None:
            ba0 = still_period_acc_bias(_init_vector(init, "acc_mean_b", [0.0, 0.0, gravity]), gravity)
        if smooth:
            smooth = False
            warnings.append("smoother disabled in riccati (paper) mode: RTS needs the optimal time-varying P")
    max_segment = max(16, int(math.ceil(settings.smoother_max_segment_s / nominal_dt_s)))
    prm = kernel_params(settings, gravity, nominal_dt_s, zupt_gain is not None, smooth, max_segment)
    return FilterSetup(q0, bg0, ba0, initial_covariance(settings), zupt_gain, prm, warnings)


def gated_chunks(bounds: np.ndarray, heading_gate) -> list[tuple[int, int, bool]]:
    """The engines' push chunks (``bounds``: increasing sample indices from 0 to N) split where the heading
    aid's per-segment gate changes: ``(a, b, open)`` with the gate constant over samples a..b−1 (``open`` True
    everywhere when ``heading_gate`` is None). The engine sets ``st[HDE_GATE]`` before each push."""
    bounds = np.asarray(bounds, dtype=np.int64)
    if heading_gate is None:
        return [(int(a), int(b), True) for a, b in zip(bounds[:-1], bounds[1:])]
    gate = np.asarray(heading_gate, dtype=bool).reshape(-1)
    n = int(bounds[-1])
    if gate.shape[0] != n:
        raise InputError(f"heading_gate has {gate.shape[0]} samples, the record {n}: give one flag per sample")
    change = np.flatnonzero(np.diff(gate.view(np.int8))) + 1
    cuts = np.union1d(bounds, change)
    return [(int(a), int(b), bool(gate[a])) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]


def delay_zupt_onsets(t_s: np.ndarray, stance: np.ndarray, delay_s: float, max_fraction: float) -> np.ndarray:
    """Stance mask with the first min(delay_s, max_fraction × phase duration) of every stance phase removed.

    Why: a detector reports stance as soon as the foot's energy falls, but after heel strike the foot is still
    settling (loading response: heel rocker to foot flat, the first ~10 % of the gait cycle, ≈ 0.1 s
    [Perry2010]). There the sensor still moves at a few cm/s, and a ZUPT would read that real motion as
    accumulated velocity ERROR and move the position by P_pv P_vv⁻¹ δv (a vertical jump per stride on the
    developer loops; tuning log). Letting the mechanization integrate that settling removes the jump.
    The cap keeps most of a short (running) stance phase. A phase starting at sample 0 (the initial
    still period) is kept whole.

    Parameters
    ----------
    t_s : (N,) array
        Sample times, s.
    stance : (N,) bool array
        Detected stance.
    delay_s : float
        Longest part removed at each onset, s (0: off).
    max_fraction : float
        Largest fraction of a phase removed (0: off).

    Returns
    -------
    (N,) bool array
        The ZUPT mask.
    """
    out = np.array(stance, dtype=bool, copy=True)
    if delay_s <= 0 or max_fraction <= 0 or not out.any():
        return out
    starts, stops = runs(out)
    keep = starts > 0
    starts, stops = starts[keep], stops[keep]
    cut_t = t_s[starts] + np.minimum(delay_s, max_fraction * (t_s[stops - 1] - t_s[starts]))
    cut = np.searchsorted(t_s, cut_t, side="left")
    for a, c in zip(starts, cut):
        out[a:c] = False
    return out
