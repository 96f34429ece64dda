"""Putting two feet on one clock and one navigation frame.

**Clock** (``gait_clock_offset``). A multi-boot recording is on one session clock already (each device clock
mapped to host receive time, ``docs/recording-format.md``); two files of one synchronised system (Voisard's
Xsens suit, gaitmap's NilsPods) are too. What is left is checked — or, for two files without a common clock,
estimated — from the gait itself: the feet alternate, and in steady walking each foot's stance onset falls
half-way between two onsets of the other foot (temporal gait symmetry; healthy step-time asymmetry is a few
percent of the stride time [Perry2010]). For every right-foot stance onset between two left onsets of one
stride (the stride no longer than 1.5 × the median stride time: not across a pause) the phase
φ = (t_R − t_L,i) / (t_L,i+1 − t_L,i) gives the right clock's lateness δ = (φ − ½)(t_L,i+1 − t_L,i);
the estimate is the median of δ (robust to turns and stair starts) and its residual the scaled median
absolute deviation of δ (1.4826 MAD). The offset to ADD to the right foot's ``t_s`` is −median(δ). Its
accuracy is limited by the walker's own asymmetry (tens of ms), so on a session clock it is reported, not
applied (``TwoBootSettings.clock``).

**Frame** (``heading_offset_rad``). Each foot's alignment sets its initial yaw to 0 in its own sensor axes (yaw
is unobservable at rest), so the two navigation frames differ by a rotation about z — the two sensors'
mounting yaw and the feet's toe-out angles. Both feet travel together, so the rotation is the angle
whose turn best maps the right foot's displacements onto the left's over the first ``heading_alignment_m`` walked.
"""

from __future__ import annotations

import math

import numpy as np

from bootnav.core.runs import runs

MAD_TO_SIGMA = 1.4826  # MAD of a normal distribution × this = its standard deviation
DISPLACEMENT_WINDOW_S = 2.5  # longer than a slow walking stride (2.4 s at 50 strides/min)
DISPLACEMENT_SPACING_S = 0.1
START_WALK_M = 2.0  # walked distance whose displacement gives the direction of the first steps (about 2 strides)


def stance_onsets(t_s: np.ndarray, stance: np.ndarray) -> np.ndarray:
    """Times of the starts of the stance phases after the first (the first phase is the initial rest), s."""
    starts, _ = runs(np.asarray(stance, dtype=bool))
    starts = starts[starts > 0]
    return np.asarray(t_s)[starts]


def gait_clock_offset(t_left: np.ndarray, stance_left: np.ndarray, t_right: np.ndarray,
                      stance_right: np.ndarray) -> dict:
    """Gait-symmetry estimate of the right clock's offset (module docstring).

    Parameters
    ----------
    t_left, stance_left, t_right, stance_right
        Each foot's sample times (s) and stance mask.

    Returns
    -------
    dict
        ``offset_s`` (add to the right foot's ``t_s``; NaN without alternating strides), ``residual_s``
        (1.4826 MAD of the per-stride estimates), ``n_strides`` used, ``method``.
    """
    on_l = stance_onsets(t_left, stance_left)
    on_r = stance_onsets(t_right, stance_right)
    out = {"method": "gait symmetry: right stance onset half-way between two left onsets", "offset_s": math.nan,
           "residual_s": math.nan, "n_strides": 0}
    if on_l.size < 3 or on_r.size < 1:
        return out
    period = np.diff(on_l)
    typical = float(np.median(period))
    i = np.searchsorted(on_l, on_r, side="right") - 1
    ok = (i >= 0) & (i < on_l.size - 1)
    i, r = i[ok], on_r[ok]
    span = on_l[i + 1] - on_l[i]
    keep = span <= 1.5 * typical
    if not keep.any():
        return out
    span, delta = span[keep], (r[keep] - on_l[i[keep]]) - 0.5 * span[keep]
    med = float(np.median(delta))
    out.update(offset_s=-med, residual_s=float(MAD_TO_SIGMA * np.median(np.abs(delta - med))),
               n_strides=int(delta.size))
    return out


