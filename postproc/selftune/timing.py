"""The vertical channel's timing self-calibration: the offset τ between specific force and attitude that
makes the level strides level (``level_timing_offset``, from probes ``timing_from_probes``), applied by
``rotate_specific_force``; see ``bootnav.postproc.selftune``."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from bootnav.core.arrays import row_dot, row_norm
from bootnav.core.runs import runs
from bootnav.errors import InputError
from bootnav.postproc.strides import footprints

from .scoring import onset_innovations


def rotate_specific_force(acc_b: np.ndarray, gyro_b: np.ndarray, tau_s: float) -> np.ndarray:
    """f_b' = exp(−[ω_b×] τ) f_b per sample: the specific force as seen at the attitude of time t − τ.

    Parameters
    ----------
    acc_b : (N, 3) specific force, m/s²; gyro_b : (N, 3) angular rate, rad/s; tau_s : offset τ, s.

    Returns
    -------
    (N, 3) rotated specific force (exact rotation by the angle ‖ω‖ τ, Rodrigues' formula).
    """
    even, odd, axial = _rotation_terms(acc_b, gyro_b, tau_s)
    return even + odd + axial


def _rotation_terms(acc_b, gyro_b, tau_s: float):
    """The terms f c, (u × f) s and u (u·f)(1 − c) of ``rotate_specific_force`` (angle ‖ω τ‖ about
    u = −ω τ / ‖ω τ‖): their sum is the rotation by τ; negating the odd one gives the rotation by −τ, bit for bit
    (IEEE rounding is symmetric in sign), for the price of one."""
    th = -np.asarray(gyro_b, float) * tau_s
    a = row_norm(th)
    u = th / np.where(a > 0, a, 1.0)[:, None]
    c, sn = np.cos(a)[:, None], np.sin(a)[:, None]
    f = np.asarray(acc_b, float)
    return f * c, np.cross(u, f) * sn, u * row_dot(u, f)[:, None] * (1.0 - c)


def level_stride_dz(t_s, pos_n, stance, max_dz_m: float = 0.1, min_length_m: float = 0.3,
                    max_level_strides: int | None = None) -> tuple[float, int]:
    """Median height change of the level strides (|Δz| < max_dz_m, length > min_length_m) and their count.

    Parameters
    ----------
    t_s, pos_n, stance : a path and its stance mask (``segment_strides`` gives the strides).
    max_dz_m, min_length_m : what counts as a level stride (m).
    max_level_strides : only the first this many level strides count (None: all).

    Returns
    -------
    (median Δz in m, NaN without level strides; number of level strides counted).
    """
    from bootnav.postproc.strides import footprints

    return footprint_level_dz(*footprints(t_s, pos_n, stance), max_dz_m, min_length_m, max_level_strides)


def footprint_level_dz(t_mid, fp, max_dz_m: float = 0.1, min_length_m: float = 0.3,
                       max_level_strides: int | None = None) -> tuple[float, int]:
    """``level_stride_dz`` from the stance phases' mid times and footprints (``strides.footprints``)."""
    from bootnav.postproc.strides import footprint_strides

    st = footprint_strides(t_mid, fp)
    lev = (np.abs(st["dz_m"]) < max_dz_m) & (st["stride_length_m"] > min_length_m)
    if max_level_strides is not None:
        lev &= np.cumsum(lev) <= max_level_strides
    return (float(np.median(st["dz_m"][lev])) if lev.sum() else float("nan")), int(lev.sum())


def level_timing_offset(t_s, acc_b, gyro_b, stance, init, gravity: float, filter_settings, *, saturated=None,
                        delta_s: float = 0.002, max_abs_s: float = 0.003, min_level_strides: int = 10,
                        max_level_strides: int | None = None) -> dict:
    """Timing offset τ (s) that zeroes the median height change of the level strides (module docstring).

    Two forward filter runs (no smoother: it moves τ* by < 0.3 ms and triples the cost) at τ = ±``delta_s``
    give the line m(τ); τ* is its zero crossing, clipped to ±``max_abs_s``. Apply it with
    ``rotate_specific_force(acc_b, gyro_b, tau_s)`` before the final filter run. The two runs are independent
    and run in two threads (the filter kernel releases the GIL): two free cores give both for about the time
    of one.

    With ``max_level_strides`` = K, m(τ) is the median of the first K level strides, and the probes run over
    the first 2K + 1 stance phases only (whole phases and the swing after the last), a part twice as long
    while it holds fewer than K level strides, up to the whole recording: a long recording costs the probes
    of its first part. A recording with at most 2K + 1 stance phases is probed whole, as with K = None.

    Parameters
    ----------
    t_s, acc_b, gyro_b : calibrated samples (s, m/s², rad/s).
    stance : (N,) bool stance mask; init : ``calibration.InitialState``; gravity : m/s².
    filter_settings : ``FilterSettings`` (the smoother and the level-stride height hold are switched off for
        the two runs).
    saturated : optional saturation mask (as ``run_filter`` takes it).
    delta_s : the two probe offsets ±δ, s; max_abs_s : bound of τ*, s.
    min_level_strides : fewer level strides than this: no calibration (τ* = 0).
    max_level_strides : only the first this many level strides count (None: all; see above).

    Returns
    -------
    dict with ``tau_s`` (τ*), ``m_minus`` / ``m_plus`` (median level-stride Δz at −δ / +δ, m), ``n_level``
    (level strides counted), ``innovation_rms_mps`` (RMS ZUPT-onset innovation of the two runs, for
    ``confidence``), ``probe_s`` (seconds of the recording the probes ran over) and ``applied`` (False when
    τ* = 0 for lack of level strides or a flat m(τ)).
    """
    import os
    from concurrent.futures import ThreadPoolExecutor

    from bootnav.postproc.ins import run_filter

    if max_level_strides is not None and max_level_strides < 1:
        raise InputError(f"settings selftune.timing_max_level_strides: {max_level_strides} level strides; give at "
                         "least 1, or null for all of them")
    # the probes measure the level strides' height drift: the height hold (level_height) would erase it
    probe_settings = replace(filter_settings, smoother="none", level_height=False)
    starts = runs(np.asarray(stance, bool))[0]
    phases = len(starts) if max_level_strides is None else 2 * max_level_strides + 1
    while True:
        cut = int(starts[phases]) if phases < len(starts) else len(t_s)  # whole stance phases and the swing after
        t, g, st = t_s[:cut], gyro_b[:cut], stance[:cut]
        sat = None if saturated is None else saturated[:cut]
        even, odd, axial = _rotation_terms(acc_b[:cut], g, -delta_s)  # sum: τ = −δ; odd term negated: τ = +δ

        def probe(sign: int) -> tuple[float, int, float]:
            f = (even + odd if sign < 0 else even - odd) + axial
            nav = run_filter(t, f, g, st, init, gravity, probe_settings, saturated=sat)
            m, n_level = level_stride_dz(t, np.asarray(nav.pos_n), st, max_level_strides=max_level_strides)
            v = onset_innovations(t, nav.vel_n, st, filter_settings)
            return m, n_level, (float(np.mean(np.sum(v**2, axis=1))) if len(v) else float("inf"))

        with ThreadPoolExecutor(max_workers=min(2, os.cpu_count() or 1)) as pool:  # one CPU: one after the other
            (m_minus, n_minus, e2_minus), (m_plus, n_level, e2_plus) = pool.map(probe, (-1, 1))
        if cut == len(t_s) or min(n_minus, n_level) >= max_level_strides:
            break
        phases *= 2  # too few level strides in this part (stairs, shuffling): probe a part twice as long
    out = {"m_minus": m_minus, "n_level": n_level, "m_plus": m_plus,
           "innovation_rms_mps": float(np.sqrt(np.mean([e2_minus, e2_plus]))),
           "probe_s": float(t_s[cut - 1] - t_s[0])}
    return timing_from_probes(out, delta_s, max_abs_s, min_level_strides)


def timing_from_probes(out: dict, delta_s: float, max_abs_s: float, min_level_strides: int) -> dict:
    """τ* (``tau_s``) and ``applied`` from the probes' ``m_minus``, ``m_plus``, ``n_level`` (``level_timing_offset``);
    updates and returns ``out``."""
    slope = (out["m_plus"] - out["m_minus"]) / (2 * delta_s)
    ok = out["n_level"] >= min_level_strides and np.isfinite(slope) and abs(slope) > 0
    m0 = 0.5 * (out["m_plus"] + out["m_minus"])
    out["tau_s"] = float(np.clip(-m0 / slope, -max_abs_s, max_abs_s)) if ok else 0.0
    out["applied"] = bool(ok)
    return out
