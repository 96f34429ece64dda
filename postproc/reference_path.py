"""Reference paths and the paper's Table 1 metrics (distance, deviation and height error). (The filter's
reference *engine*, the filterpy loop, is another idea: ``ins.filterpy_engine``.)

The paper [Heidari2019, §4.2, Table 1] reports "deviation", "distance" and "height" errors in % for a 9 m
straight walk and an 11 m stair path but never defines them. bootnav fixes these
definitions (also in ``docs/metrics.md``); every metric is given in metres *and* in %, because the
paper's conclusion mixes the two.

Reference file (``--reference FILE``)
-------------------------------------
* CSV with a header: ``t_s,x_m,y_m[,z_m]`` (a timed reference trajectory, or surveyed footprints with
  their times) or ``x_m,y_m[,z_m]`` (waypoints of the walked polyline, in walking order), in any column
  order; an index column ``stride`` is ignored (the datasets' ``truth_footprints.csv``). ``.csv.gz`` accepted.
* CSV ``[foot,]t_start_s,t_end_s,stride_length_m``: reference stride lengths (e.g. motion capture; the
  datasets' ``truth_strides.csv``) -> ``stride_mae_m``, ``stride_bias_m`` and the summed distance error.
* ``truth``: the exact trajectory in a simulated recording's ``/truth`` group (``truth_reference``).
* JSON: ``{"closed_loop": true}`` (the walk ends where it started; ``approx_length_m`` optional, as in the
  datasets' ``truth.json``), ``{"straight_m": 9}`` (a straight line of 9 m; optional ``"height_m"`` for
  the end height), or ``{"waypoints": [[x, y], [x, y, z], ...]}``.

Alignment (as the datasets' METRICS.md; never scale, never a fit to the whole path)
-----------------------------------------------------------------------------------
1. Estimate and reference are translated to start at the origin (estimate: first sample; reference: first
   point, or its position at the estimate's first time for a timed reference).
2. At the first estimate sample at least 0.8 m (horizontally) from the start, the estimate is rotated
   about z so that its horizontal position points the same way as the reference's: for a timed
   reference its position at that time (linear interpolation), for a polyline the point at the same
   arc length as the sample's distance from the start.
3. z is never rotated or scaled.

Definitions (symbols: footprints p_k = mean estimate position in stance phase k, k = 0..K-1, aligned;
reference polyline R with horizontal length L_ref)
--------------------------------------------------------------------------------------------------
* ``L_est`` = Σ_k ‖(p_k − p_{k−1})_xy‖, the horizontal distance walked (stride by stride).
* **distance error** = |L_est − L_ref|  [m];  % = 100 · |L_est − L_ref| / L_ref.
  (Signed value ``distance_diff_m`` = L_est − L_ref also reported.)
* **deviation error** = max_k d_xy(p_k, R), the largest horizontal distance of a footprint from the
  reference polyline  [m]; % = 100 · max / L_ref. (Mean and the final footprint's distance also given.)
* **height error** = |Δz_est − Δz_ref| with Δz = end height − start height (estimate: last − first
  footprint; reference: last − first point, 0 for a 2-D reference)  [m]; % = 100 · error / L_ref, and
  also 100 · error / |Δz_ref| (``height_error_pct_of_climb``) when the reference climbs > 0.1 m.
* **closure** (every run; the metric for ``closed_loop``): c = p_{K−1} − p_0; ``closure_h_m``,
  ``closure_v_m``, ``closure_3d_m``; ``closure_pct`` = 100 · ‖c‖ / L_est.
* **end-point error** (polyline/timed reference): ``final_error_m`` = ‖(p_{K−1} − R_end)_xy‖.
* Timed reference only (METRICS.md "trajectory"): ``mean_h_err_m``, ``armse_2d`` (pyshoe's 2-D ARMSE),
  ``mean_v_err_m``, ``final_h_err_m``, the estimate interpolated at the reference times.
"""

from __future__ import annotations

import gzip
import io
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bootnav.errors import InputError

from .strides import footprints, stride_footprints

ALIGN_DISTANCE_M = 0.8


@dataclass
class Reference:
    """A reference path in its own right-handed, z-up frame (metres)."""

    kind: str  # "closed_loop" | "straight" | "waypoints" | "trajectory" | "strides"
    points_n: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # (M, 3)
    strides: dict | None = None  # "strides": t_start_s, t_end_s, stride_length_m arrays
    t_s: np.ndarray | None = None  # (M,) for "trajectory"
    has_z: bool = False
    approx_length_m: float | None = None
    source: str = ""

    @property
    def length_m(self) -> float | None:
        """Horizontal polyline length L_ref (None for a closed loop without geometry)."""
        if self.strides is not None:
            return float(np.sum(self.strides["stride_length_m"]))
        if len(self.points_n) < 2:
            return self.approx_length_m
        d = np.diff(self.points_n[:, :2], axis=0)
        return float(np.hypot(d[:, 0], d[:, 1]).sum())


