"""Revisits: correct the smoothed path where the walker comes back to a place already visited (FootSLAM spirit
[Robertson2009]; a pose graph over strides [Grisetti2010]).

Graph (horizontal only; height is the floors' business): one node per stride end (footprint, ``strides.
footprints`` + ``stride_footprints``), unknown horizontal position X_k.

* odometry edges: X_{k+1} − X_k = d_k, the smoothed path's step, with variance the growth of the filter's
  horizontal position variance between the two footprints (``NavSolution.pos_sigma_n``), floored at
  (``revisit_step_sigma_m``)² per stride (the filter's covariance misses unmodelled sensor errors);
* revisit edges: X_i − X_j = 0 with std ``revisit_sigma_m`` (where a foot lands at a door or on a stair);
* X_0 = its path value (the start is the origin).

Each axis is a linear least-squares problem with a tridiagonal-plus-sparse normal matrix (scipy.sparse); the
correction of each footprint is spread over the samples by linear interpolation in time (so the per-sample
path stays continuous).

Truth-free revisit detection (``revisits``):

* ``entry``: the walk ends where it started (a search leaves through the entry): the last footprint is tied
  to the first when their distance is below ``revisit_entry_gate`` × the distance walked (1 %: the drift of a
  foot INS; a larger gap comes from scale or heading errors, which a position graph can only absorb by bending
  the path) — never on a walk that ends far away;
* ``stairs``: two stair flights (runs of at least 3 strides each climbing or descending ≥ ``level_max_dz_m``,
  half the lowest riser: the height hold's level-stride rule read the other way) with parallel directions
  (lower to upper end within 30°) whose lower ends and upper ends are both within ``revisit_stair_gate_m``
  horizontally are the same flight or one stacked above it: both ends are tied.

Off by default (``revisits = "none"``): ``docs/building.md`` gives what it does on the building scenario.
"""

from __future__ import annotations

import math

import numpy as np

STAIR_MIN_STRIDES = 3
STAIR_PARALLEL_RAD = math.radians(30.0)


def flights(fp: np.ndarray, riser_m: float) -> list[tuple[int, int]]:
    """(first, last) footprint indices of every stair flight: ≥ STAIR_MIN_STRIDES consecutive strides each
    climbing (or each descending) at least ``riser_m``."""
    dz = np.diff(fp[:, 2])
    sign = np.where(dz >= riser_m, 1, np.where(dz <= -riser_m, -1, 0))
    out, k = [], 0
    while k < len(sign):
        if sign[k] == 0:
            k += 1
            continue
        j = k
        while j + 1 < len(sign) and sign[j + 1] == sign[k]:
            j += 1
        if j - k + 1 >= STAIR_MIN_STRIDES:
            out.append((k, j + 1))
        k = j + 1
    return out


def detect_revisits(fp: np.ndarray, settings) -> list[tuple[int, int, str]]:
    """Revisit edges (i, j, kind) between footprints (K, 3) of the smoothed path (module docstring)."""
    mode = settings.revisits
    edges: list[tuple[int, int, str]] = []
    if len(fp) < 3:
        return edges
    if "entry" in mode:
        walked = float(np.linalg.norm(np.diff(fp[:, :2], axis=0), axis=1).sum())
        if np.linalg.norm(fp[-1, :2] - fp[0, :2]) < settings.revisit_entry_gate * walked:
            edges.append((0, len(fp) - 1, "entry"))
    if "stairs" in mode:
        fl = flights(fp, settings.level_max_dz_m)
        ends = []
        for a, b in fl:
            lo, hi = (a, b) if fp[b, 2] > fp[a, 2] else (b, a)
            d = fp[hi, :2] - fp[lo, :2]
            ends.append((lo, hi, math.atan2(d[1], d[0])))
        for i in range(len(ends)):
            for j in range(i + 1, len(ends)):
                (lo1, hi1, h1), (lo2, hi2, h2) = ends[i], ends[j]
                if abs(math.remainder(h1 - h2, 2 * math.pi)) > STAIR_PARALLEL_RAD:
                    continue
                g = settings.revisit_stair_gate_m
                if np.linalg.norm(fp[lo1, :2] - fp[lo2, :2]) < g and np.linalg.norm(fp[hi1, :2] - fp[hi2, :2]) < g:
                    edges += [(lo1, lo2, "stairs"), (hi1, hi2, "stairs")]
    return edges


