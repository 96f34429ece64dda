"""Strides, distance, closure and floors from a ZUPT trajectory and its stance mask.

A foot-mounted sensor sees one *stride* per stance phase: the foot rests, swings, rests again. Stance
phase ``k`` is a maximal run of ``stance == True``; its *footprint* is the mean nav-frame position over
the run (after ZUPT/smoothing the foot is still there, so the mean only removes sample noise).
Stride ``k`` (k >= 1) goes from footprint ``k-1`` to footprint ``k``:

* ``t_s``: mid time of stance phase ``k``;
* ``x_m, y_m, z_m``: footprint ``k`` (ENU, origin at the start of the recording);
* ``stride_length_m``: horizontal distance ``‖(Δx, Δy)‖`` (the convention of the datasets' METRICS.md);
* ``dz_m``: height change ``Δz`` (stairs: riser height × steps per stride);
* ``yaw_enu_rad``: ``atan2(Δy, Δx)``, direction of the stride counter-clockwise from x (east)
  (``bootnav.CONVENTIONS["heading"]``; files add ``heading_deg_cw_from_north``).

Distance = Σ stride lengths (horizontal; ``distance_3d_m`` also reported). Closure (METRICS.md
``closed_loop``): footprint of the last stance phase minus that of the first; ``closure_pct = 100 ·
closure_3d_m / distance_m``.

Floors (the paper's stairs walk [Heidari2019, Chart 7], with no flat-floor assumption): the footprint
height relative to the first footprint is turned into an integer floor level with hysteresis. Level ``L``
goes up when ``z > (L + ½)·h + hyst`` and down when ``z < (L − ½)·h − hyst`` (``h`` = floor height): a
landing halfway or a few centimetres of vertical drift never toggle the count. Floors climbed = number of
up transitions, descended = number of down transitions.

Every stride row also carries (``footprint_strides``):

* ``floor``: the integer floor level of its footprint (the rule above, on the footprint heights relative to
  the first footprint), so a stride's floor is known when it is written (the same rule runs live);
* ``ellipse_major_m``, ``ellipse_minor_m``, ``ellipse_orientation_rad`` (when the path carries its position
  covariance): the horizontal 1-σ error ellipse of the footprint (``ellipse``): semi-axes in m, orientation
  of the major axis in rad counter-clockwise from x (east), ENU, in (−π/2, π/2] (the convention of
  ``yaw_enu_rad``). The covariance is the filter's at the last sample of the stance phase: the segment
  smoother ends every segment there on the filtered estimate (``ins/smoother.py``), so there the smoothed
  covariance equals the filtered one. The 2σ ellipse is twice as large (86.5 % of a consistent 2-D
  Gaussian inside, 39.3 % inside 1σ).

Optional stair gating (``stair_min_dz_m``): the height signal is then the running sum of only those stride
height changes with |Δz| ≥ ``stair_min_dz_m``. A stair stride climbs two risers (≈ 0.3 m), while the
vertical drift of a ZUPT INS adds millimetres per flat stride; gating removes hours of slow drift from the
floor count. The price: a gentle ramp (|Δz| per stride below the gate) never counts as a floor.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from bootnav.core.arrays import GrowingRows
from bootnav.core.runs import runs

STEP_COLUMNS = ("t_s", "x_m", "y_m", "z_m", "stride_length_m", "dz_m", "yaw_enu_rad")
FLOOR_COLUMN = "floor"
ELLIPSE_COLUMNS = ("ellipse_major_m", "ellipse_minor_m", "ellipse_orientation_rad")


def ellipse(cov_ee, cov_nn, cov_en) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Horizontal 1-σ error ellipse of 2×2 covariances [[P_EE, P_EN], [P_EN, P_NN]] (m², arrays of any shape).

    Returns the semi-major and semi-minor axes (m; the square roots of the eigenvalues
    λ = (P_EE + P_NN)/2 ± √(((P_EE − P_NN)/2)² + P_EN²)) and the orientation of the major axis, rad
    counter-clockwise from east (ENU), θ = ½ atan2(2 P_EN, P_EE − P_NN) in (−π/2, π/2] (0 for a circle).
    """
    a, b, c = (np.asarray(v, float) for v in (cov_ee, cov_nn, cov_en))
    mean, half = 0.5 * (a + b), np.hypot(0.5 * (a - b), c)
    return (np.sqrt(np.maximum(mean + half, 0.0)), np.sqrt(np.maximum(mean - half, 0.0)),
            0.5 * np.arctan2(2.0 * c, a - b))