def heading_offset_rad(t_left: np.ndarray, pos_left: np.ndarray, t_right: np.ndarray, pos_right: np.ndarray,
                       distance_m: float) -> dict:
    """Yaw that turns the right foot's frame onto the left's (module docstring).

    The two feet's horizontal displacements over ``DISPLACEMENT_WINDOW_S`` (longer than a stride, so each
    foot's own stride rhythm and the stagger between the feet average out), taken every
    ``DISPLACEMENT_SPACING_S`` until the left foot has walked ``distance_m``, are matched by the
    least-squares rotation in the plane (2-D Procrustes without translation, [Umeyama1991]):
    ψ = atan2(Σ d_R × d_L, Σ d_R · d_L). Displacements weigh walking and ignore standing; the feet's positions
    themselves would not do, because the offset between the feet turns with the walker.

    Parameters
    ----------
    t_left, pos_left, t_right, pos_right
        Each foot's single-foot solution: times (s) and positions (N, 3), m, each starting at its origin.
    distance_m
        Walked distance of the left foot over which the paths are compared, m.

    Returns
    -------
    dict
        ``yaw_rad`` (rotate the right frame by it, counter-clockwise about z; 0 when the left path spreads
        less than 1 m RMS: nothing to align on), ``walk_yaw_rad`` (direction of the left foot's first
        ``START_WALK_M`` walked, ENU), ``t_s`` of the end of the comparison, ``extent_m`` (RMS spread of the
        left path compared), ``n_points``.
    """
    step = np.linalg.norm(np.diff(pos_left[:, :2], axis=0), axis=1)
    walked = np.concatenate([[0.0], np.cumsum(step)])
    k = int(min(np.searchsorted(walked, distance_m), len(walked) - 1))
    k0 = int(min(np.searchsorted(walked, START_WALK_M), len(walked) - 1))
    d0 = pos_left[k0, :2] - pos_left[0, :2]
    out = {"yaw_rad": 0.0, "walk_yaw_rad": float(math.atan2(d0[1], d0[0])), "t_s": float(t_left[k]),
           "extent_m": 0.0, "n_points": 0}
    t = np.arange(t_left[0], t_left[k] - DISPLACEMENT_WINDOW_S, DISPLACEMENT_SPACING_S)
    if t.size < 3:
        return out
    pl = np.column_stack([np.interp(t, t_left, pos_left[:, j]) for j in range(2)])
    out["extent_m"] = float(np.sqrt(np.mean(np.sum((pl - pl.mean(axis=0)) ** 2, axis=1))))
    if out["extent_m"] < 1.0:  # the feet hardly moved: nothing to align on
        return out
    t2 = t + DISPLACEMENT_WINDOW_S
    a0 = np.column_stack([np.interp(t2, t_left, pos_left[:, j]) for j in range(2)]) - pl
    b0 = np.column_stack([np.interp(t2, t_right, pos_right[:, j]) - np.interp(t, t_right, pos_right[:, j])
                          for j in range(2)])
    # rotation R(ψ) minimising Σ‖a0 − R b0‖²: ψ = atan2(Σ b0 × a0, Σ b0 · a0)
    cross = float(np.sum(b0[:, 0] * a0[:, 1] - b0[:, 1] * a0[:, 0]))
    dot = float(np.sum(b0 * a0))
    out.update(yaw_rad=float(math.atan2(cross, dot)), n_points=int(t.size))
    return out


def rotate_yaw_quat(q_nb: np.ndarray, yaw_rad: float) -> np.ndarray:
    """q_z(yaw) ⊗ q_nb: the same body attitude in a navigation frame turned by ``yaw_rad`` about z (wxyz)."""
    from bootnav.core.rotations import quat_multiply

    qz = np.array([math.cos(yaw_rad / 2.0), 0.0, 0.0, math.sin(yaw_rad / 2.0)])
    return np.asarray(quat_multiply(qz, np.asarray(q_nb, float)), dtype=float)