def _read_text(path: Path) -> str:
    raw = path.read_bytes()
    if raw[:2] == b"\x1f\x8b":
        raw = gzip.decompress(raw)
    return raw.decode("utf-8-sig")


def load_reference(path: str | Path) -> Reference:
    """Read a reference file (format in the module docstring); InputError says what is wrong and where.

    An inline JSON object (a string starting with ``{``, e.g. ``'{"closed_loop": true}'``) is accepted too.
    """
    if isinstance(path, str) and path.lstrip().startswith("{"):
        return _from_json(Path("<inline reference>"), path)
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: reference file not found")
    text = _read_text(path)
    if text.lstrip().startswith("{"):
        return _from_json(path, text)
    return _from_csv(path, text)


def _from_json(path: Path, text: str) -> Reference:
    try:
        spec = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}") from exc
    if spec.get("closed_loop"):
        approx = spec.get("approx_length_m")
        return Reference("closed_loop", approx_length_m=float(approx) if approx else None, source=str(path))
    if "straight_m" in spec:
        length = spec["straight_m"]
        if isinstance(length, bool) or not isinstance(length, (int, float)) or not length > 0:
            raise InputError(f"{path}: straight_m must be a positive number of metres, got {json.dumps(length)}")
        height = spec.get("height_m", 0.0)
        if isinstance(height, bool) or not isinstance(height, (int, float)):
            raise InputError(f"{path}: height_m must be a number of metres, got {json.dumps(height)}")
        pts = np.array([[0.0, 0.0, 0.0], [float(length), 0.0, float(height)]])
        return Reference("straight", pts, has_z=True, source=str(path))
    if "waypoints" in spec:
        return _waypoints(path, spec["waypoints"])
    raise InputError(
        f"{path}: JSON reference needs one of 'closed_loop': true, 'straight_m': <m>, 'waypoints': [[x, y(, z)], ...]"
        f"; got keys {sorted(spec)}"
    )


def _waypoints(path: Path, rows) -> Reference:
    try:
        rows = [list(map(float, r)) for r in rows]
    except (TypeError, ValueError) as exc:
        raise InputError(f"{path}: waypoints must be lists of 2 or 3 numbers ({exc})") from exc
    widths = {len(r) for r in rows}
    if len(rows) < 2 or not widths <= {2, 3} or len(widths) != 1:
        raise InputError(f"{path}: need >= 2 waypoints, all [x, y] or all [x, y, z]; got {len(rows)} rows of widths {sorted(widths)}")
    pts = np.array(rows)
    has_z = pts.shape[1] == 3
    if not has_z:
        pts = np.column_stack((pts, np.zeros(len(pts))))
    return Reference("waypoints", pts, has_z=has_z, source=str(path))


def _from_csv(path: Path, text: str) -> Reference:
    lines = text.splitlines()
    if not lines:
        raise InputError(f"{path}: empty reference file")
    header = [h.strip() for h in lines[0].split(",")]
    if {"t_start_s", "t_end_s", "stride_length_m"} <= set(header):
        return _strides_csv(path, text, header)
    allowed = ({"t_s", "x_m", "y_m"}, {"x_m", "y_m"})
    # "stride" (an index column, as in the datasets' truth_footprints.csv) is accepted and ignored
    if not any(a <= set(header) for a in allowed) or not set(header) <= {"t_s", "x_m", "y_m", "z_m", "stride"}:
        raise InputError(f"{path}: line 1: header must be t_s,x_m,y_m[,z_m] or x_m,y_m[,z_m] (optional stride "
                         f"column); got {lines[0]!r}")
    try:
        data = np.loadtxt(io.StringIO(text), delimiter=",", skiprows=1, ndmin=2)
    except ValueError as exc:
        raise InputError(f"{path}: unreadable number ({exc})") from exc
    if data.shape[0] < 2:
        raise InputError(f"{path}: need at least 2 rows, got {data.shape[0]}")
    bad = np.argwhere(~np.isfinite(data))
    if len(bad):
        raise InputError(f"{path}: line {bad[0, 0] + 2}: non-finite value in column {header[bad[0, 1]]}")
    col = {name: data[:, i] for i, name in enumerate(header)}
    z = col.get("z_m", np.zeros(len(data)))
    pts = np.column_stack((col["x_m"], col["y_m"], z))
    if "t_s" in col:
        t = col["t_s"]
        back = np.flatnonzero(np.diff(t) <= 0)
        if len(back):
            raise InputError(f"{path}: line {back[0] + 3}: t_s not increasing ({t[back[0]]} then {t[back[0] + 1]})")
        return Reference("trajectory", pts, t_s=t, has_z="z_m" in col, source=str(path))
    return Reference("waypoints", pts, has_z="z_m" in col, source=str(path))