def footprints(t_s: np.ndarray, pos_n: np.ndarray, stance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mid time (K,) and mean position (K, 3) of each stance phase, i.e. run of True in ``stance``
    (vectorised with cumulative sums)."""
    starts, stops = runs(stance)
    if starts.size == 0:
        return np.zeros(0), np.zeros((0, 3))
    csum = np.vstack((np.zeros((1, 3)), np.cumsum(pos_n, axis=0)))
    n = (stops - starts)[:, None]
    mean = (csum[stops] - csum[starts]) / n
    t_mid = 0.5 * (t_s[starts] + t_s[stops - 1])
    return t_mid, mean


class FootprintAccumulator:
    """``footprints`` of a path pushed in consecutive chunks (bounded memory: one open stance phase).

    Each phase's sum of positions is accumulated chunk by chunk, so its mean equals ``footprints``' (a
    difference of cumulative sums over the whole path) to rounding (1e-12 m at hours of walking). Pushed with
    ``cov_h``, it keeps each phase's value at its last sample (``segment_strides``' ellipse covariances).
    """

    def __init__(self):
        self._t_mid, self._fp, self._cov = GrowingRows(1), GrowingRows(3), GrowingRows(3)  # 56 B per phase
        self._open_cov: np.ndarray | None = None
        self._open: tuple | None = None  # (first time, position sum, samples, last time) of the open phase
        self.first_stop_t: float | None = None  # time of the last sample of the first stance phase
        self.last_start_t: float | None = None  # time of the first sample of the last stance phase

    def push(self, t_s: np.ndarray, pos_n: np.ndarray, stance: np.ndarray, cov_h: np.ndarray | None = None) -> None:
        """Add consecutive samples (s, m ENU, bool; ``cov_h`` (m, 3): horizontal covariance P_EE, P_NN, P_EN, m²)."""
        m = len(t_s)
        if m == 0:
            return
        starts, stops = runs(stance)
        if self._open is not None and (starts.size == 0 or starts[0] > 0):
            self._close()  # the open phase ended with the previous chunk
        for a, b in zip(starts.tolist(), stops.tolist()):  # one iteration per stance phase, not per sample
            psum = pos_n[a:b].sum(axis=0)
            if a == 0 and self._open is not None:
                t0, s0, n0, _ = self._open
                self._open = (t0, s0 + psum, n0 + b, float(t_s[b - 1]))
            else:
                self._open = (float(t_s[a]), psum, b - a, float(t_s[b - 1]))
                self.last_start_t = float(t_s[a])
            if cov_h is not None:
                self._open_cov = np.array(cov_h[b - 1], float)
            if b < m:
                self._close()

    def _close(self) -> None:
        if self._open is None:
            return
        t0, psum, n, t1 = self._open
        self._t_mid.append(0.5 * (t0 + t1))
        self._fp.append(psum / n)
        if self._open_cov is not None:
            self._cov.append(self._open_cov)
            self._open_cov = None
        if self.first_stop_t is None:
            self.first_stop_t = t1
        self._open = None

    def finish(self) -> tuple[np.ndarray, np.ndarray]:
        """Mid times (K,) and footprints (K, 3), as ``footprints`` returns them."""
        self._close()
        return self.t_mid.copy(), self.fp.copy()

    @property
    def t_mid(self) -> np.ndarray:
        """Mid times of the closed phases so far (K,), s (a view)."""
        return self._t_mid.rows[:, 0]

    @property
    def fp(self) -> np.ndarray:
        """Footprints of the closed phases so far (K, 3), m (a view)."""
        return self._fp.rows

    @property
    def cov(self) -> np.ndarray:
        """Horizontal covariance at the last sample of each closed phase (K, 3), m², when pushed with ``cov_h``."""
        return self._cov.rows

    @property
    def walked_s(self) -> float:
        """From the end of the first stance phase to the start of the last one, s (``path_summary``)."""
        return 0.0 if self.first_stop_t is None else float(self.last_start_t - self.first_stop_t)


def stride_footprints(fp: np.ndarray, min_stride_m: float) -> np.ndarray:
    """Indices of the footprints that start or end a stride: the first, then each footprint at least
    ``min_stride_m`` (3-D) away from the last one kept.

    A weight shift or a foot settling while the walker stands moves the footprint by millimetres to a few
    centimetres; that is not a stride. Measuring from the last KEPT footprint means a slow shuffle of
    tiny moves still counts once its moves add up. One Python iteration per stance phase (not per sample).
    """
    if len(fp) == 0 or min_stride_m <= 0:
        return np.arange(len(fp))
    keep = [0]
    last = fp[0]
    for k in range(1, len(fp)):
        if np.linalg.norm(fp[k] - last) >= min_stride_m:
            keep.append(k)
            last = fp[k]
    return np.asarray(keep, dtype=np.int64)


def phase_ends(stance: np.ndarray) -> np.ndarray:
    """Index of the last sample of every stance phase (run of True), in order."""
    return runs(stance)[1] - 1


def segment_strides(t_s: np.ndarray, pos_n: np.ndarray, stance: np.ndarray, min_stride_m: float = 0.0,
                    flags: np.ndarray | None = None, floors: FloorSettings | None = None,
                    pos_sigma_n: np.ndarray | None = None, pos_cov_en: np.ndarray | None = None,
                    floor_z: np.ndarray | None = None, cov_extra: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """One row per stride (dict of equal-length arrays, keys ``STEP_COLUMNS``, plus ``quality_flags`` when
    ``flags`` is given).

    Parameters
    ----------
    t_s, pos_n, stance
        Sample times (s), positions (m, ENU) and the stance mask.
    min_stride_m
        Moves between stance phases shorter than this (m, 3-D) are not strides (``stride_footprints``).
    flags
        Optional per-raw-stride flag words (one per pair of consecutive stance phases,
        ``selftune.stride_quality``); a kept stride carries the OR of the raw strides it spans.
    floors
        Floor counting (module docstring): adds the ``floor`` column; None = FloorSettings().
    pos_sigma_n, pos_cov_en
        Optional per-sample position 1-σ (N, 3) and east-north covariance P_EN (N,), m and m²: add the
        ellipse columns (``ELLIPSE_COLUMNS``) from their values at the last sample of each stance phase.
    floor_z
        Optional (K,) height per stance phase to count floors from instead of the footprint heights (the
        storeys' climbed height, ``floors.StoreyResult.climbed_fp``).
    cov_extra
        Optional (K, 3) horizontal covariance (EE, NN, EN) per stance phase, m², added to the filter's
        (``ellipses.scale_error_covariance``: the sensor errors the filter does not model).
    """
    t_mid, fp = footprints(np.asarray(t_s, float), np.asarray(pos_n, float), stance)
    cov = None
    if pos_sigma_n is not None and pos_cov_en is not None:
        end = phase_ends(np.asarray(stance, bool))
        sig = np.asarray(pos_sigma_n, float)[end]
        cov = np.column_stack((sig[:, 0] ** 2, sig[:, 1] ** 2, np.asarray(pos_cov_en, float)[end]))
        if cov_extra is not None:
            cov = cov + np.asarray(cov_extra, float).reshape(-1, 3)
    return footprint_strides(t_mid, fp, min_stride_m, flags, floors, cov, floor_z)


def footprint_strides(t_mid: np.ndarray, fp: np.ndarray, min_stride_m: float = 0.0,
                      flags: np.ndarray | None = None, floors: FloorSettings | None = None,
                      cov_h: np.ndarray | None = None, floor_z: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """``segment_strides`` from the stance phases' mid times (K,) and footprints (K, 3); ``cov_h`` (K, 3):
    each footprint's horizontal covariance (P_EE, P_NN, P_EN), m², for the ellipse columns; ``floor_z`` (K,):
    the height to count floors from (default: the footprints')."""
    keep = stride_footprints(fp, min_stride_m)
    t_k, fp_k = t_mid[keep], fp[keep]
    d = np.diff(fp_k, axis=0)
    out = {
        "t_s": t_k[1:],
        "x_m": fp_k[1:, 0],
        "y_m": fp_k[1:, 1],
        "z_m": fp_k[1:, 2],
        "stride_length_m": np.hypot(d[:, 0], d[:, 1]),
        "dz_m": d[:, 2],
        "yaw_enu_rad": np.arctan2(d[:, 1], d[:, 0]),
    }
    fs = floors or FloorSettings()
    if floor_z is not None:
        out[FLOOR_COLUMN] = floor_levels(np.asarray(floor_z, float)[keep] - float(floor_z[0]), fs)[1:]
    else:
        z_rel = fp_k[:, 2] - fp[0, 2] if len(fp) else fp_k[:, 2]
        out[FLOOR_COLUMN] = floor_levels(floor_signal(z_rel, fs), fs)[1:]
    if cov_h is not None:
        c = np.asarray(cov_h, float)[keep[1:]].reshape(-1, 3)
        out.update(zip(ELLIPSE_COLUMNS, ellipse(c[:, 0], c[:, 1], c[:, 2])))
    if flags is not None:
        flags = np.asarray(flags)
        if len(keep) >= 2 and len(flags) == len(fp) - 1:
            out["quality_flags"] = np.bitwise_or.reduceat(flags, keep[:-1]).astype(np.uint8)
        else:
            out["quality_flags"] = np.zeros(max(len(keep) - 1, 0), np.uint8)
    return out


@dataclass
class FloorSettings:
    """Floor counting from cumulative height.

    The one home of these defaults: ``ProcessSettings.floor_*`` (what ``process`` and every other run
    uses) take theirs from here (the reasons are in its docstring).

    floor_height_m: storey height h (m); the paper's building is unknown, 3 m is a typical storey.
    stair_min_dz_m: None = count floors from the footprint height; a value (m) = from stair strides only
        (|Δz| >= this), see the module docstring; used only with ``storeys`` off (``floor_signal``).
    hysteresis_m: extra height beyond the half-storey boundary before a level change counts (m).
    storeys: keep the height on discrete storeys where the stairs say so (``floors``).
    riser_min_m, riser_max_m: range of a riser's height (m).
    """

    floor_height_m: float = 3.0
    hysteresis_m: float = 0.5
    stair_min_dz_m: float | None = 0.1
    storeys: bool = True
    riser_min_m: float = 0.15
    riser_max_m: float = 0.20

    def __post_init__(self):
        if not self.floor_height_m > 0:
            raise ValueError(f"floor_height_m must be > 0, got {self.floor_height_m}")
        if self.stair_min_dz_m is not None and not 0 < self.stair_min_dz_m < self.floor_height_m:
            raise ValueError(f"stair_min_dz_m must be None or in (0, floor_height_m), got {self.stair_min_dz_m}")
        if not 0 < self.riser_min_m < self.riser_max_m < self.floor_height_m:
            raise ValueError(f"riser_min_m, riser_max_m must satisfy 0 < min < max < floor_height_m, got "
                             f"{self.riser_min_m}, {self.riser_max_m}")
        if not isinstance(self.storeys, bool):
            raise ValueError(f"storeys must be true or false, got {self.storeys!r}")
        if not 0 <= self.hysteresis_m < self.floor_height_m / 2:
            raise ValueError(
                f"hysteresis_m must be in [0, floor_height_m/2) = [0, {self.floor_height_m / 2}), got {self.hysteresis_m}"
            )


def floor_signal(z_rel_m: np.ndarray, settings: FloorSettings) -> np.ndarray:
    """Height (m, relative to the first footprint) used for counting floors: the footprint height, or the
    running sum of stair-stride height changes when ``stair_min_dz_m`` is set and the storeys are off (with
    ``storeys`` the heights are already held on floors and landings, ``floors``: the gate's job is done, and
    it would count a kneel (a 0.1 m drop of the sensor) without the stand-up that follows in smaller moves)."""
    z = np.asarray(z_rel_m, float)
    if settings.stair_min_dz_m is None or settings.storeys or len(z) < 2:
        return z
    dz = np.diff(z)
    return np.concatenate(([0.0], np.cumsum(np.where(np.abs(dz) >= settings.stair_min_dz_m, dz, 0.0))))


def floor_levels(z_rel_m: np.ndarray, settings: FloorSettings) -> np.ndarray:
    """Integer floor level (0 = start) for each height sample, with hysteresis (see module docstring)."""
    h, hy = settings.floor_height_m, settings.hysteresis_m
    levels = np.zeros(len(z_rel_m), dtype=np.int64)
    level = 0
    # K footprints (one per stride), so a short Python loop is fine here.
    for i, z in enumerate(np.asarray(z_rel_m, float)):
        while z > (level + 0.5) * h + hy:
            level += 1
        while z < (level - 0.5) * h - hy:
            level -= 1
        levels[i] = level
    return levels


def count_floors(z_rel_m: np.ndarray, settings: FloorSettings) -> dict:
    """Floors climbed/descended and the final level from footprint heights relative to the start."""
    levels = floor_levels(floor_signal(z_rel_m, settings), settings)
    steps = np.diff(np.concatenate(([0], levels)))
    return {
        "floors_climbed": int(steps[steps > 0].sum()),
        "floors_descended": int(-steps[steps < 0].sum()),
        "final_floor": int(levels[-1]) if len(levels) else 0,
        "floor_height_m": settings.floor_height_m,
        "floor_hysteresis_m": settings.hysteresis_m,
        "floor_stair_min_dz_m": settings.stair_min_dz_m,
    }


def path_summary(t_s: np.ndarray, pos_n: np.ndarray, stance: np.ndarray, floors: FloorSettings,
                 min_stride_m: float = 0.0, floor_z: np.ndarray | None = None) -> dict:
    """Distance, closure, height and floors from stance phases (all in metres; see module docstring).

    Strides and distance count only moves of at least ``min_stride_m`` (``stride_footprints``); closure and
    heights use every footprint."""
    starts, stops = runs(stance)
    _, fp = footprints(np.asarray(t_s, float), np.asarray(pos_n, float), stance)
    walked = float(t_s[starts[-1]] - t_s[stops[0] - 1]) if starts.size else 0.0
    return footprint_summary(fp, floors, min_stride_m, walked, floor_z)


def footprint_summary(fp: np.ndarray, floors: FloorSettings, min_stride_m: float, walked_s: float,
                      floor_z: np.ndarray | None = None) -> dict:
    """``path_summary`` from the footprints (K, 3) and the time from the end of the first stance phase to the
    start of the last one (``walked_s``, s): what a chunked run keeps of the path (``FootprintAccumulator``)."""
    keep = stride_footprints(fp, min_stride_m)
    out: dict = {"stance_phases": int(len(fp)), "strides": max(int(len(keep)) - 1, 0)}
    if len(fp) < 2:
        out.update(distance_m=0.0, distance_3d_m=0.0)
        return out
    if len(keep) < 2:
        keep = np.array([0, len(fp) - 1])
    d = np.diff(fp[keep], axis=0)
    dist = float(np.hypot(d[:, 0], d[:, 1]).sum())
    closure = fp[-1] - fp[0]
    z_rel = fp[:, 2] - fp[0, 2]
    out.update(
        distance_m=dist,
        distance_3d_m=float(np.linalg.norm(d, axis=1).sum()),
        closure_h_m=float(np.hypot(closure[0], closure[1])),
        closure_v_m=float(abs(closure[2])),
        closure_3d_m=float(np.linalg.norm(closure)),
        closure_pct=float(100.0 * np.linalg.norm(closure) / dist) if dist > 0 else float("nan"),
        height_change_m=float(z_rel[-1]),
        height_max_m=float(z_rel.max()),
        height_min_m=float(z_rel.min()),
        mean_stride_length_m=float(np.hypot(d[:, 0], d[:, 1]).mean()),
        duration_walked_s=walked_s,
    )
    if floor_z is None:
        out.update(count_floors(z_rel, floors))
    else:  # the storeys' climbed height: already free of drift, counted as it is
        out.update(count_floors(np.asarray(floor_z, float) - float(floor_z[0]), replace(floors, stair_min_dz_m=None)))
    return out
