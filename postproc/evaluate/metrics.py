"""The one scorer of the developer datasets' METRICS.md [DatasetMetrics]: every accuracy figure of
``bootnav eval``, the PDR evaluation (``bootnav.postproc.evaluate.pdr``) and the benchmarks comes from here.

Every position metric first removes the unknown start position and start heading — never scale, never
anything fitted to the whole path:

1. translate estimate and truth so both start at the origin (first sample, or stride 0);
2. find the first estimate sample whose horizontal distance from the start is >= 0.8 m and rotate the
   estimate about the vertical axis so that its horizontal position there points the same way as the truth
   at the same time (truth interpolated linearly in time) — pyshoe's evaluation convention [Wagstaff2017];
3. z is never rotated or scaled.

All functions take plain arrays (SI, nav frame z up) so they serve the foot-mounted filter and PDR alike.

Empty cases
-----------
METRICS.md defines every rate as a ratio; where its denominator is zero the ratio is undefined and the
metric is NaN (``null`` in metrics.json, "—" in report.md, left out of a dataset's mean and median, and
counted per dataset in ``n_undefined``). Never 0, which would read as a measured value:

===================  =============================  ==========================================
metric               definition                     undefined (NaN) when
===================  =============================  ==========================================
precision            matched / detected             nothing detected
recall               matched / true                 no true event
f1                   2 matched / (detected + true)  both empty (0 when only one side is empty:
                     (= 2 P R / (P + R))            every detection false, or every event missed)
count_err_pct        100 (detected − true) / true   no true step, even with none detected
step_len_mae_m/bias  over matched steps             no detected step within ±0.25 s of a contact
stance_precision     per sample, as precision       no stance sample estimated
stance_recall        per sample, as recall          no stance sample in the truth
closure_pct          100 closure_3d / distance      no horizontal distance walked
final_fp_err_pct     100 final error / length       truth polyline of zero length
distance_err_pct     100 (est − true) / true        true distance zero
===================  =============================  ==========================================

[Lazarevskiy2021] Table 3.1 prints a count error of 0 % for a still recording (0 true, 0 detected); here
that case is undefined: a percentage of zero steps measures nothing.

[DatasetMetrics] METRICS.md of the bootnav developer dataset collection (alignment, metric per truth kind).
"""

from __future__ import annotations

import numpy as np

from bootnav.core.runs import runs

ALIGN_DISTANCE_M = 0.8
EVENT_TOLERANCE_S = 0.25


def _ratio(num: float, den: float) -> float:
    """num / den, NaN when the denominator is zero (module docstring, "Empty cases")."""
    return num / den if den else float("nan")