def _strides_csv(path: Path, text: str, header: list[str]) -> Reference:
    """Reference stride lengths with their start/end times (the datasets' truth_strides.csv)."""
    cols = [header.index(c) for c in ("t_start_s", "t_end_s", "stride_length_m")]
    try:
        data = np.loadtxt(io.StringIO(text), delimiter=",", skiprows=1, ndmin=2, usecols=cols)
    except ValueError as exc:
        raise InputError(f"{path}: unreadable number ({exc})") from exc
    if len(data) == 0 or not np.all(np.isfinite(data)):
        raise InputError(f"{path}: need finite rows of t_start_s,t_end_s,stride_length_m")
    bad = np.flatnonzero(data[:, 1] <= data[:, 0])
    if len(bad):
        raise InputError(f"{path}: line {bad[0] + 2}: t_end_s must be after t_start_s")
    strides = {"t_start_s": data[:, 0], "t_end_s": data[:, 1], "stride_length_m": data[:, 2]}
    if "foot" in header:
        k = header.index("foot")
        strides["foot"] = np.array([ln.split(",")[k].strip() for ln in text.splitlines()[1:] if ln.strip()])
    return Reference("strides", strides=strides, source=str(path))


def stride_metrics(ref: Reference, t_s: np.ndarray, pos_n: np.ndarray, mount: str | None = None) -> dict:
    """Estimated stride length = horizontal distance between the estimate's positions at each reference
    stride's start and end time (METRICS.md ``stride_lengths``); MAE, bias, and the summed distance.

    A file listing both feet is reduced to one foot (so the summed distance counts each metre once): the
    recording's own foot when its ``mount`` says left/right, else the foot with the most strides."""
    st = dict(ref.strides)
    foot = None
    if "foot" in st:
        feet, counts = np.unique(st["foot"], return_counts=True)
        side = {"left": "L", "right": "R"}
        foot = next((side[k] for k in side if mount and k in str(mount).lower() and side[k] in feet),
                    str(feet[np.argmax(counts)]))
        keep = st["foot"] == foot
        st = {k: v[keep] for k, v in st.items()}
    inside = (st["t_start_s"] >= t_s[0]) & (st["t_end_s"] <= t_s[-1])
    if not inside.any():
        raise InputError(f"{ref.source}: no reference stride lies within the processed time "
                         f"{t_s[0]:.2f}-{t_s[-1]:.2f} s")
    at = lambda tt: np.column_stack([np.interp(tt, t_s, pos_n[:, k]) for k in range(2)])  # noqa: E731
    est = np.linalg.norm(at(st["t_end_s"][inside]) - at(st["t_start_s"][inside]), axis=1)
    true = st["stride_length_m"][inside]
    err = est - true
    return {
        "stride_foot": foot,
        "strides_ref": int(inside.sum()),
        "stride_mae_m": float(np.abs(err).mean()),
        "stride_bias_m": float(err.mean()),
        "stride_mae_pct": float(100 * np.abs(err).mean() / true.mean()),
        "distance_ref_m": float(true.sum()),
        "distance_est_strides_m": float(est.sum()),
        "distance_error_m": float(abs(est.sum() - true.sum())),
        "distance_error_pct": float(100 * abs(est.sum() - true.sum()) / true.sum()),
    }


def truth_reference(rec, path) -> Reference:
    """``--reference truth``: the simulator's exact sensor trajectory stored in the recording's ``/truth``
    (row-aligned with ``/imu``, so matched on the recording's own clock)."""
    from bootnav.logger.recording import load

    truth = load(path).truth if path is not None else getattr(rec, "truth", None)
    if not truth or "pos_n_m" not in truth:
        raise InputError(f"{path or 'recording'}: --reference truth needs a /truth group with pos_n_m "
                         "(recordings written by `bootnav simulate`)")
    pos = np.asarray(truth["pos_n_m"], float)
    if len(pos) != rec.n:
        raise InputError(f"{path}: /truth has {len(pos)} rows, /imu {rec.n}: not row-aligned")
    return Reference("trajectory", pos, t_s=np.asarray(rec.t_s, float), has_z=True, source=f"{path}:/truth")