def solve_graph(xy: np.ndarray, step_var: np.ndarray, edges: list[tuple[int, int, str]], sigma_m: float) -> np.ndarray:
    """Least-squares node positions (K, 2): odometry from ``xy`` with per-step variance ``step_var`` (K-1,),
    revisit edges X_i = X_j with std ``sigma_m``, X_0 fixed."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.linalg import spsolve

    K = len(xy)
    w = 1.0 / np.maximum(step_var, 1e-12)
    rows, cols, vals = [], [], []
    b = np.zeros((K, 2))
    d = np.diff(xy, axis=0)
    k = np.arange(K - 1)
    # odometry: w (X_{k+1} - X_k - d_k)^2
    for r, c, v in ((k, k, w), (k + 1, k + 1, w), (k, k + 1, -w), (k + 1, k, -w)):
        rows.append(r), cols.append(c), vals.append(v)
    np.add.at(b, k, -w[:, None] * d)
    np.add.at(b, k + 1, w[:, None] * d)
    wc = 1.0 / sigma_m**2
    for i, j, _ in edges:
        rows.append(np.array([i, j, i, j])), cols.append(np.array([i, j, j, i]))
        vals.append(np.array([wc, wc, -wc, -wc]))
    big = 1e12  # X_0 fixed at its value
    rows.append(np.array([0])), cols.append(np.array([0])), vals.append(np.array([big]))
    b[0] += big * xy[0]
    A = coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(K, K)).tocsc()
    return np.column_stack([spsolve(A, b[:, 0]), spsolve(A, b[:, 1])])


def apply_revisits(nav, t_s: np.ndarray, stance: np.ndarray, settings):
    """Correct ``nav.pos_n`` (a ``NavSolution``) by the pose graph when revisits are found; the report goes
    into ``nav.info["revisits"]``. Returns ``nav`` (its position array replaced, never modified in place)."""
    from bootnav.postproc.strides import footprints

    t_fp, fp = footprints(t_s, np.asarray(nav.pos_n), np.asarray(stance, bool))
    sig = np.asarray(nav.pos_sigma_n) if getattr(nav, "pos_sigma_n", None) is not None else None
    var_h = np.interp(t_fp, t_s, sig[:, 0] ** 2 + sig[:, 1] ** 2) if sig is not None else None
    t_fp, delta, report = revisit_corrections(t_fp, fp, var_h, settings)
    if delta is not None:
        pos = np.array(nav.pos_n, dtype=float, copy=True)
        for ax in range(2):
            pos[:, ax] += np.interp(t_s, t_fp, delta[:, ax])
        nav.pos_n = pos
    nav.info["revisits"] = report
    return nav


def revisit_corrections(t_fp: np.ndarray, fp: np.ndarray, var_h: np.ndarray | None, settings):
    """The pose graph's horizontal corrections at the strides' footprints: ``(t_fp, delta, report)`` of the
    footprints kept (moves of at least ``hde_min_stride_m``), ``delta`` (K, 2) m or None without a revisit.
    ``var_h``: the horizontal position variance sum (m²) at each footprint's time (None: unknown). The one
    definition of the correction: the whole path (``apply_revisits``) and the block passes (``pipeline``)
    interpolate ``delta`` in time between the footprints."""
    from bootnav.postproc.strides import stride_footprints

    keep = stride_footprints(fp, settings.hde_min_stride_m) if len(fp) else np.zeros(0, int)
    t_fp, fp = t_fp[keep], fp[keep]
    edges = detect_revisits(fp, settings)
    report = {"mode": settings.revisits, "edges": [{"from_stride": int(i), "to_stride": int(j), "kind": k}
                                                   for i, j, k in edges], "max_correction_m": 0.0}
    if not edges:
        return t_fp, None, report
    if var_h is not None:
        step_var = np.maximum(np.diff(np.asarray(var_h)[keep]), 0.0)
    else:
        step_var = np.zeros(len(fp) - 1)
    step_var = np.maximum(step_var, settings.revisit_step_sigma_m**2)
    xy = solve_graph(fp[:, :2], step_var, edges, settings.revisit_sigma_m)
    delta = xy - fp[:, :2]
    report["max_correction_m"] = float(np.linalg.norm(delta, axis=1).max())
    return t_fp, delta, report