# ----------------------------------------------------------------------------------------- alignment
def _interp_rows(t_query: np.ndarray, t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Linear interpolation of each column of ``values`` (clamped at the ends)."""
    values = np.asarray(values, dtype=float)
    return np.column_stack([np.interp(t_query, t, values[:, k]) for k in range(values.shape[1])])


def align_to_truth(t_est, pos_est, t_truth, pos_truth, t_origin: float | None = None):
    """Return the estimate translated and rotated about z per METRICS.md, and the rotation angle (rad).

    ``t_origin``: time of the common origin (default: the estimate's first sample; footprints use the time
    of stride 0). The truth is translated so that it is at the origin at ``t_origin``.
    """
    t_est = np.asarray(t_est, float)
    pos_est = np.asarray(pos_est, float)
    t_truth = np.asarray(t_truth, float)
    pos_truth = np.asarray(pos_truth, float)
    if t_origin is None:
        t_origin = t_est[0]
    est0 = _interp_rows(np.array([t_origin]), t_est, pos_est)[0]
    truth0 = _interp_rows(np.array([t_origin]), t_truth, pos_truth)[0]
    est = pos_est - est0
    truth_shift = truth0
    after = t_est >= t_origin
    horiz = np.hypot(est[:, 0], est[:, 1])
    far = np.flatnonzero(after & (horiz >= ALIGN_DISTANCE_M))
    if far.size == 0:
        return est, 0.0, truth_shift
    k = far[0]
    truth_k = _interp_rows(np.array([t_est[k]]), t_truth, pos_truth)[0] - truth0
    angle = np.arctan2(truth_k[1], truth_k[0]) - np.arctan2(est[k, 1], est[k, 0])
    c, s = np.cos(angle), np.sin(angle)
    rotated = est.copy()
    rotated[:, 0] = c * est[:, 0] - s * est[:, 1]
    rotated[:, 1] = s * est[:, 0] + c * est[:, 1]
    return rotated, float(angle), truth_shift


# ----------------------------------------------------------------------------------- stance phases
def stance_positions(pos, stance) -> np.ndarray:
    """Mean position of each stance phase (run of True in ``stance``: the foot is still there)."""
    starts, stops = runs(stance)
    pos = np.asarray(pos, float)
    if starts.size == 0:
        return np.zeros((0, pos.shape[1]))
    return np.array([pos[a:b].mean(axis=0) for a, b in zip(starts, stops)])


# --------------------------------------------------------------------------------- per truth kind
def trajectory_metrics(t_est, pos_est, t_truth, pos_truth) -> dict:
    """mean_h_err_m, armse_2d, mean_v_err_m, final_h_err_m (truth samples matched by time)."""
    t_truth = np.asarray(t_truth, float)
    pos_truth = np.asarray(pos_truth, float)
    inside = (t_truth >= t_est[0]) & (t_truth <= t_est[-1])
    t_truth, pos_truth = t_truth[inside], pos_truth[inside]
    aligned, angle, truth0 = align_to_truth(t_est, pos_est, t_truth, pos_truth, t_origin=t_truth[0])
    est_at = _interp_rows(t_truth, t_est, aligned)
    truth = pos_truth - truth0
    d = est_at - truth
    h = np.hypot(d[:, 0], d[:, 1])
    return {
        "mean_h_err_m": float(h.mean()),
        "armse_2d": float(np.mean(np.sqrt((d[:, 0] ** 2 + d[:, 1] ** 2) / 2.0))),
        "mean_v_err_m": float(np.mean(np.abs(d[:, 2]))) if d.shape[1] > 2 else float("nan"),
        "final_h_err_m": float(h[-1]),
        "align_angle_rad": angle,
    }


def closed_loop_metrics(pos_est, stance) -> dict:
    """closure_h_m, closure_v_m, closure_3d_m, distance_m, closure_pct (first vs last stance phase)."""
    p = stance_positions(pos_est, stance)
    if len(p) < 2:
        raise ValueError("closed-loop metrics need at least two stance phases")
    d = p[-1] - p[0]
    distance = float(np.sum(np.hypot(np.diff(p[:, 0]), np.diff(p[:, 1]))))
    c3 = float(np.linalg.norm(d))
    return {
        "closure_h_m": float(np.hypot(d[0], d[1])),
        "closure_v_m": float(abs(d[2])),
        "closure_3d_m": c3,
        "distance_m": distance,
        "closure_pct": _ratio(100.0 * c3, distance),
    }


def footprint_metrics(t_est, pos_est, fp_t, fp_xy, n_detected_strides: int | None = None) -> dict:
    """mean_fp_err_m, final_fp_err_m, final_fp_err_pct, stride_count_err (footprints with times)."""
    fp_t = np.asarray(fp_t, float)
    fp_xy = np.asarray(fp_xy, float)[:, :2]
    truth3 = np.column_stack([fp_xy, np.zeros(len(fp_xy))])
    est3 = np.asarray(pos_est, float)
    aligned, angle, truth0 = align_to_truth(t_est, est3, fp_t, truth3, t_origin=fp_t[0])
    est_at = _interp_rows(fp_t, t_est, aligned)[:, :2]
    err = np.hypot(*(est_at - (fp_xy - truth0[:2])).T)
    length = float(np.sum(np.hypot(*np.diff(fp_xy, axis=0).T)))
    out = {
        "mean_fp_err_m": float(err.mean()),
        "final_fp_err_m": float(err[-1]),
        "final_fp_err_pct": _ratio(100.0 * float(err[-1]), length),
        "truth_length_m": length,
        "align_angle_rad": angle,
    }
    if n_detected_strides is not None:
        out["stride_count_err"] = int(n_detected_strides)
    return out


def stride_length_metrics(t_est, pos_est, t_start, t_end, length_truth) -> dict:
    """stride_mae_m, stride_bias_m: estimated stride = horizontal distance between positions at start/end."""
    a = _interp_rows(np.asarray(t_start, float), t_est, pos_est)
    b = _interp_rows(np.asarray(t_end, float), t_est, pos_est)
    est = np.hypot(b[:, 0] - a[:, 0], b[:, 1] - a[:, 1])
    e = est - np.asarray(length_truth, float)
    return {"stride_mae_m": float(np.mean(np.abs(e))), "stride_bias_m": float(np.mean(e)), "n_strides": int(len(e))}


def _walked_m(t_est, pos_est, stance_t, stance_xy, t_start, t_end) -> float:
    """Horizontal length of the polyline through the position at ``t_start``, every stance-phase (footfall)
    position whose time lies strictly inside the window, and the position at ``t_end``."""
    ends = _interp_rows(np.array([t_start, t_end]), np.asarray(t_est, float), np.asarray(pos_est, float)[:, :2])
    stance_t = np.asarray(stance_t, float)
    inside = (stance_t > t_start) & (stance_t < t_end)
    p = np.vstack([ends[:1], np.asarray(stance_xy, float)[inside, :2], ends[1:]])
    return float(np.sum(np.hypot(*np.diff(p, axis=0).T)))


def out_and_back_metrics(t_est, pos_est, stance_t, stance_xy, t_start, t_end, distance_truth,
                         uturn: tuple[float, float] | None = None) -> dict:
    """distance_err_pct of the estimated horizontal distance walked between two times (foot-mounted).

    The walked distance is the length of the polyline through the position at ``t_start``, every footfall
    inside the window and the position at ``t_end`` (``_walked_m``) — so a footfall at either end of the window
    is neither lost nor counted twice. With the U-turn's times (``uturn``), also ``distance_straight_err_pct``
    (a bootnav diagnostic, not in METRICS.md): the two straight legs only, i.e. the walk without the U-turn, against
    the same course length. The truth is the course (2 × 10 m); a foot's real path also holds the turn's arc, so
    the METRICS.md figure counts the turn as error and the straight-leg figure measures the filter's scale.
    """
    args = (t_est, pos_est, stance_t, stance_xy)
    est = _walked_m(*args, t_start, t_end)
    out = {"distance_est_m": est, "distance_err_pct": _ratio(100.0 * (est - distance_truth), distance_truth)}
    if uturn is not None and t_start < uturn[0] <= uturn[1] < t_end:
        straight = _walked_m(*args, t_start, uturn[0]) + _walked_m(*args, uturn[1], t_end)
        out["distance_straight_est_m"] = straight
        out["distance_straight_err_pct"] = _ratio(100.0 * (straight - distance_truth), distance_truth)
    return out


def step_distance_metrics(step_t, step_len, t_start, t_end, distance_truth,
                          tolerance: float = EVENT_TOLERANCE_S) -> dict:
    """distance_err_pct for step-and-heading (PDR): the sum of the lengths of the steps detected between
    the two times (± the event tolerance, as a step's contact may be stamped slightly outside)."""
    step_t = np.asarray(step_t, float)
    inside = (step_t >= t_start - tolerance) & (step_t <= t_end + tolerance)
    est = float(np.sum(np.asarray(step_len, float)[inside]))
    return {"distance_est_m": est, "distance_err_pct": _ratio(100.0 * (est - distance_truth), distance_truth)}


def match_events(detected, truth, tolerance: float = EVENT_TOLERANCE_S) -> list[tuple[int, int]]:
    """One-to-one matching of detected to true events within ±tolerance, nearest pairs first.

    Parameters
    ----------
    detected, truth : array_like, shape (D,), (T,)
        Event times, s (any order).
    tolerance : float
        Largest |detected − true| of a match, s (METRICS.md: 0.25 s).

    Returns
    -------
    list of (int, int)
        (index into ``detected`` sorted by time, index into ``truth`` as given) pairs. Equal distances go to
        the earlier detection.
    """
    detected = np.sort(np.asarray(detected, float))
    truth = np.asarray(truth, float)
    order_truth = np.argsort(truth)
    truth_sorted = truth[order_truth]
    # Candidate pairs: each detected event vs the truth events within tolerance (sorted search).
    lo = np.searchsorted(truth_sorted, detected - tolerance, side="left")
    hi = np.searchsorted(truth_sorted, detected + tolerance, side="right")
    counts = hi - lo
    det_idx = np.repeat(np.arange(len(detected)), counts)
    tru_idx = np.concatenate([np.arange(a, b) for a, b in zip(lo, hi)]) if len(detected) else np.zeros(0, int)
    dist = np.abs(detected[det_idx] - truth_sorted[tru_idx])
    pairs = []
    used_d = np.zeros(len(detected), bool)
    used_t = np.zeros(len(truth), bool)
    for k in np.argsort(dist, kind="stable"):  # greedy over candidate pairs (a few per event), not samples
        i, j = det_idx[k], tru_idx[k]
        if not used_d[i] and not used_t[j]:
            used_d[i] = used_t[j] = True
            pairs.append((int(i), int(order_truth[j])))
    return pairs


def count_err_pct(n_detected: int, n_true: int) -> float:
    """Step-count error, % = 100 (detected − true) / true; NaN when there is no true step."""
    return _ratio(100.0 * (n_detected - n_true), n_true)


def step_event_metrics(detected, truth, tolerance: float = EVENT_TOLERANCE_S) -> dict:
    """METRICS.md ``step_events``: precision, recall, f1 and count_err_pct of detected event times.

    Parameters
    ----------
    detected, truth : array_like
        Detected and true event times, s (heel strikes, foot-switch edges, initial contacts).
    tolerance : float
        Matching tolerance, s (``match_events``).

    Returns
    -------
    dict
        ``precision``, ``recall``, ``f1``, ``count_err_pct`` (NaN where undefined, module docstring),
        ``n_detected``, ``n_true``.
    """
    n_det, n_true = len(detected), len(truth)
    tp = len(match_events(detected, truth, tolerance))
    precision = _ratio(tp, n_det)
    recall = _ratio(tp, n_true)
    # 2PR/(P+R) = 2 tp/(n_det + n_true); with no match it is 0, or undefined when both sides are empty
    f1 = 2 * precision * recall / (precision + recall) if tp else _ratio(0.0, n_det + n_true)
    return {
        "precision": precision,
        "recall": recall,
        "f1": f1,
        "count_err_pct": count_err_pct(n_det, n_true),
        "n_detected": n_det,
        "n_true": n_true,
    }


def step_count_metrics(n_detected: int, n_true: int) -> dict:
    """METRICS.md ``step_count``: count_err_pct (NaN without true steps), n_detected, n_true."""
    return {"count_err_pct": count_err_pct(n_detected, n_true), "n_detected": n_detected, "n_true": n_true}


def step_length_metrics(step_t, step_len, ref_t, ref_len, tolerance: float = EVENT_TOLERANCE_S) -> dict:
    """METRICS.md ``step_lengths``: the detected step nearest each reference contact within ±tolerance.

    Parameters
    ----------
    step_t, step_len : array_like, shape (N,)
        Detected step times, s, and their estimated lengths, m.
    ref_t, ref_len : array_like, shape (M,)
        Reference initial contacts, s, and the reference step lengths, m.
    tolerance : float
        Largest |detected − reference| time of a match, s. Equidistant steps: the earlier one.

    Returns
    -------
    dict
        ``step_len_mae_m``, ``step_len_bias_m`` (estimate − reference) over the matches (NaN without a
        match), ``n_matched``.
    """
    step_t = np.asarray(step_t, float)
    step_len = np.asarray(step_len, float)
    ref_t = np.asarray(ref_t, float)
    ref_len = np.asarray(ref_len, float)
    if step_t.size == 0 or ref_t.size == 0:
        return {"step_len_mae_m": float("nan"), "step_len_bias_m": float("nan"), "n_matched": 0}
    order = np.argsort(step_t, kind="stable")
    step_t, step_len = step_t[order], step_len[order]
    right = np.clip(np.searchsorted(step_t, ref_t), 0, step_t.size - 1)
    left = np.maximum(right - 1, 0)
    nearest = np.where(np.abs(step_t[left] - ref_t) <= np.abs(step_t[right] - ref_t), left, right)
    ok = np.abs(step_t[nearest] - ref_t) <= tolerance
    e = step_len[nearest[ok]] - ref_len[ok]
    if e.size == 0:
        return {"step_len_mae_m": float("nan"), "step_len_bias_m": float("nan"), "n_matched": 0}
    return {"step_len_mae_m": float(np.abs(e).mean()), "step_len_bias_m": float(e.mean()), "n_matched": int(e.size)}


def stance_metrics(t_est, stance_est, t_truth, stance_truth) -> dict:
    """Per-sample precision and recall of stance (estimate sampled at the truth times, nearest)."""
    t_est = np.asarray(t_est, float)
    idx = np.clip(np.searchsorted(t_est, np.asarray(t_truth, float)), 0, len(t_est) - 1)
    est = np.asarray(stance_est, bool)[idx]
    truth = np.asarray(stance_truth, bool)
    tp = np.sum(est & truth)
    return {
        "stance_precision": float(_ratio(tp, est.sum())),
        "stance_recall": float(_ratio(tp, truth.sum())),
    }