def point_at_arclength(points: np.ndarray, s: float) -> np.ndarray:
    """Horizontal point of a polyline at horizontal arc length ``s`` (clamped to the ends)."""
    seg = np.hypot(*np.diff(points[:, :2], axis=0).T)
    cum = np.concatenate(([0.0], np.cumsum(seg)))
    return np.array([np.interp(s, cum, points[:, 0]), np.interp(s, cum, points[:, 1])])


def align_to_reference(ref: Reference, t_s: np.ndarray, pos_n: np.ndarray) -> tuple[np.ndarray, np.ndarray, float | None]:
    """Translate + rotate the estimate about z (METRICS.md rule). Returns (pos aligned, ref points, yaw rad).

    Reference points are returned translated to start at the origin. Yaw is None when the estimate
    never leaves a 0.8 m circle around its start (no rotation then) or the reference has no geometry.
    """
    pos = np.asarray(pos_n, float) - np.asarray(pos_n, float)[0]
    pts = ref.points_n.copy()
    if len(pts) == 0:
        return pos, pts, None
    if ref.t_s is not None:
        origin = np.array([np.interp(t_s[0], ref.t_s, pts[:, i]) for i in range(3)])
    else:
        origin = pts[0].copy()
    pts = pts - origin
    r = np.hypot(pos[:, 0], pos[:, 1])
    far = np.flatnonzero(r >= ALIGN_DISTANCE_M)
    if len(far) == 0:
        return pos, pts, None
    i = far[0]
    if ref.t_s is not None:
        target = np.array([np.interp(t_s[i], ref.t_s, pts[:, k]) for k in range(2)])
    else:
        target = point_at_arclength(pts, float(r[i]))
    if np.hypot(*target) < 1e-9:
        return pos, pts, None
    yaw = float(np.arctan2(target[1], target[0]) - np.arctan2(pos[i, 1], pos[i, 0]))
    c, s = np.cos(yaw), np.sin(yaw)
    out = pos.copy()
    out[:, 0] = c * pos[:, 0] - s * pos[:, 1]
    out[:, 1] = s * pos[:, 0] + c * pos[:, 1]
    return out, pts, float(np.angle(np.exp(1j * yaw)))


def _point_segment_distance(p_xy: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Horizontal distance of each point p_xy[i] (K, 2) to the segment a[i]-b[i] (K, 2)."""
    ab = b - a
    den = np.maximum((ab**2).sum(-1), 1e-300)
    ap = p_xy - a
    u = np.clip((ap * ab).sum(-1) / den, 0.0, 1.0)
    return np.linalg.norm(ap - u[..., None] * ab, axis=-1)


def distance_to_polyline(p_xy: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Exact horizontal distance of each point (K, 2) to a polyline (M, >=2), in O((K + M) log M).

    A dense reference (the simulator's truth: one vertex per sample) has ~10⁵-10⁶ segments, so the
    point-to-every-segment search costs K·M. Instead every segment is sampled at spacing ≤ h (its two
    ends included) into a KD tree [Bentley1975]. The nearest sample gives d0 ≥ d (the true distance);
    the segment holding the closest polyline point has a sample within d + h/2 ≤ d0 + h/2 of the query, so
    the exact point-to-segment distance over the segments of the samples in that ball is the true
    minimum, computed with the same arithmetic as a brute-force search.

    Parameters
    ----------
    p_xy : (K, 2) array
        Query points (x, y), m.
    poly : (M, >=2) array
        Polyline vertices; only x and y are used.

    Returns
    -------
    (K,) array
        Distance of each point to the nearest segment, m.
    """
    from scipy.spatial import cKDTree

    p_xy = np.asarray(p_xy, float)[:, :2]
    v = np.asarray(poly, float)[:, :2]
    if len(p_xy) == 0:
        return np.zeros(0)
    if len(v) == 1:
        return np.linalg.norm(p_xy - v[0], axis=1)
    a, b = v[:-1], v[1:]
    seg_len = np.hypot(*(b - a).T)
    h = max(float(seg_len.sum()) / 20_000, 1e-3)  # ≤ 20000 extra samples on a sparse (waypoint) reference
    n_sub = np.maximum(np.ceil(seg_len / h), 1).astype(np.int64)  # sub-intervals per segment
    seg_of = np.repeat(np.arange(len(a)), n_sub + 1)
    first = np.concatenate(([0], np.cumsum(n_sub + 1)[:-1]))
    frac = (np.arange(len(seg_of)) - np.repeat(first, n_sub + 1)) / np.repeat(n_sub, n_sub + 1)
    samples = a[seg_of] + frac[:, None] * (b - a)[seg_of]
    tree = cKDTree(samples)
    d0, _ = tree.query(p_xy)
    step = float((seg_len / n_sub).max())
    balls = tree.query_ball_point(p_xy, (d0 + step / 2) * (1 + 1e-9) + 1e-12)
    counts = np.fromiter(map(len, balls), np.int64, len(balls))  # >= 1: the nearest sample is in its ball
    point = np.repeat(np.arange(len(p_xy)), counts)
    seg = seg_of[np.concatenate(balls).astype(np.int64)]
    dist = _point_segment_distance(p_xy[point], a[seg], b[seg])
    return np.minimum.reduceat(dist, np.concatenate(([0], np.cumsum(counts)[:-1])))


def compute_metrics(ref: Reference, t_s: np.ndarray, pos_n: np.ndarray, stance: np.ndarray,
                    mount: str | None = None, min_stride_m: float = 0.0) -> dict:
    """Table 1 metrics + closure (definitions in the module docstring). Keys end in _m or _pct.

    The estimated distance counts the same strides as the path summary (moves >= ``min_stride_m``,
    ``strides.stride_footprints``)."""
    t_s = np.asarray(t_s, float)
    aligned, ref_pts, yaw = align_to_reference(ref, t_s, pos_n)
    _, fp = footprints(t_s, aligned, stance)
    out: dict = {"reference_kind": ref.kind, "reference_source": ref.source,
                 "alignment_yaw_rad": yaw, "alignment_rule": "start + heading at first sample >= 0.8 m"}
    if len(fp) < 2:
        raise InputError("reference metrics need at least 2 stance phases in the estimate")
    d = np.diff(fp[stride_footprints(fp, min_stride_m)], axis=0)
    l_est = float(np.hypot(d[:, 0], d[:, 1]).sum())
    c = fp[-1] - fp[0]
    out.update(
        distance_est_m=l_est,
        closure_h_m=float(np.hypot(c[0], c[1])),
        closure_v_m=float(abs(c[2])),
        closure_3d_m=float(np.linalg.norm(c)),
        closure_pct=float(100 * np.linalg.norm(c) / l_est) if l_est > 0 else float("nan"),
    )
    if ref.kind == "closed_loop":
        if ref.approx_length_m:
            out["distance_ref_approx_m"] = ref.approx_length_m
        return out
    if ref.kind == "strides":
        out.update(stride_metrics(ref, t_s, np.asarray(pos_n, float), mount))
        return out
    l_ref = ref.length_m
    pct = lambda m: float(100.0 * m / l_ref) if l_ref else float("nan")  # noqa: E731
    dev = distance_to_polyline(fp[:, :2], ref_pts)
    dz_est = float(fp[-1, 2] - fp[0, 2])
    dz_ref = float(ref_pts[-1, 2] - ref_pts[0, 2]) if ref.has_z else 0.0
    h_err = abs(dz_est - dz_ref)
    out.update(
        distance_ref_m=l_ref,
        distance_diff_m=l_est - l_ref,
        distance_error_m=abs(l_est - l_ref),
        distance_error_pct=pct(abs(l_est - l_ref)),
        deviation_error_m=float(dev.max()),
        deviation_error_pct=pct(float(dev.max())),
        deviation_mean_m=float(dev.mean()),
        deviation_final_m=float(dev[-1]),
        final_error_m=float(np.hypot(*(fp[-1, :2] - ref_pts[-1, :2]))),
        height_est_m=dz_est,
        height_ref_m=dz_ref,
        height_error_m=h_err,
        height_error_pct=pct(h_err),
    )
    if abs(dz_ref) > 0.1:
        out["height_error_pct_of_climb"] = float(100 * h_err / abs(dz_ref))
    if ref.t_s is not None:
        inside = (ref.t_s >= t_s[0]) & (ref.t_s <= t_s[-1])
        if inside.sum() >= 2:
            est = np.column_stack([np.interp(ref.t_s[inside], t_s, aligned[:, k]) for k in range(3)])
            delta = est - ref_pts[inside]
            h = np.hypot(delta[:, 0], delta[:, 1])
            out.update(
                mean_h_err_m=float(h.mean()),
                armse_2d=float(np.sqrt((delta[:, 0] ** 2 + delta[:, 1] ** 2) / 2).mean()),
                mean_v_err_m=float(np.abs(delta[:, 2]).mean()),
                final_h_err_m=float(h[-1]),
            )
    return out
